"""Make (or remake) the committed archive of a suite: every built-in optimizer on every member.

    .venv/bin/python tools/build_archive.py --suite vpid1 --runs 15 --target 1e-8
    .venv/bin/python tools/build_archive.py --suite smoke --runs 30

Resumable: each stage is a ``vpid-bench`` sweep into a fixed folder, which skips the runs it
has recorded, so the same command again runs only what is missing. The stages, certify (with
``--target``), runs and pack: docs/sweeps.md, building an archive. Anything after ``--``
goes to both sweeps (e.g. a Hydra launcher). Commit the archive with the code that made it:
the manifest names the commit and command.

After a peer's code changed, ``--replace nevergrad`` makes only that optimizer's runs again
(the archive's own command, stopped at the archive's optima) and packs them with every other
run of the archive kept as it is:

    .venv/bin/python tools/build_archive.py --suite vpid1 --replace nevergrad
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import os
import re
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

from vpid_bench.analysis.optimum import optimum_key
from vpid_bench.job_analysis import SHARED_DIR
from vpid_bench.plugins import Registry
from vpid_bench.report.load import load_records
from vpid_bench.report.pack import pack, splice
from vpid_bench.store.archive import ARCHIVE_DIR_ENV, MANIFEST, RUN_FILES, ArchiveError, located
from vpid_bench.store.archive_records import read_archive
from vpid_bench.store.optimum import write_optimum_file

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
#: The optimizer and budget of the certify stage: ``lsq`` reaches every member's optimum
#: well within 100·D on the smoke suite's ladder (docs/protocol.md), and the job's polish
#: from the truth and from each run's best does the rest.
CERTIFY = ("lsq", 100)


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



def sweep(argv: list[str], env: dict[str, str] | None = None) -> bool:
    """Run ``vpid-bench <argv>`` (printed first); whether it ended clean (exit 0)."""
    print("vpid-bench " + shlex.join(argv), flush=True)
    return subprocess.run([str(BIN / "vpid-bench"), *argv], cwd=ROOT, env=env).returncode == 0


def clean(folder: Path, exit_ok: bool) -> bool:
    """Whether the sweep in ``folder`` ended clean (else one line on stderr says why)."""
    loaded = load_records([folder])
    if exit_ok and not loaded.failures:
        return True
    print(f"not packed: the sweep {folder} did not end clean; "
          + ("; ".join(loaded.failures[:5]) or "its command failed (see above)"),
          file=sys.stderr)
    return False


def seed_optima(certify: Path, runs_dir: Path) -> None:
    """Copy the certify sweep's optimum and per-problem files (bounds, floors per estimator)
    that the runs sweep's ``optima/`` lacks (their names key the record's data, not the
    optimizer), so its jobs do not polish each truth and floor again."""
    for sub in (Path("."), Path(SHARED_DIR)):
        source = certify / "optima" / sub
        if not source.is_dir():
            continue
        target = runs_dir / "optima" / sub
        target.mkdir(parents=True, exist_ok=True)
        for f in sorted(source.glob("*.json")):
            if f.is_file() and not f.is_symlink() and not (target / f.name).exists():
                shutil.copyfile(f, target / f.name)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 epilog="Arguments after -- go to both sweeps (e.g. a launcher).")
    ap.add_argument("--suite", default="smoke",
                    help="the suite swept (or, with --problems, the archive's name)")
    ap.add_argument("--problems", default=None,
                    help="problems to sweep instead of the whole suite (comma-separated)")
    ap.add_argument("--optimizers", default=None,
                    help="optimizers to run (default: every built-in one)")
    ap.add_argument("--optima-only", action="store_true",
                    help="ship the instance optima alone (what target= stops at), no runs")
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--target", type=float, default=None,
                    help="stop each run at this final target (certifies the optima first)")
    ap.add_argument("--budget-per-dim", type=int, default=None,
                    help="budget per parameter instead of each member's default (raises "
                         "problem.iterations so that the budget alone ends every run)")
    ap.add_argument("--sweep", type=Path, default=None,
                    help="the build's folder (default: outputs/archive-<suite>)")
    ap.add_argument("--out", type=Path, default=None,
                    help="archive folder (default: archive/<suite> in the repository)")
    ap.add_argument("--no-pack", action="store_true", help="run the sweeps, do not pack")
    ap.add_argument("--replace", default=None,
                    help="optimizers (comma-separated) whose runs are made again by the "
                         "archive's own command and replace theirs in it, every other run kept")
    ap.add_argument("extra", nargs="*", help="overrides for both sweeps (after --)")
    return ap.parse_args(argv)


@dataclasses.dataclass
class Built:
    """What :func:`build` did: whether it ended clean, the runs' sweep folder, the wall time
    of each stage (s) and the manifest it packed (``None`` when not packed)."""

    ok: bool
    runs_dir: Path
    seconds: dict[str, float]
    manifest: dict | None = None


def ship(out: Path, suite: str, manifest: dict) -> None:
    """Print each packed file's size; a shipped archive's runs move to their data
    distribution, ``archive-runs/`` (docs/sweeps.md)."""
    total = sum(f["bytes"] for f in manifest["files"].values())
    for name, f in manifest["files"].items():
        print(f"{out / name}: {f['bytes']:,} bytes, sha256 {f['sha256'][:16]}...")
    print(f"archive {out}: {manifest['runs']} runs of {len(manifest['optimizers'])} "
          f"optimizers on {len(manifest['problems'])} problems, {total:,} bytes")
    if Path(out).resolve().parent == (ROOT / "archive").resolve():
        home = ROOT / "archive-runs" / "vpid_archive_runs" / suite
        home.mkdir(parents=True, exist_ok=True)
        for name in RUN_FILES:
            (Path(out) / name).replace(home / name)
        print(f"its runs ({', '.join(RUN_FILES)}) moved to {home}")


#: An override the archive's command may hold (an untrusted manifest): ``key=value`` with a
#: dotted key, no Hydra key (a callback could name code to run), no ``+``/``~``, no ``_target_``.
PLAIN_OVERRIDE = re.compile(r"[A-Za-z][A-Za-z0-9_.]*=[^\s]*")


def rerun_argv(command: str, optimizers: str, runs_dir: Path, extra: list[str]) -> list[str]:
    """The archive's sweep ``command`` (``vpid-bench -m ...``, from its manifest) with only
    ``optimizers`` and its sweep folder ``runs_dir``; ``ValueError`` if it is not one."""
    words = shlex.split(command)
    plain = all(PLAIN_OVERRIDE.fullmatch(w) and "_target_" not in w and not w.startswith(
        "hydra") for w in words[2:] if not w.startswith("hydra.sweep.dir="))  # replaced below
    if words[:2] != ["vpid-bench", "-m"] or not plain or not any(
            w.startswith("optimizer=") for w in words):
        raise ValueError(f"the archive's command is not a vpid-bench sweep: {command[:200]!r}")
    given = tuple(f"{w.split('=', 1)[0]}=" for w in extra if "=" in w)
    keep = [w for w in words[2:] if not w.startswith(("optimizer=", "hydra.sweep.dir=", *given))]
    return ["-m", *keep, f"optimizer={optimizers}", f"hydra.sweep.dir={runs_dir}", *extra]


def replace(args: argparse.Namespace) -> Built:
    """Make the runs of ``args.replace`` again and splice them into the archive (``--out``,
    default ``archive/<suite>``): a copy of the archive as it was goes to ``<build>/before``,
    whose optima the sweep stops at (``target=``) and starts its ``optima/`` from."""
    out = (args.out or ROOT / "archive" / args.suite).resolve()
    base = (args.sweep or ROOT / "outputs" / f"replace-{args.suite}").resolve()
    before, runs_dir = base / "before" / args.suite, base / "runs"
    if not before.is_dir():  # the first invocation; a resumed one keeps its copy
        shutil.copytree(out, before, ignore=shutil.ignore_patterns(*RUN_FILES))
        for name in RUN_FILES:
            shutil.copyfile(located(out, name), before / name)
    archive = read_archive(before, optima_only=True)
    argv = rerun_argv(str(archive.manifest["command"]), args.replace, runs_dir, args.extra)
    for opt in archive.optima:  # no truth polished again (as seed_optima does)
        path = runs_dir / "optima" / (optimum_key(
            opt.problem, opt.settings or {}, opt.data.get("data"), opt.instance) + ".json")
        if not path.exists():
            write_optimum_file(path, opt.data)
    made_by, t0 = commit(), time.perf_counter()
    ok = sweep(argv, {**os.environ, ARCHIVE_DIR_ENV: str(before.parent)})
    seconds = {"runs": time.perf_counter() - t0}
    if args.no_pack or not clean(runs_dir, ok):
        return Built(ok and args.no_pack, runs_dir, seconds)
    t1, spliced = time.perf_counter(), base / "spliced" / args.suite
    shutil.rmtree(spliced, ignore_errors=True)
    made_at = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    manifest = splice(before, runs_dir, set(args.replace.split(",")), spliced, replacing={
        "optimizers": sorted(args.replace.split(",")), "command": "vpid-bench " + shlex.join(argv),
        "commit": made_by, "made_at": made_at})
    for name in [*manifest["files"], MANIFEST]:
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(spliced / name, out / name)
    seconds["pack"] = time.perf_counter() - t1
    ship(out, args.suite, manifest)
    print(f"the runs side by side: {BIN / 'python'} tools/compare_archives.py {before} {out}")
    return Built(True, runs_dir, seconds, manifest)


def build(args: argparse.Namespace) -> Built:
    """The stages (docs/sweeps.md, building an archive); each prints its command first."""
    base = (args.sweep or ROOT / "outputs" / f"archive-{args.suite}").resolve()
    out = args.out or ROOT / "archive" / args.suite
    which = f"problem={args.problems}" if args.problems else f"suite={args.suite}"
    budget = ([f"budget_per_dim={args.budget_per_dim}", "problem.iterations=1000000"]
              if args.budget_per_dim else [])
    made_by = commit()  # before the sweeps: the code that runs them
    env = None
    seconds: dict[str, float] = {}
    runs_dir = base / "runs" if args.target is not None else base
    t0 = time.perf_counter()
    if args.target is not None:
        certify, certified = base / "certify", base / "certified"
        opt, per_dim = CERTIFY
        ok = sweep(["-m", which, f"optimizer={opt}", f"runs={args.runs}",
                    f"budget_per_dim={per_dim}", "archive=false", "report=false",
                    f"hydra.sweep.dir={certify}", *args.extra])
        if not clean(certify, ok):
            return Built(False, runs_dir, seconds)
        pack(certify, args.suite, certified / args.suite, command="(certify stage)",
             commit=made_by, made_at="", optima_only=True)
        env = {**os.environ, ARCHIVE_DIR_ENV: str(certified)}
        seed_optima(certify, runs_dir)
        seconds["certify"] = time.perf_counter() - t0
    argv = ["-m", which, "optimizer=" + (args.optimizers or ",".join(builtin_optimizers())),
            f"runs={args.runs}", *budget,
            *([f"target={args.target!r}"] if args.target is not None else []),
            "archive=false", "report=false", f"hydra.sweep.dir={runs_dir}", *args.extra]
    t1 = time.perf_counter()
    ok = sweep(argv, env)
    seconds["runs"] = time.perf_counter() - t1
    if args.no_pack or not clean(runs_dir, ok):
        return Built(ok and args.no_pack, runs_dir, seconds)
    t2 = time.perf_counter()
    made_at = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    manifest = pack(runs_dir, args.suite, out, command="vpid-bench " + shlex.join(argv),
                    commit=made_by, made_at=made_at, optima_only=args.optima_only)
    seconds["pack"] = time.perf_counter() - t2
    ship(out, args.suite, manifest)
    return Built(True, runs_dir, seconds, manifest)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        built = replace(args) if args.replace else build(args)
    except (ArchiveError, ValueError, OSError) as exc:  # --replace: no usable archive there
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print("stages: " + ", ".join(f"{k} {v:.1f} s" for k, v in built.seconds.items()))
    return 0 if built.ok else 1


if __name__ == "__main__":
    sys.exit(main())
