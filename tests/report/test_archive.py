"""The archive: archived runs of built-in optimizers ranked beside a sweep's own runs, never
mixed in from another version of a problem, and read as untrusted input.

A small archive is made here from a real sweep (``random`` and ``centre`` on ``smoke_quarter``);
the archive shipped with the package is checked against the code in
``test_the_shipped_archive_*``.
"""

from __future__ import annotations

import gzip
import hashlib
import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from extras import limit, needs_archive_runs

sys.path.insert(0, str(Path(__file__).parents[1] / "sweeps"))
from sweep_helpers import run_cli  # noqa: E402

from vpid_bench.report import archive as report_archive  # noqa: E402
from vpid_bench.report.build import build_report  # noqa: E402
from vpid_bench.report.pack import pack  # noqa: E402
from vpid_bench.store import archive as arch  # noqa: E402
from vpid_bench.store import archive_records  # noqa: E402
from vpid_bench.store.archive_pack import compact_trace  # noqa: E402
from vpid_bench.store.archive_records import load_all, read_archive  # noqa: E402

SWEEP = ["report=false", "archive=false", "isolation=none", "problem=smoke_quarter"]


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> dict[str, Path]:
    """An archive of random and centre (3 runs) and a sweep of de1 (2 runs) on smoke_quarter."""
    root = tmp_path_factory.mktemp("archive")
    base = root / "base"
    done = run_cli(["-m", "optimizer=random,centre", "runs=3", *SWEEP,
                    f"hydra.sweep.dir={base}"], cwd=root)
    assert done.returncode == 0, done.stderr[-2000:]
    pack(base, "smoke", root / "archives" / "smoke", command="test", commit="abc123",
              made_at="2026-01-01T00:00:00+00:00")
    mine = root / "mine"
    done = run_cli(["-m", "optimizer=de1,random", "runs=2", *SWEEP,
                    f"hydra.sweep.dir={mine}"], cwd=root)
    assert done.returncode == 0, done.stderr[-2000:]
    return {"root": root, "archives": root / "archives", "mine": mine, "base": base}


def _report(made, tmp_path, archives, paths=None):
    return build_report(paths or [made["mine"]], tmp_path / "report", short=True,
                        archive=archives)


