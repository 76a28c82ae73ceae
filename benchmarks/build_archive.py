"""Make (or remake) the committed archive of a suite: every built-in optimizer on every member.

    .venv/bin/python benchmarks/build_archive.py --suite smoke --runs 10

It runs ``vpid-bench -m suite=<suite> optimizer=<every optimizer of the vpid-bench
distribution> runs=<runs> archive=false report=false`` into a sweep folder (resumable: run the
same command again after an interruption), refuses to pack a sweep with a failed job or run,
then writes ``archive/<suite>/`` (manifest, records, optima, summary, IOH zip) and prints
the size of each file. Commit the folder together with the code that made it: the manifest
names the commit (``-dirty`` when the work tree had changes).
"""

from __future__ import annotations

import argparse
import datetime
import shlex
import subprocess
import sys
from pathlib import Path

from vpid_bench.plugins import Registry
from vpid_bench.report.load import load_records
from vpid_bench.report.pack import pack

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def builtin_optimizers() -> list[str]:
    """The optimizers registered by the vpid-bench distribution itself."""
    registry = Registry()
    return sorted(n for n in registry.optimizers
                  if registry.provenance("optimizer", n).get("distribution") == "vpid-bench")


def commit() -> str | None:
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True,
                             text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=ROOT, capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    return sha + ("-dirty" if dirty.strip() else "")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--suite", default="smoke",
                    help="the suite swept (or, with --problems, the archive's name)")
    ap.add_argument("--problems", default=None,
                    help="problems to sweep instead of a suite (comma-separated)")
    ap.add_argument("--optimizers", default=None,
                    help="optimizers to run (default: every built-in one)")
    ap.add_argument("--optima-only", action="store_true",
                    help="ship the instance optima alone (what target= stops at), no runs")
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--sweep", type=Path, default=None,
                    help="sweep folder (default: outputs/archive-<suite>)")
    ap.add_argument("--out", type=Path, default=None,
                    help="archive folder (default: archive/<suite> in the repository)")
    args = ap.parse_args()
    sweep = args.sweep or ROOT / "outputs" / f"archive-{args.suite}"
    out = args.out or ROOT / "archive" / args.suite
    which = f"problem={args.problems}" if args.problems else f"suite={args.suite}"
    argv = ["-m", which, "optimizer=" + (args.optimizers or ",".join(builtin_optimizers())),
            f"runs={args.runs}", "archive=false", "report=false", f"hydra.sweep.dir={sweep}"]
    command = "vpid-bench " + " ".join(shlex.quote(a) for a in argv)
    made_by = commit()  # before the sweep: the code that runs it
    print(command, flush=True)
    done = subprocess.run([str(BIN / "vpid-bench"), *argv], cwd=ROOT)
    loaded = load_records([sweep])
    if done.returncode != 0 or loaded.failures:
        print(f"not packed: the sweep did not end clean (exit {done.returncode}); "
              + "; ".join(loaded.failures[:5]), file=sys.stderr)
        return 1
    made_at = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    manifest = pack(sweep, args.suite, out, command=command, commit=made_by, made_at=made_at,
                    optima_only=args.optima_only)
    total = sum(f["bytes"] for f in manifest["files"].values())
    for name, f in manifest["files"].items():
        print(f"{out / name}: {f['bytes']:,} bytes, sha256 {f['sha256'][:16]}...")
    print(f"archive {out}: {manifest['runs']} runs of {len(manifest['optimizers'])} "
          f"optimizers on {len(manifest['problems'])} problems, {total:,} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
