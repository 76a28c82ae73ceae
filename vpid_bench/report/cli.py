"""``vpid-bench-report DIR... [-o OUT]``: one report from any set of run records.

Merges the records below every given folder (sweeps, single jobs, record files) and writes
the report into ``OUT`` (default ``report`` in the current folder). Exit status: 0 when the
report was written and every record and job was fine, 1 when it was written but some job or
run failed or some record was unreadable, 2 for a usage error or when no record was found.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from .safe import clean


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="vpid-bench-report",
        description="Build a vpid-bench report (Markdown, HTML pages, CSV, LaTeX, PNG figures) "
        "from the run records below one or more sweep or job folders, merged.",
    )
    p.add_argument("paths", nargs="+", type=Path, metavar="DIR",
                   help="sweep folders, job folders or record files (any number)")
    p.add_argument("-o", "--out", type=Path, default=Path("report"),
                   help="output folder (default: ./report)")
    p.add_argument("--short", action="store_true",
                   help="skip the significance tests and critical-difference diagrams")
    p.add_argument("--alpha", type=float, default=0.05,
                   help="significance level after Holm correction (default 0.05)")
    p.add_argument("--no-archive", action="store_true",
                   help="leave out the archived runs of the built-in optimizers (by default "
                   "they are ranked beside runs on a suite's problems)")
    p.add_argument("--archive-dir", type=Path, default=None, metavar="DIR",
                   help="read archives from DIR instead of those shipped with vpid-bench")
    p.add_argument("--baseline", default="random",
                   help="optimizer name of the baseline to clear (default: random)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point ``vpid-bench-report``; returns (and exits with) the status. Ctrl-C
    is one line and status 130 (a report half written is left as it is; run it again)."""
    try:
        return _main(argv)
    except KeyboardInterrupt:
        print("interrupted: the report is not complete; run the same command again",
              file=sys.stderr)
        return _exit(130, argv)


def _main(argv: Sequence[str] | None) -> int:
    args = _parser().parse_args(argv)
    missing = [str(p) for p in args.paths if not p.exists()]
    if missing:
        print(f"error: no such file or folder: {', '.join(missing)}", file=sys.stderr)
        return _exit(2, argv)
    if not 0.0 < args.alpha < 1.0:
        print(f"error: --alpha={args.alpha} is not allowed: a number between 0 and 1",
              file=sys.stderr)
        return _exit(2, argv)
    bad_out = check_output_dir(args.out)
    if bad_out:
        print(f"error: -o {args.out} is not allowed: {bad_out}", file=sys.stderr)
        return _exit(2, argv)
    from ..progress import Stages
    from .build import NoRecordsError, build_report

    try:
        report = build_report(args.paths, args.out, short=args.short, alpha=args.alpha,
                              baseline=args.baseline,
                              archive=False if args.no_archive else (args.archive_dir or True),
                              progress=None if args.short else Stages("report"))
    except NoRecordsError as exc:
        print(f"error: {clean(exc)}", file=sys.stderr)
        return _exit(2, argv)
    except OSError as exc:  # the folder checked above became unwritable, or a full disk
        print(f"error: the report could not be written into {clean(args.out)} "
              f"({exc.strerror or type(exc).__name__})", file=sys.stderr)
        return _exit(1, argv)
    # every line below may quote records, archives or paths: cleaned (report.safe)
    for note in report.archive_notes:
        print(clean(note), file=sys.stderr)
    print(clean(report.headline, keep_newlines=True))
    print(f"\nreport: {clean(report.report_md)} ({report.n_records} run records)")
    if report.index_html is not None:
        print(f"html: {clean(report.index_html)} (open it in a browser; it works offline)")
    for line in report.failures:
        print(f"warning: {clean(line)}", file=sys.stderr)
    return _exit(1 if report.failures else 0, argv)


def check_output_dir(out: Path) -> str | None:
    """Why ``out`` cannot hold the report (an existing file, a device such as /dev/null, a
    folder that cannot be created or written), or None. Creates the folder."""
    if out.exists() and not out.is_dir():
        return "a folder (this is an existing file)"
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out):
            pass
    except OSError as exc:
        return f"a folder you can create and write to ({exc.strerror or type(exc).__name__})"
    return None


def _exit(code: int, argv: Sequence[str] | None) -> int:
    if argv is None:  # called as the console script
        sys.exit(code)
    return code


if __name__ == "__main__":  # pragma: no cover
    main()