def _rows(report_dir: Path) -> list[dict[str, str]]:
    import csv

    with open(report_dir / "runs.csv", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def test_archived_runs_stand_beside_mine_on_shared_instances(made, tmp_path):
    report = _report(made, tmp_path, made["archives"])
    rows = _rows(tmp_path / "report")
    by_alg: dict[str, list[dict[str, str]]] = {}
    for r in rows:
        by_alg.setdefault(r["algorithm"], []).append(r)
    assert set(by_alg) == {"de1", "random", "centre"}
    # centre comes from the archive, only on the two instances this sweep ran (of three)
    assert sorted(r["instance"] for r in by_alg["centre"]) == \
        sorted(r["instance"] for r in by_alg["de1"])
    assert all("records.jsonl.gz" in r["file"] for r in by_alg["centre"])
    # the sweep's own random is kept: the archived random is not mixed in
    assert all("records.jsonl.gz" not in r["file"] for r in by_alg["random"])
    assert len(by_alg["random"]) == 2
    # the archived runs are judged against their instances' optima (shipped in the archive)
    assert all(float(r["rel_gap"]) >= 0 for r in by_alg["centre"])
    assert len(report.archive_notes) == 1
    assert "centre from the archive of suite smoke" in report.archive_notes[0]
    assert "commit abc123" in report.archive_notes[0]
    assert "from the archive" in report.report_md.read_text(encoding="utf-8")


def test_archive_false_leaves_the_archive_out(made, tmp_path):
    report = _report(made, tmp_path, False)
    assert {r["algorithm"] for r in _rows(tmp_path / "report")} == {"de1", "random"}
    assert report.archive_notes == []


def _rewrite(folder: Path, edit) -> None:
    """Apply ``edit`` to every archived record and re-hash the manifest (a consistent
    archive of another version of the problem)."""
    path = folder / arch.RECORDS
    lines = gzip.decompress(path.read_bytes()).decode().splitlines()
    recs = [json.loads(line) for line in lines]
    for r in recs:
        edit(r)
    with gzip.GzipFile(path, "wb", mtime=0) as fh:
        fh.write("".join(json.dumps(r) + "\n" for r in recs).encode())
    manifest = json.loads((folder / arch.MANIFEST).read_text())
    manifest["files"][arch.RECORDS]["sha256"] = hashlib.sha256(path.read_bytes()).hexdigest()
    (folder / arch.MANIFEST).write_text(json.dumps(manifest))


def _copy(made, tmp_path) -> Path:
    out = tmp_path / "archives"
    shutil.copytree(made["archives"], out)
    return out


def test_a_foreign_version_of_the_problem_is_refused_in_one_line(made, tmp_path):
    archives = _copy(made, tmp_path)

    def nudge(r):
        r["parameters"]["true"][0] *= 1 + 1e-6
    _rewrite(archives / "smoke", nudge)
    report = _report(made, tmp_path, archives)
    assert {r["algorithm"] for r in _rows(tmp_path / "report")} == {"de1", "random"}
    (line,) = report.archive_notes
    assert "smoke_quarter not used" in line and "true parameters differ" in line
    assert "never mixed in" in line and "\n" not in line


def test_another_plugin_version_is_refused(made, tmp_path):
    archives = _copy(made, tmp_path)

    def bump(r):
        r["problem"]["plugin"]["version"] = "9.9"
    _rewrite(archives / "smoke", bump)
    report = _report(made, tmp_path, archives)
    (line,) = report.archive_notes
    assert "plugin version differs" in line


def test_other_settings_are_not_compared(made, tmp_path):
    other = tmp_path / "other"
    done = run_cli(["optimizer=de1", "runs=2", *SWEEP, "problem.noise_level=0.1",
                    f"hydra.run.dir={other}"], cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    report = _report(made, tmp_path, made["archives"], [other])
    assert {r["algorithm"] for r in _rows(tmp_path / "report")} == {"de1"}
    (line,) = report.archive_notes
    assert "no archived runs of smoke_quarter with these settings" in line


def test_a_changed_records_file_is_refused(made, tmp_path):
    archives = _copy(made, tmp_path)
    path = archives / "smoke" / arch.RECORDS
    data = bytearray(path.read_bytes())
    data[-9] ^= 0xFF
    path.write_bytes(bytes(data))
    report = _report(made, tmp_path, archives)
    assert {r["algorithm"] for r in _rows(tmp_path / "report")} == {"de1", "random"}
    assert report.archive_notes == []  # an unusable archive is a failure of the report:
    (line,) = report.failures  # named once (a warning line, exit 1)
    assert "does not match the SHA-256" in line


def test_the_optima_alone_are_read_without_the_records_and_checked_the_same(
        made, tmp_path, monkeypatch):
    """What ``target=`` reads (``optima_only``): the same optima as the whole archive, no
    record parsed (the shipped archives' 8,265 records took 6.5 s, once per job), and a
    changed records file still refuses the archive."""
    whole = read_archive(made["archives"] / "smoke")
    with monkeypatch.context() as m:
        m.setattr(archive_records, "_read_records", lambda *a: pytest.fail("records were read"))
        alone = read_archive(made["archives"] / "smoke", optima_only=True)
        found, bad = load_all(made["archives"], {"smoke_quarter"}, optima_only=True)
    assert whole.records and alone.records == [] and bad == []
    assert alone.optima == whole.optima and [a.optima for a in found] == [whole.optima]
    archives = _copy(made, tmp_path)
    path = archives / "smoke" / arch.RECORDS
    data = bytearray(path.read_bytes())
    data[-9] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.raises(arch.ArchiveError, match="does not match the SHA-256"):
        read_archive(archives / "smoke", optima_only=True)


def test_target_certifies_from_the_optima_alone(made, monkeypatch, registry,
                                                 compose_config):
    from vpid_bench.build import build_problem_from_job
    from vpid_bench.spec import parse_job
    from vpid_bench.targets import certified_optima

    job = parse_job(compose_config([*SWEEP, "optimizer=random", "runs=3", "target=1e-8"]),
                    registry)
    monkeypatch.setattr(archive_records, "_read_records",
                        lambda *a: pytest.fail("records were read"))
    found = certified_optima(job, build_problem_from_job(job), made["archives"])
    assert sorted(found) == [0, 1, 2]


@pytest.mark.parametrize("damage, fragment", [
    (lambda f: (f / arch.MANIFEST).write_text("{not json"), "not readable JSON"),
    (lambda f: (f / arch.MANIFEST).write_text('{"schema": "x"}'), "not a vpid-bench archive"),
    (lambda f: (f / arch.MANIFEST).write_text("[" * 100000), "not readable JSON"),
    (lambda f: (f / arch.OPTIMA).unlink(), "missing or not a regular file"),
    (lambda f: ((f / arch.RECORDS).unlink(), (f / arch.RECORDS).symlink_to(f / arch.OPTIMA)),
     "missing or not a regular file"),
])
def test_a_damaged_archive_is_named_and_skipped(made, tmp_path, damage, fragment):
    archives = _copy(made, tmp_path)
    damage(archives / "smoke")
    report = _report(made, tmp_path, archives)
    assert {r["algorithm"] for r in _rows(tmp_path / "report")} == {"de1", "random"}
    (line,) = report.failures
    assert fragment in line and line.startswith("archive "), line


def test_a_records_file_that_inflates_past_the_limit_is_refused(made, tmp_path, monkeypatch):
    monkeypatch.setattr("vpid_bench.store.archive.MAX_RECORDS_BYTES", 1000)  # its one home
    report = _report(made, tmp_path, made["archives"])
    assert any("holds more than 1000 bytes" in n for n in report.failures)


def test_bad_lines_are_skipped_and_counted(made, tmp_path):
    archives = _copy(made, tmp_path)
    folder = archives / "smoke"
    path = folder / arch.RECORDS
    text = gzip.decompress(path.read_bytes()).decode()
    first = json.loads(text.splitlines()[0])
    first["run_index"] = -1
    text += "not json\n" + json.dumps(first) + "\n"
    path.write_bytes(gzip.compress(text.encode(), mtime=0))
    manifest = json.loads((folder / arch.MANIFEST).read_text())
    manifest["files"][arch.RECORDS]["sha256"] = hashlib.sha256(path.read_bytes()).hexdigest()
    (folder / arch.MANIFEST).write_text(json.dumps(manifest))
    report = _report(made, tmp_path, archives)
    (line,) = report.archive_notes
    assert "centre from the archive" in line and "2 bad archive line(s) skipped" in line


def test_a_report_of_the_archive_alone_needs_no_run(made, tmp_path):
    report = build_report([made["archives"] / "smoke"], tmp_path / "report", short=True)
    rows = _rows(tmp_path / "report")
    assert {r["algorithm"] for r in rows} == {"random", "centre"} and len(rows) == 6
    assert all(float(r["rel_gap"]) >= 0 for r in rows)  # the archive's optima judge them
    assert report.failures == []
    # the identifiability section uses the same optima as the rankings: it never says none
    md = " ".join(report.report_md.read_text().split())
    section = md.split("## Identifiability")[1]
    assert "no instance optimum was found" not in section
    assert "measured floor: median NoRE of the record optima x*" in section


def test_the_per_job_files_travel_so_an_archive_alone_has_its_bounds(made, tmp_path):
    folder = made["archives"] / "smoke"
    manifest = json.loads((folder / arch.MANIFEST).read_text())
    assert {f"jobs/smoke_quarter/{f}" for f in arch.JOB_FILES} <= set(manifest["files"])
    from vpid_bench.report.compute import compute

    data = compute([folder], True, 0.05, "random")
    assert data.bounds and all(v > 0 for v in data.bounds.values())  # the CRB norm
    assert data.estimator_floors  # the floors per estimator


@pytest.mark.parametrize("damage, fragment", [
    (lambda f: (f / "jobs" / "smoke_quarter" / "estimators.json").write_text("{}"),
     "does not match the SHA-256"),
    (lambda f: _add_listed(f, "jobs/../../escape/estimators.json"), "an unexpected file"),
    (lambda f: _add_listed(f, "jobs/smoke_quarter/evil.py"), "an unexpected file"),
])
def test_per_job_files_are_checked_like_the_rest(made, tmp_path, damage, fragment):
    archives = _copy(made, tmp_path)
    damage(archives / "smoke")
    with pytest.raises(arch.ArchiveError, match=fragment):
        read_archive(archives / "smoke")


def _add_listed(folder: Path, name: str) -> None:
    manifest = json.loads((folder / arch.MANIFEST).read_text())
    manifest["files"][name] = {"sha256": "0" * 64, "bytes": 1}
    (folder / arch.MANIFEST).write_text(json.dumps(manifest))


def test_a_damaged_archive_given_as_a_path_is_named(made, tmp_path):
    archives = _copy(made, tmp_path)
    (archives / "smoke" / arch.MANIFEST).write_text("{}")
    report = build_report([archives / "smoke", made["mine"]], tmp_path / "report", short=True)
    assert any("not a vpid-bench archive" in f for f in report.failures)


def test_packing_the_same_sweep_twice_gives_the_same_bytes(made, tmp_path):
    a = pack(made["base"], "smoke", tmp_path / "a", command="test", commit="abc123",
                  made_at="2026-01-01T00:00:00+00:00")
    assert a == json.loads((made["archives"] / "smoke" / arch.MANIFEST).read_text())
    rows = (tmp_path / "a" / arch.SUMMARY).read_text().splitlines()
    assert rows[0].startswith("problem,optimizer,runs,ok,metric")
    assert len(rows) == 1 + 2  # random and centre on smoke_quarter



def test_archived_traces_keep_their_improvements_and_lose_nothing(made):
    """An archive cuts each trace to the batches that improved its best (and the last one),
    with their batch numbers: every batch's best-so-far, and every hit in evaluations,
    batches and seconds, reads the same off the cut trace as off the record it came from."""
    import dataclasses

    from vpid_bench.report.anytime import run_hits
    from vpid_bench.report.load import load_records

    own = {r["run_id"]: r for r in load_records([made["base"]]).records}
    archived = read_archive(made["archives"] / "smoke").records
    cut = 0
    for rec in archived:
        full = own[rec["run_id"]]
        ev, best = full["trace"]["evaluations"], full["trace"]["best"]
        kept = rec["trace"]
        cut += len(kept["evaluations"]) < len(ev)
        assert kept["evaluations"][-1] == ev[-1] and kept["batch"][-1] == len(ev)
        for i in range(len(ev)):  # the step function at every batch
            j = int(np.searchsorted(kept["batch"], i + 1, side="right")) - 1
            assert kept["best"][j] == best[i]
            assert kept["evaluations"][j] <= ev[i]
        f_opt = min(best) / 1.005  # the run ends 0.5 % above it: the targets 1 to 1e-2 are hit
        row = {"run_id": rec["run_id"], "f_opt": f_opt, "status": "ok", "context": "c",
               "algorithm": "a", "evaluations": float(ev[-1]), "budget": rec["budget"],
               "run_time_s": 1.0}
        a, b = run_hits([full], [row]), run_hits([rec], [row])
        for field in dataclasses.fields(a[0])[2:]:  # budget, used, hits, ... in each cost
            np.testing.assert_array_equal(np.asarray(getattr(a[0], field.name), float),
                                          np.asarray(getattr(b[0], field.name), float))
        assert sum(np.isfinite(a[0].hits)) == 3
    assert cut  # random search does not improve every batch


def test_a_trace_is_cut_to_its_improvements():
    record = {"trace": {"evaluations": [20, 40, 60, 80, 100], "best": [None, 3.0, 3.0, 2.0, 2.0]},
              "timing": {"trace_s": [0.1, 0.2, 0.3, 0.4, 0.5]}}
    out = compact_trace(record)
    assert out["trace"] == {"evaluations": [40, 80, 100], "best": [3.0, 2.0, 2.0],
                            "batch": [2, 4, 5]}
    assert out["timing"]["trace_s"] == [0.2, 0.4, 0.5]
    assert "batch" not in record["trace"]  # the record itself is not changed
    assert compact_trace(out) == out  # a cut trace packed again keeps its batch numbers
    odd = {"trace": {"evaluations": [1, 2], "best": [1.0]}}  # not aligned: left as it is
    assert compact_trace(odd) == odd


# --- the archive shipped with the package ---------------------------------------------------

@pytest.fixture(scope="module")
def shipped():
    return read_archive(arch.default_root() / "smoke")


@needs_archive_runs
def test_the_runs_of_named_problems_are_the_same_read_alone(shipped):
    """What a report beside one job reads: the archive's runs of its problems only, each the
    same record as in the whole archive."""
    alone = read_archive(arch.default_root() / "smoke", problems={"smoke_quarter"})
    mine = [r for r in shipped.records if r["problem"]["name"] == "smoke_quarter"]
    assert 0 < len(alone.records) == len(mine) < len(shipped.records)
    assert [r["run_id"] for r in alone.records] == [r["run_id"] for r in mine]
    assert alone.optima == shipped.optima


@needs_archive_runs
def test_the_shipped_archive_holds_every_builtin_on_every_smoke_member(shipped, registry):
    builtins = {n for n in registry.optimizers
                if registry.provenance("optimizer", n).get("distribution") == "vpid-bench"}
    assert set(shipped.manifest["optimizers"]) == builtins
    assert shipped.problems == set(registry.suites()["smoke"])
    assert shipped.skipped == 0
    assert all(r["status"] == "ok" for r in shipped.records)
    runs = {(r["problem"]["name"], r["optimizer"]["name"]) for r in shipped.records}
    assert len(runs) == len(builtins) * len(shipped.problems)
    # every instance of every member has its optimum in the archive
    instances = {(r["problem"]["name"], r["instance"]["id"]) for r in shipped.records}
    assert instances <= {(o.problem, o.instance) for o in shipped.optima}


@needs_archive_runs
def test_the_shipped_archive_was_made_by_this_code(shipped, registry):
    """Each member's instances, built by the installed code, hold the archived data (true
    parameters and objective at the truth, to 1e-9): a change to a problem that moves its
    data fails here, and the archive must be rebuilt (tools/build_archive.py)."""
    from vpid_bench.params import build_dataclass

    seen = set()
    for rec in shipped.records:
        name, index = rec["problem"]["name"], rec["instance"]["index"]
        if (name, index) in seen or index > 1:
            continue
        seen.add((name, index))
        cls = registry.problem(name)
        problem = cls(build_dataclass(cls.Config, rec["problem"]["config"])).instance(index)
        assert problem.instance_id() == rec["instance"]["id"]
        assert report_archive._same_instance(
            {"parameters": {"true": problem.x_true.tolist()},
             "problem": {"info": problem.describe()}}, rec) is None, (name, index)
    assert len(seen) == 2 * len(shipped.problems)


@needs_archive_runs
def test_the_shipped_paper_optima_belong_to_this_codes_records(registry):
    """archive/paper certifies the optima that target= stops at on both designs of the
    paper's problem: 30 instances each, and the installed code's objective at each archived
    optimum (first two instances per design) is the archived value, to 1e-9."""
    from vpid_bench.params import build_dataclass

    paper = read_archive(arch.default_root() / "paper")
    assert paper.records == [] and paper.manifest["optima_only"] is True
    by_design: dict[str, list] = {}
    for o in paper.optima:
        by_design.setdefault(json.dumps(o.settings, sort_keys=True), []).append(o)
    assert len(by_design) == 2 and all(len(v) == 30 for v in by_design.values())
    cls = registry.problem("vehicle")
    for optima in by_design.values():
        config = build_dataclass(cls.Config, optima[0].settings)
        problem = cls(config)
        for i in range(2):
            inst = problem.instance(i)
            (o,) = [o for o in optima if o.instance == inst.instance_id()]
            f = float(inst.evaluate(np.array([o.x_opt]))[0])
            assert f == pytest.approx(o.f_opt, rel=1e-9)


def test_the_advice_section_is_written_from_an_archive_alone(made, tmp_path):
    """tools/archive_advice.py (the advice per family and budget of docs/study.md,
    regenerated from archive/vpid1) reads only the archive: per group the share
    solved at each rung the runs reached, the score table with intervals, who is not
    separated from the leader (a paired bootstrap over problem and instance), the caveats
    with the archive's own numbers."""
    import csv
    import os
    import subprocess

    root = Path(__file__).resolve().parents[2]
    out = tmp_path / "advice"
    done = subprocess.run(
        [sys.executable, str(root / "tools" / "archive_advice.py"),
         str(made["archives"] / "smoke"), "-o", str(out)],
        capture_output=True, text=True, timeout=limit(300), env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr[-2000:]
    md = (out / "advice.md").read_text(encoding="utf-8")
    assert "| optimizer | 10·D | score [95 % interval] |" in md  # 100·D: never reached
    assert "Not separated from the leader" in md and "3 instance(s) per problem" in md
    with open(out / "ladder.csv", encoding="utf-8") as fh:
        ladder = list(csv.DictReader(fh))
    assert {r["algorithm"] for r in ladder} == {"random", "centre"}
    # smoke_quarter's budget is 220 evaluations, 55·D: the rung at 100·D was not reached
    assert all(r["solved_at_100D"] == "nan" and r["solved_at_10D"] != "nan" for r in ladder)
    with open(out / "scores.csv", encoding="utf-8") as fh:
        scores = list(csv.DictReader(fh))
    assert all(float(r["score_lo"]) <= float(r["score_auc"]) <= float(r["score_hi"])
               for r in scores)


def test_the_advice_names_the_black_box_leader_apart_from_the_residual_users():
    """A problem without residuals cannot use ``lsq`` or ``de_lsq``: the advice also names the
    leader among the optimizers whose class does not set ``wants_residuals``, and who is not
    separated from it; an optimizer not installed here counts as black-box."""
    import importlib.util

    root = Path(__file__).resolve().parents[2]
    sys.path.insert(0, str(root / "tools"))
    try:
        spec = importlib.util.spec_from_file_location(
            "archive_advice", root / "tools" / "archive_advice.py")
        advice = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(advice)
    finally:
        sys.path.remove(str(root / "tools"))
    users = advice.residual_users(["lsq", "de_lsq", "de4", "cmaes", "not_installed_here"])
    assert users == {"lsq", "de_lsq"}
    # per-run AUC on (problem, instance): lsq best, cmaes and de4 apart by a clear margin
    pairs = [("p", str(i)) for i in range(12)]
    rng = np.random.default_rng(0)
    aucs = {"lsq": {k: 0.9 for k in pairs},
            "cmaes": {k: 0.5 + 0.01 * rng.standard_normal() for k in pairs},
            "de4": {k: 0.3 + 0.01 * rng.standard_normal() for k in pairs}}
    rows = [["all", "all", name] for name in ("lsq", "cmaes", "de4")]  # best first
    leader, others = advice.not_separated(aucs, rows, "all")
    assert leader == "lsq" and [o[0] for o in others] == ["cmaes", "de4"]
    box_leader, box_others = advice.not_separated(aucs, rows, "all", users)
    assert box_leader == "cmaes" and [o[0] for o in box_others] == ["de4"]
    assert box_others[0][1] > 0  # separated: the interval of cmaes - de4 lies above 0


@needs_archive_runs
# 15-20 s of CPU each (the whole archive read and tested): make test-slow checks both, and
# must run after a change to the advice's code or an archive; the default run keeps the
# advice's path on an archive of its own (test_the_advice_section_is_written_from_an_archive_
# alone)
@pytest.mark.slow
@pytest.mark.parametrize("suite", ["vpid1", "vpid1_10k"])
def test_the_committed_vpid1_advice_is_what_the_archive_gives(tmp_path, suite):
    """docs/study/<archive>-advice (quoted by docs/study.md and the README) is regenerated
    from archive/vpid1 (and archive/vpid1_10k, its 10,000·D rung) alone, byte for byte: the
    advice and its tables come from the shipped archive, and a rebuilt archive that changed
    them would fail here until the docs follow."""
    import os
    import subprocess

    root = Path(__file__).resolve().parents[2]
    if not (root / "archive" / suite / "manifest.json").is_file():
        pytest.skip(f"archive/{suite} is not in this checkout")
    out = tmp_path / "advice"
    done = subprocess.run(
        [sys.executable, str(root / "tools" / "archive_advice.py"), f"archive/{suite}",
         "-o", str(out)], cwd=root, capture_output=True, text=True, timeout=limit(600),
        env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr[-2000:]
    committed = root / "docs" / "study" / f"{suite}-advice"
    for name in ("advice.md", "ladder.csv", "scores.csv"):
        assert (out / name).read_text(encoding="utf-8") == \
            (committed / name).read_text(encoding="utf-8"), name


def test_the_advice_script_refuses_a_bad_archive_in_one_line(tmp_path):
    """No archive there: one ``error:`` line naming the folder and the file, no traceback."""
    import os
    import subprocess

    root = Path(__file__).resolve().parents[2]
    done = subprocess.run(
        [sys.executable, str(root / "tools" / "archive_advice.py"), str(tmp_path / "none")],
        capture_output=True, text=True, timeout=limit(120), env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert done.stderr.strip().splitlines() == [
        f"error: archive {tmp_path / 'none'}: manifest.json is not readable JSON "
        "(FileNotFoundError)"]


def test_the_10000_d_rung_holds_every_member_whose_evaluation_is_cheap():
    """archive/vpid1_10k is the archive's 10,000·D rung on the members whose evaluation is
    cheap (30-62 µs per candidate: the quarter cars, half cars and linear single-track
    members; the full cars cost 84-175 µs, the Magic Formula member 360): every one of them
    × every built-in × 15 instances, each run to 10,000·D with stop at the final target.
    Read from its manifest (the reader checks a manifest against its files, tests above)."""
    import json

    from vpid_bench.plugins import Registry

    root = Path(__file__).resolve().parents[2]
    if not (root / "archive" / "vpid1_10k" / "manifest.json").is_file():
        pytest.skip("archive/vpid1_10k is not in this checkout")
    full, rung = (json.loads((root / "archive" / name / "manifest.json").read_text())
                  for name in ("vpid1", "vpid1_10k"))
    registry = Registry()
    cheap = {"quarter car", "half car", "single-track lateral"}
    members = {m for m in registry.suites()["vpid1"] if registry.problem(m).family in cheap}
    builtins = sorted(n for n in registry.optimizers
                      if registry.provenance("optimizer", n).get("distribution") == "vpid-bench")
    assert len(members) >= 12 and set(rung["problems"]) == members
    assert rung["optimizers"] == builtins
    assert rung["runs"] == len(members) * len(builtins) * 15
    for name, p in rung["problems"].items():  # archive/vpid1's budgets are 1,000·D
        assert p["budget"] == 10 * full["problems"][name]["budget"], name
    assert "target=1e-08" in rung["command"] and "budget_per_dim=10000" in rung["command"]


@needs_archive_runs
def test_the_wheel_alone_certifies_and_the_report_says_what_to_install(tmp_path, monkeypatch):
    """The shipped archives' runs are a data distribution apart from the wheel: without it
    (``$VPID_BENCH_ARCHIVE_RUNS_DIR`` naming an empty folder) ``target=`` still finds every
    optimum, and reading the runs fails in one line that names the command to install them;
    with it (this environment: ``make install``) the runs are read from there."""
    from vpid_bench.store.archive import RECORDS, RUNS_DIR_ENV, located

    smoke = arch.default_root() / "smoke"
    assert not (smoke / RECORDS).exists()  # not in the code package
    assert located(smoke, RECORDS).is_file()  # in the installed data distribution
    archives, bad = load_all(None, {"smoke_quarter"}, optima_only=True)
    with_runs = [o for a in archives for o in a.optima]
    assert bad == [] and with_runs
    monkeypatch.setenv(RUNS_DIR_ENV, str(tmp_path))
    archives, bad = load_all(None, {"smoke_quarter"}, optima_only=True)
    assert bad == [] and [o for a in archives for o in a.optima] == with_runs
    with pytest.raises(arch.ArchiveError, match=r"records.jsonl.gz is missing .*make install"):
        read_archive(smoke)


def test_the_wheel_ships_no_archived_runs():
    """pyproject's package data of ``vpid_bench.archive`` lists no run file (they are in
    archive-runs/, whose own pyproject ships them)."""
    root = Path(__file__).parents[2]

    def package_data(pyproject: Path, package: str) -> str:
        lines = pyproject.read_text(encoding="utf-8").splitlines()
        return next(line for line in lines if line.startswith(f'"{package}" = ['))

    shipped = package_data(root / "pyproject.toml", "vpid_bench.archive")
    assert "manifest.json" in shipped and "optima.jsonl" in shipped
    assert "records" not in shipped and "ioh" not in shipped
    runs = package_data(root / "archive-runs" / "pyproject.toml", "vpid_archive_runs")
    assert "records.jsonl.gz" in runs and "ioh.zip" in runs


@pytest.mark.parametrize("replaced, said", [
    ([{"optimizers": ["nevergrad"], "commit": "c8332e2abcdef0123"}],
     "vpid-bench 0.1.0, commit abc; nevergrad's runs remade at commit c8332e2abcde"),
    ([{"optimizers": ["a", "b"]}, {"optimizers": ["c"], "commit": "d"}],
     "vpid-bench 0.1.0, commit abc; a, b's runs remade; c's runs remade at commit d"),
    ("junk", "vpid-bench 0.1.0, commit abc"),
    ([1, {"optimizers": "x"}, {"optimizers": [2, "\x1b[31m"]}], "vpid-bench 0.1.0, commit abc"),
])
def test_an_archive_names_the_sweeps_that_replaced_runs(replaced, said):
    """``made_by`` (what a report says of archived runs) names each sweep that remade some
    optimizers' runs (tools/build_archive.py --replace); an untrusted manifest's junk there
    is left out, never shown or raised."""
    from vpid_bench.store.archive_records import Archive

    manifest = {"vpid_bench_version": "0.1.0", "commit": "abc", "replaced": replaced}
    assert Archive(Path("."), "s", manifest, [], []).made_by == said
