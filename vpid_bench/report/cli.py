"""``vpid-bench-report DIR... [-o OUT]``: one report from the records below any folders, into
``OUT`` (one report, whole: it must hold a report or nothing). Exit status: 0 written and all
fine; 1 written with a failed job, run or unreadable record, or not written (``OUT`` keeps
the previous report); 2 a usage error or no record. SIGTERM and SIGHUP end it as Ctrl-C does
(one line, status 143, 129)."""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from .safe import clean


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="vpid-bench-report", description=(
        "Build a vpid-bench report (Markdown, HTML pages, CSV, LaTeX, PNG figures) from the run "
        "records below one or more sweep or job folders, merged."))
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
    """Console entry point ``vpid-bench-report``; returns (and exits with) the status."""
    from .. import interrupts

    if argv is None:  # the console command: SIGTERM and SIGHUP end it as Ctrl-C does
        interrupts.install()
    try:
        code = _main(argv)
    except KeyboardInterrupt:
        print("interrupted: no report written (its folder keeps the previous one, if any); "
              "run the same command again", file=sys.stderr)
        code = interrupts.exit_status()
    if argv is None:  # called as the console script
        sys.exit(code)
    return code


def _main(argv: Sequence[str] | None) -> int:
    args = _parser().parse_args(argv)
    missing = [str(p) for p in args.paths if not p.exists()]
    if missing:
        print(f"error: no such file or folder: {', '.join(missing)}", file=sys.stderr)
        return 2
    if not 0.0 < args.alpha < 1.0:
        print(f"error: --alpha={args.alpha} is not allowed: a number between 0 and 1",
              file=sys.stderr)
        return 2
    bad_out = check_output_dir(args.out, args.paths)
    if bad_out:
        print(f"error: -o {args.out} is not allowed: {bad_out}", file=sys.stderr)
        return 2
    from ..progress import Stages
    from .build import NoRecordsError, build_report

    try:
        report = build_report(args.paths, args.out, short=args.short, alpha=args.alpha,
                              baseline=args.baseline,
                              archive=False if args.no_archive else (args.archive_dir or True),
                              progress=None if args.short else Stages("report"))
    except NoRecordsError as exc:
        print(f"error: {clean(exc)}", file=sys.stderr)
        return 2
    except OSError as exc:  # the folder became unwritable, a full disk, a file-size limit
        print(f"error: the report could not be written into {clean(args.out)} "
              f"({clean(exc.strerror or type(exc).__name__)}); it keeps the previous report, "
              "if any", file=sys.stderr)
        return 1
    # every line below may quote records, archives or paths: cleaned (report.safe)
    for note in [*report.folder_notes, *report.archive_notes]:
        print(clean(note), file=sys.stderr)
    print(clean(report.headline, keep_newlines=True))
    print(f"\nreport: {clean(report.report_md)} ({report.n_records} run records)")
    if report.index_html is not None:
        print(f"html: {clean(report.index_html)} (open it in a browser; it works offline)")
    for line in report.failures:
        print(f"warning: {clean(line)}", file=sys.stderr)
    return 1 if report.failures else 0


def check_output_dir(out: Path, inputs: Sequence[Path] = ()) -> str | None:
    """Why ``out`` cannot hold the report (a file, a folder holding the records read or
    anything a report does not write, one not creatable or writable), or None; creates it."""
    from .build import foreign_entries

    if out.exists() and not out.is_dir():
        return "a folder (this is an existing file)"
    where = Path(os.path.abspath(out))
    for p in inputs:
        read = Path(os.path.abspath(p))
        if where == read or where in read.parents:
            return (f"a folder apart from the records read ({clean(p)} is in it): a report "
                    "replaces its folder whole")
    foreign = [] if out.is_symlink() else foreign_entries(out)
    if foreign:
        return ("a folder that holds a report or nothing: a report replaces its folder whole, "
                f"and this one holds {', '.join(clean(f) for f in foreign[:3])}"
                + (" ..." if len(foreign) > 3 else ""))
    try:
        out.mkdir(parents=True, exist_ok=True)
        for folder in {out, out if os.path.ismount(out) else where.parent}:
            with tempfile.TemporaryFile(dir=folder):  # the old report goes, the new one in
                pass
    except OSError as exc:
        return f"a folder you can create and write to ({exc.strerror or type(exc).__name__})"
    return None


if __name__ == "__main__":  # pragma: no cover
    main()
