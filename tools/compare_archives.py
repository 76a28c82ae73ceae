"""Two archives' runs side by side, run by run (problem, optimizer, run index): whether a
rebuild (another commit, launcher or machine) made the same runs.

    .venv/bin/python tools/compare_archives.py archive/vpid1 /tmp/vpid1-archive

Both archives are read through the archive reader (checksums, limits).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from vpid_bench.store.archive import ArchiveError
from vpid_bench.store.archive_records import read_archive


def runs(folder: Path) -> dict[tuple[str, str, int], dict]:
    """The archive's records by (problem, optimizer, run index)."""
    return {(r["problem"]["name"], r["optimizer"]["name"], int(r["run_index"])): r
            for r in read_archive(folder).records}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    ap.add_argument("--show", type=int, default=4, help="largest differences listed")
    args = ap.parse_args(argv)
    try:
        a, b = runs(args.a), runs(args.b)
    except ArchiveError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    both = sorted(set(a) & set(b))
    same = {"evaluations": 0, "stopped_by": 0}
    identical, gaps = 0, []
    for key in both:
        ra, rb = a[key]["result"], b[key]["result"]
        for field in same:
            same[field] += ra.get(field) == rb.get(field)
        fa, fb = float(ra["f_best"]), float(rb["f_best"])
        if fa == fb:
            identical += 1
        else:
            gaps.append((abs(fa - fb) / max(abs(fa), abs(fb)), key))
    gaps.sort(reverse=True)
    print(f"runs in both: {len(both)} (only in {args.a}: {len(set(a) - set(b))}, "
          f"only in {args.b}: {len(set(b) - set(a))})")
    print(f"same evaluations: {same['evaluations']}, same reason to stop: {same['stopped_by']}")
    print(f"best values bit-identical: {identical}; largest relative differences of the others:")
    for gap, key in gaps[:args.show]:
        print(f"  {gap:.1e}  {key[0]} {key[1]} run {key[2]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
