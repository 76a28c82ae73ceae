"""Plugin report sections through the hook, the short (single-job) mode, and untrusted
records: safe file names, escaped text, badly typed fields, no write outside -o."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest
from extras import limit
from report_synth import objective_job, record, write_job

from vpid_bench import hookimpl
from vpid_bench.plugins import Registry
from vpid_bench.report.build import build_report
from vpid_bench.report.safe import escape
from vpid_bench.report.sections import Contribution, HeadlineColumn, Section
from vpid_bench.store.artifacts import BadArtifactError, read_best_signals, write_best_signals
from vpid_bench.store.paths import slug


def _toy_plugin(calls: list) -> types.SimpleNamespace:
    """A third-party problem plugin contributing sections for problem ``toy``: one good (a
    table, a figure, a headline column), one that raises, one returning a file outside."""

    def good(ctx):
        calls.append((ctx.problem, len(ctx.rows), ctx.short))
        rows = [[r["algorithm"], r["f_best"]] for r in ctx.rows if r["status"] == "ok"]
        files = ctx.write_table("toy/../../escape attempt", ["algorithm", "f"], rows)
        if not ctx.short:
            import matplotlib.pyplot as plt

            fig, ax = plt.subplots()
            ax.plot([0, 1], [1, 0])
            files.append(ctx.save_figure(fig, "toy figure"))
        best = {(r["context"], r["algorithm"]): -r["f_best"] for r in ctx.rows}  # last run
        return Contribution(
            sections=(Section("Toy section", ctx.markdown_table(["algorithm", "f"], rows),
                              tuple(files)),),
            headline=(HeadlineColumn("toy col", best),))

    def broken(ctx):
        raise RuntimeError("toy section exploded")

    def outside(ctx):
        return Contribution(sections=(Section("Outside", "x", (ctx.out_dir.parent / "x.csv",)),))

    @hookimpl
    def vpid_bench_register_report_sections(register):
        register("toy", good)
        register("toy", broken)
        register("toy", outside)
        register("nothing_ran", broken)  # never called: no record of that problem

    return types.SimpleNamespace(vpid_bench_register_report_sections=(
        vpid_bench_register_report_sections))


@pytest.fixture
def toy_registry(registry_of):
    calls: list = []
    return registry_of(("toyplug", _toy_plugin(calls))), calls


@pytest.mark.parametrize("short", [False, True])
def test_a_plugin_contributes_sections_through_the_hook(tmp_path, toy_registry, short):
    registry, calls = toy_registry
    objective_job(tmp_path / "s", "a", 10, [1.0, 2.0, 3.0, 4.0, 5.0])
    objective_job(tmp_path / "s", "b", 10, [2.0, 3.0, 4.0, 5.0, 6.0])
    rep = build_report([tmp_path / "s"], tmp_path / "out", short=short, registry=registry)
    assert calls == [("toy", 10, short)]
    md = rep.report_md.read_text()
    assert "## Toy section" in md and "toy col" in md
    table = tmp_path / "out" / "tables" / "toy_escape_attempt.csv"
    assert table.is_file() and "algorithm,f" in table.read_text()
    assert (tmp_path / "out" / "tables" / "toy_escape_attempt.csv") in rep.files
    assert ((tmp_path / "out" / "figures" / "toy_figure.png").is_file()) is (not short)
    assert not (tmp_path / "x.csv").exists()
    errors = " ".join(rep.failures)
    assert "toy section exploded" in errors and "outside the report folder" in errors
    assert "## Outside" in md  # the section stays, its outside file is dropped
    head = (tmp_path / "out" / "tables" / "headline.csv").read_text()
    assert "toy col" in head.splitlines()[0] and head.splitlines()[1].endswith(",-5.0")
    # the same section on the problem's HTML page: its title, table, figure and files
    page = (tmp_path / "out" / "problem-toy.html").read_text()
    assert "<h2>Toy section</h2>" in page and "<h2>Outside</h2>" in page
    assert "<td>a</td>" in page  # a cell of the section's Markdown table
    assert 'href="tables/toy_escape_attempt.csv"' in page
    assert ('src="figures/toy_figure.png"' in page) is (not short)


def test_the_registry_collects_sections_in_plugin_order(toy_registry):
    registry, _ = toy_registry
    assert [p for p, _ in registry.report_sections["toy"]] == ["toyplug"] * 3
    assert set(registry.report_sections) == {"toy", "nothing_ran"}
    # The installed vehicle plugin registers its sections the same way.
    assert "vehicle" in Registry().report_sections


def test_slug_is_bounded_and_safe():
    for text in ("../../x", "a/b\\c", "..", ".", "", "x" * 500, "ü ö|<b>", "-.-"):
        s = slug(text)
        assert re.fullmatch(r"[A-Za-z0-9._=-]+", s), text
        assert ".." not in s and "/" not in s and len(s) <= 80 and not s.startswith(".")
    assert slug("x" * 500) != slug("x" * 499)  # long names keep a hash of the whole
    assert slug("vehicle ps=20") == "vehicle_ps=20"
    assert escape("a|b<i>&") == "a\\|b&lt;i&gt;&amp;"


def test_hostile_record_names_write_nothing_outside_the_output_folder(tmp_path):
    """A record naming "../../x" as its problem and HTML with pipes as its optimizer: every
    file lands inside -o, and the text is escaped in report.md."""
    src = tmp_path / "deep" / "er" / "src"
    recs = [record(problem="../../x", optimizer="../../y|<b>", ps=10, run_index=i,
                   x=np.ones(2), f=float(i + 1), names=["../p", "q|<i>"], true=np.ones(2),
                   metrics={"../m": 1.0 + i}) for i in range(5)]
    write_job(src / "job", recs)
    before = {p for p in tmp_path.rglob("*")}
    out = tmp_path / "deep" / "er" / "out"
    rep = build_report([src], out)
    after = {p for p in tmp_path.rglob("*")}
    new = after - before
    assert new and all(out == p or out in p.parents for p in new)
    assert all(out in Path(f).resolve().parents for f in rep.files)
    md = rep.report_md.read_text()
    assert "<b>" not in md and "&lt;b&gt;" in md and "y\\|&lt;b&gt;" in md


def test_a_badly_typed_record_is_skipped_with_one_line(tmp_path):
    job = objective_job(tmp_path / "s", "a", 10, [1.0, 2.0])
    path = sorted((job / "records").glob("run-*.json"))[0]
    data = json.loads(path.read_text())
    data["result"]["f_best"] = "small"
    path.write_text(json.dumps(data))
    rep = build_report([tmp_path / "s"], tmp_path / "out", short=True)
    assert rep.n_records == 1
    (line,) = [ln for ln in rep.failures if path.name in ln]
    assert line == f"unreadable record {path}: field result.f_best: expected a number"


HEAVY = ("pandas", "matplotlib", "seaborn", "scipy.stats", "statsmodels", "scikit_posthocs")


def test_short_mode_imports_nothing_heavy(tmp_path):
    """The callback's single-job report, in a fresh interpreter: no heavy module loaded,
    no figures, the command for the full report printed."""
    job = objective_job(tmp_path, "random", 20, [1.0, 3.0])
    failed = record(problem="toy", optimizer="random", ps=20, run_index=7, x=None, f=None,
                    names=["x1", "x2"], true=None, status="failed")
    write_job(job, [failed], status="failed_runs")
    code = (
        "import sys\n"
        "from pathlib import Path\n"
        "from vpid_bench.shell.callbacks import write_report\n"
        f"ok = write_report(Path({str(job)!r}), short=True)\n"
        f"print('RESULT', ok, sorted(m for m in {HEAVY!r} if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=limit(120))
    # Written (False only because the report lists the synthetic failed run), nothing heavy:
    assert "RESULT False []" in out.stdout, out.stdout + out.stderr
    assert (job / "report" / "report.md").is_file()
    assert "report with figures and statistics: vpid-bench-report" in out.stdout
    assert "1 problem(s) found" in out.stderr  # the failed run
    md = (job / "report" / "report.md").read_text()
    assert "(single job)" in md and "Statistical tests" not in md
    assert not (job / "report" / "figures").exists()


def test_best_signals_round_trip_and_refusals(tmp_path):
    from report_synth import OV
    from test_report_outputs import FakeConfig, FakeVehicle

    problem = FakeVehicle(FakeConfig())
    path = write_best_signals(tmp_path, problem, OV * 1.1, {"run_index": 3, "f_best": 0.5})
    sig = read_best_signals(path)
    ref = problem.signals(OV * 1.1)
    np.testing.assert_array_equal(sig.t, ref["t"])
    np.testing.assert_array_equal(sig.channels["z2''"][1], ref["z2'':fitted"])
    assert sig.units == {"t": "s", "z1''": "m/s²", "z2''": "m/s²"}
    assert sig.source == {"run_index": 3, "f_best": 0.5}
    assert not list(tmp_path.glob(".*.tmp"))  # written atomically, no temporary left
    with pytest.raises(BadArtifactError, match="more than 10"):
        read_best_signals(path, max_bytes=10)
    path.write_text(path.read_text().replace("z1'':fitted", "../../etc"))
    with pytest.raises(BadArtifactError, match="is not <channel>:measured"):
        read_best_signals(path)
    assert write_best_signals(tmp_path / "none", types.SimpleNamespace(
        signals=lambda x: None, name="n"), OV) is None


def test_a_vehicle_job_records_metrics_and_writes_its_best_signals(tmp_path, registry):
    from vpid_vehicle.config import VehicleConfig

    from vpid_bench.experiment import run_from_config
    from vpid_bench.params import hydra_node

    cfg = {
        "problem": hydra_node(VehicleConfig, "vehicle") | {"iterations": 1, "ps": 4},
        "optimizer": {"name": "random"},
        "seed": 0, "runs": 3, "progress": False, "report": False,
    }
    summary = run_from_config(cfg, tmp_path, registry=registry)
    recs = [json.loads(p.read_text()) for p in summary.record_paths]
    for r in recs:
        x, true = np.asarray(r["result"]["x_best"]), np.asarray(r["parameters"]["true"])
        assert r["result"]["metrics"]["NoRE"] == pytest.approx(
            np.linalg.norm(100 * (x - true) / true), rel=1e-12)
        assert "nore" not in r["result"]
    sig = read_best_signals(tmp_path / "best_signals.csv")
    best = min(recs, key=lambda r: r["result"]["metrics"]["NoRE"])
    assert sig.source["run_index"] == best["run_index"] and sig.source["ranked_by"] == "NoRE"
    assert set(sig.channels) == {"z1''", "z2''"} and sig.t.size == 480


def test_the_core_report_knows_no_problem():
    """No word of one problem (its name, its paper, its metric) in the core report's code."""
    import vpid_bench

    root = Path(vpid_bench.__file__).parent
    files = [*sorted((root / "report").glob("*.py")), root / "store" / "artifacts.py"]
    pattern = re.compile(r"\b(vehicles?|paper|nore)\b", re.IGNORECASE)
    hits = [f"{f.name}:{i}" for f in files
            for i, line in enumerate(f.read_text(encoding="utf-8").splitlines(), start=1)
            if pattern.search(line)]
    assert hits == []
