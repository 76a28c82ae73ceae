"""What a report costs: the full report of a sweep and the short report of one job, side by
side with the runs they report on; or an archive's report.

    .venv/bin/python benchmarks/bench_report.py [--repeats 3] [--records SWEEP_DIR]
    .venv/bin/python benchmarks/bench_report.py --archive ARCHIVE [--instances 15]

The full report of the paper experiment's records (made once into a temporary folder unless
``--records`` names a sweep) in a child process, beside the sweep's own time; a single job
(``runs=30``) with and without its short report; or (``--archive``) an archive's report
beside its 60 s target, and with ``--instances N`` that of the same runs copied to N
instances, each copy's values scaled by a factor in [1, 1.05) so the copies are not tied
(the measurements: docs/report.md and docs/sweeps.md).
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import statistics
import tempfile
from pathlib import Path

import numpy as np
from _shared import CLI, REPORT, run_timed

from vpid_bench.analysis.optimum import optimum_key, record_settings
from vpid_bench.report.pack import pack
from vpid_bench.store.archive import JOBS, MANIFEST, OPTIMA, RECORDS
from vpid_bench.store.archive_records import read_archive
from vpid_bench.store.records import stable_hash, write_json_atomic

#: What the report over archive/vpid1 may take on a quiet 2-core machine (issue 46), in s.
TARGET_S = 60.0
PAPER_SWEEP = ["-m", "optimizer=de1,de2,de3,de4,de5,de6,de7,de8,ga", "problem.ps=20,30",
               "runs=30", "progress=false", "report=false"]


def full_report(records: Path | None, repeats: int, tmp: Path) -> None:
    sweep_s = None
    if records is None:
        records = tmp / "sweep"
        sweep_s = run_timed([*CLI, *PAPER_SWEEP, f"hydra.sweep.dir={records}"])[0]
    times = [run_timed([*REPORT, str(records), "-o", str(tmp / f"report-{i}")])[0]
             for i in range(repeats)]
    print(f"full report of {records} ({repeats} repeats): median "
          f"{statistics.median(times):.2f} s  (all: {', '.join(f'{t:.2f}' for t in times)})")
    if sweep_s is not None:
        print(f"  the sweep it reports on (540 runs, report=false): {sweep_s:.2f} s")


def short_report(repeats: int, tmp: Path) -> None:
    times: dict[bool, list[float]] = {True: [], False: []}
    for i in range(repeats):
        for report in (True, False):
            times[report].append(run_timed([*CLI, "runs=30", "progress=false",
                                            f"report={str(report).lower()}",
                                            f"hydra.run.dir={tmp / f'job-{report}-{i}'}"])[0])
    on, off = statistics.median(times[True]), statistics.median(times[False])
    print(f"single job, runs=30 ({repeats} repeats each): report=true median {on:.2f} s, "
          f"report=false median {off:.2f} s; the short report adds {on - off:+.2f} s")


def scaled_archive(archive: Path, instances: int, tmp: Path) -> Path:
    """An archive of the runs of ``archive`` copied to ``instances`` instances each (see the
    module), packed by the real packer from a sweep folder written here."""
    sweep = tmp / "scaled-sweep"
    rng = np.random.default_rng(0)
    manifest = json.loads((archive / MANIFEST).read_text(encoding="utf-8"))
    with gzip.open(archive / RECORDS, "rt", encoding="utf-8") as fh:
        records = [json.loads(line) for line in fh if line.strip()]
    for rec in records:
        job = sweep / f"{rec['problem']['name']}-{rec['optimizer']['name']}"
        source = archive / JOBS / rec["problem"]["name"]
        for f in source.glob("*.json") if source.is_dir() else []:
            job.mkdir(parents=True, exist_ok=True)
            (job / f.name).write_bytes(f.read_bytes())
        for k in range(instances):
            c = 1.0 + 0.05 * rng.random()
            copy = json.loads(json.dumps(rec))
            index = int(rec["run_index"]) * instances + k  # apart from the others' copies
            copy["instance"] = {"id": f"{rec['instance']['id']}~{k}", "index": index}
            copy["run_index"] = index
            copy["run_id"] = stable_hash([rec["run_id"], k])
            res, trace = copy.get("result") or {}, copy.get("trace") or {}
            if isinstance(res.get("f_best"), float):
                res["f_best"] *= c
            trace["best"] = [b * c if isinstance(b, float) else b for b in trace.get("best") or []]
            write_json_atomic(job / "records" / f"run-{index:03d}-{copy['run_id']}.json", copy)
    for line in (archive / OPTIMA).read_text(encoding="utf-8").splitlines():
        opt = json.loads(line)
        for k in range(instances):
            copy = {**opt, "instance": f"{opt['instance']}~{k}"}
            key = optimum_key(opt["problem"], record_settings(opt["settings"]), opt.get("data"),
                              copy["instance"])
            write_json_atomic(sweep / "optima" / f"{key}.json", copy)
    out = tmp / "scaled-archive" / manifest["suite"]
    pack(sweep, manifest["suite"], out, command=f"scaled x{instances} from {archive}",
         commit=manifest.get("commit"), made_at="")
    return out


def archive_report(archive: Path, instances: int | None, tmp: Path) -> None:
    """The report of ``archive`` (nothing run), and of its scaled copy (see the module)."""
    load = os.getloadavg()[0]
    plain, plain_cpu = run_timed([*REPORT, str(archive), "-o", str(tmp / "report-archive")])
    n = len(read_archive(archive).records)
    print(f"report of the archive {archive} ({n} runs): {plain:.1f} s wall, "
          f"{plain_cpu:.1f} s CPU; target {TARGET_S:.0f} s wall on a quiet 2-core machine: "
          f"{plain / TARGET_S:.2f}x of it (load average {load:.1f} before, "
          f"{os.getloadavg()[0]:.1f} after: above 0.5 the machine was not quiet)")
    if instances:
        scaled = scaled_archive(archive, instances, tmp)
        big, big_cpu = run_timed([*REPORT, str(scaled), "-o", str(tmp / "report-scaled")])
        size = sum(f.stat().st_size for f in scaled.rglob("*") if f.is_file())
        print(f"report of it scaled to {instances} instances ({n * instances} runs, "
              f"{size / 1e6:.1f} MB): {big:.1f} s wall ({big / plain:.1f}x), "
              f"{big_cpu:.1f} s CPU")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--records", type=Path, default=None,
                    help="an existing sweep folder to report on (default: run the paper sweep)")
    ap.add_argument("--archive", type=Path, default=None,
                    help="time the report of this archive instead (and, with --instances, "
                         "of its copy scaled to that many instances)")
    ap.add_argument("--instances", type=int, default=None)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        if args.archive is not None:
            archive_report(args.archive, args.instances, Path(tmp))
            return
        full_report(args.records, args.repeats, Path(tmp))
        short_report(args.repeats, Path(tmp))


if __name__ == "__main__":
    main()
