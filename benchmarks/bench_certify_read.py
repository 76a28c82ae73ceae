"""What certifying a ``target=`` job's stops reads from the shipped archives: the whole
archives (records parsed and checked) against their optima alone (the records file checked
against its SHA-256, not parsed), side by side in one run.

    .venv/bin/python benchmarks/bench_certify_read.py [--problem vpid1_q_golden_hump] [--repeat 3]

Prints the median wall time of each read over ``--repeat`` timings, the records and optima each
read, and their ratio. ``target=`` reads the optima alone, once in the pre-flight and once per job.
"""

from __future__ import annotations

import argparse
import statistics
import time

from vpid_bench.store.archive_records import load_all


def timed(problem: str, optima_only: bool, repeat: int) -> tuple[float, int, int]:
    """Median seconds of ``load_all`` over the shipped archives holding ``problem``, and the
    records and optima it returned."""
    seconds = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        archives, _ = load_all(None, {problem}, optima_only=optima_only)
        seconds.append(time.perf_counter() - t0)
    return (statistics.median(seconds), sum(len(a.records) for a in archives),
            sum(len(a.optima) for a in archives))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--problem", default="vpid1_q_golden_hump")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    whole = timed(args.problem, False, args.repeat)
    alone = timed(args.problem, True, args.repeat)
    print("| read | s (median) | records | optima |")
    print("| --- | --- | --- | --- |")
    for name, (s, records, optima) in (("whole archives", whole), ("optima alone", alone)):
        print(f"| {name} | {s:.3f} | {records:,} | {optima} |")
    print(f"ratio: {whole[0] / max(alone[0], 1e-9):.0f}x")


if __name__ == "__main__":
    main()
