"""The report's identifiability section, built from a real small sweep on the vehicle (two
record designs, two population sizes), and what it does with bad files."""

from __future__ import annotations

import csv
import json
import shutil
import statistics

import numpy as np
import pytest
from vpid_vehicle.config import VehicleConfig, VehicleParams

from vpid_bench.analysis.optimum import load_optima, optimum_key
from vpid_bench.experiment import run_from_config
from vpid_bench.params import hydra_node
from vpid_bench.report.build import build_report
from vpid_bench.report.identifiability import UNDETERMINED_PERCENT, reference_levels
from vpid_bench.store.job_files import MAX_BYTES

RUNS = 3
SHORT, LONG = "vehicle record.extra=0", "vehicle record.extra=0.5"  # the designs' labels


@pytest.fixture(scope="module")
def sweep(tmp_path_factory, registry):
    """``<sweep>/{ps,extra}/records``, optima shared in ``<sweep>/optima``: the default
    design at ps 4 and 6, and the long record (record.extra = 0.5 s) at ps 4."""
    root = tmp_path_factory.mktemp("idsweep")
    for name, ps, extra in (("short4", 4, 0.0), ("short6", 6, 0.0), ("long4", 4, 0.5)):
        problem = hydra_node(VehicleConfig, "vehicle") | {"iterations": 1, "ps": ps}
        problem["record"] = {"extra": extra}
        cfg = {"problem": problem, "optimizer": {"name": "random"}, "seed": 0, "runs": RUNS,
               "progress": False, "report": False}
        run_from_config(cfg, root / name, registry, optima_dir=root / "optima")
    return root


@pytest.fixture(scope="module")
def full(sweep, tmp_path_factory, registry):
    """The full report of the sweep (figures included), built once."""
    out = tmp_path_factory.mktemp("idreport")
    return build_report([sweep], out, registry=registry)


def _csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _design_optima(root) -> dict[str, list[dict]]:
    """The optimum files of each design, by the file names the job gives them (the key of
    the problem, its settings without the protocol and the instance id)."""
    optima = load_optima([root / "optima"])
    out = {}
    for job, label in (("short4", SHORT), ("long4", LONG)):
        files = []
        for path in sorted((root / job / "records").glob("*.json")):
            rec = json.loads(path.read_text())
            key = optimum_key("vehicle", rec["problem"]["config"], None, rec["instance"]["id"])
            files.append(optima[key])
        out[label] = files
    return out


def test_the_section_per_design(sweep, full):
    md = full.report_md.read_text()
    tmp = full.out_dir
    words = " ".join(md.split())
    assert "## Identifiability" in md
    assert "σ_k = noise level × |z_k| for multiplicative noise" in words
    # the rounding rule and the bound's sensitivity to a sigma floor (multiplicative noise)
    assert "2 sample(s) with no or rounding-level noise" in words
    crb = json.loads((sweep / "short4" / "identifiability.json").read_text())
    floors = crb["sigma_floor_sensitivity"]
    assert ("the CRB norm is " + ", ".join(
        f"{e['crb_norm_percent']:.3g} % at {e['fraction']:g}" for e in floors)) in words
    instances = _csv(tmp / "tables" / "identifiability_instances.csv")
    assert len(instances) == 2 * RUNS  # per design, one row per instance
    assert {r["instance"] for r in instances} == {e["instance"] for e in crb["instances"]}
    rows = _csv(tmp / "tables" / "identifiability.csv")
    designs = {r["design"]: r for r in _csv(tmp / "tables" /
                                             "identifiability_designs.csv")}
    assert set(designs) == {SHORT, LONG}
    assert designs[SHORT]["contexts"] == (
        "vehicle ps=4 record.extra=0; vehicle ps=6 record.extra=0")
    # per context and parameter, the bound written by the job of that design
    for design, job in ((SHORT, "short4"), (LONG, "long4")):
        crb = json.loads((sweep / job / "identifiability.json").read_text())
        mine = [r for r in rows if r["design"] == design]
        assert len(mine) == len(crb["names"]) * len(designs[design]["contexts"].split("; "))
        for r in mine:
            j = crb["names"].index(r["parameter"])
            assert float(r["crb_percent"]) == pytest.approx(crb["crb_percent"][j], rel=1e-12)
        assert float(designs[design]["crb_norm_percent"]) == pytest.approx(
            crb["crb_norm_percent"], rel=1e-12)
        assert float(designs[design]["condition_number"]) == pytest.approx(
            crb["condition_number"], rel=1e-12)
        undetermined = [n for n, b in zip(crb["names"], crb["crb_percent"], strict=True)
                        if b > UNDETERMINED_PERCENT]
        text = md[md.index(f"Record design **{design}**"):][:800]
        for name in undetermined:
            assert f"{name} (" in text
        assert ("cannot determine" in text) == bool(undetermined)
    assert (tmp / "figures" / "identifiability_vehicle_record.extra=0.png").is_file()
    assert len(list((tmp / "figures").glob("identifiability_*.png"))) == 2


def test_the_floor_is_the_median_over_the_instances_of_each_design(sweep, tmp_path, registry):
    """Computed here from the optimum files and the records' instance ids, independently of
    the report: NoRE of x* per instance (the file's metric) and |x*_j - θ_j| / θ_j."""
    report = build_report([sweep], tmp_path / "r", registry=registry, short=True)
    designs = {r["design"]: r for r in _csv(tmp_path / "r" / "tables" /
                                             "identifiability_designs.csv")}
    rows = _csv(tmp_path / "r" / "tables" / "identifiability.csv")
    assert len(load_optima([sweep / "optima"])) == 2 * RUNS  # ps 4 and 6 share theirs
    names = ["m", "I", "m1", "m2", "k1", "k2", "c1", "c2", "a1"]
    theta = np.array([getattr(VehicleParams(), n) for n in names])
    by_design = _design_optima(sweep)
    for label, files in by_design.items():
        assert len(files) == RUNS
        floor = statistics.median(d["metrics"]["NoRE"] for d in files)
        assert float(designs[label]["floor_median"]) == pytest.approx(floor, rel=1e-12)
        assert int(designs[label]["instances"]) == RUNS
        err = np.median([np.abs(100 * (np.array(d["x_opt"]) - theta) / theta) for d in files],
                        axis=0)
        for r in rows:
            if r["design"] == label:
                j = names.index(r["parameter"])
                assert float(r["floor_median_abs_error_percent"]) == pytest.approx(err[j],
                                                                                   rel=1e-9)
    assert not list((tmp_path / "r").glob("figures/identifiability*"))  # short: no figure
    assert "## Identifiability" in report.report_md.read_text()


def test_the_convergence_levels_are_medians_over_instances(sweep, registry):
    from vpid_bench.report.load import load_records, run_rows

    loaded = load_records([sweep])
    rows = run_rows(loaded.records)
    f_true, f_opt = reference_levels(loaded.records, rows)
    short = _design_optima(sweep)[SHORT]
    f_at_true = {r["instance"]["id"]: r["problem"]["info"]["f_at_true"] for r in loaded.records
                 if r["problem"]["config"]["record"]["extra"] == 0.0}
    assert len(f_at_true) == RUNS
    for context in ("vehicle ps=4 record.extra=0", "vehicle ps=6 record.extra=0"):
        assert f_true[context] == pytest.approx(statistics.median(f_at_true.values()), rel=1e-12)
        assert f_opt[context] == pytest.approx(statistics.median(d["f_opt"] for d in short),
                                               rel=1e-12)
        assert f_opt[context] < f_true[context]


@pytest.mark.parametrize("bad", [
    "{not json",
    json.dumps({"names": ["m"], "crb_percent": [1.0]}),
    "NAN",
    "CRB_NAN",
    "BIG",
    "INSTANCE_RUNS",
    "INSTANCE_BOUNDS",
    "FLOOR_NAN",
    "EXCLUDED",
])
def test_bad_identifiability_files_are_skipped_with_one_line(sweep, tmp_path, registry, bad):
    copy = tmp_path / "copy"
    shutil.copytree(sweep, copy)
    path = copy / "long4" / "identifiability.json"
    good = json.loads(path.read_text())
    if bad == "NAN":
        text = json.dumps({**good, "crb_norm_percent": float("nan")})
    elif bad == "CRB_NAN":
        text = json.dumps({**good, "crb_percent": good["crb_percent"][:-1] + ["x"]})
    elif bad == "BIG":
        text = json.dumps({**good, "pad": "x" * (MAX_BYTES + 100_000)})
    elif bad == "INSTANCE_RUNS":
        text = json.dumps({**good, "instances": [{**good["instances"][0], "runs": [-1]}]})
    elif bad == "INSTANCE_BOUNDS":
        text = json.dumps({**good, "instances": [{**good["instances"][0], "crb_percent": [1]}]})
    elif bad == "FLOOR_NAN":
        floors = good["sigma_floor_sensitivity"]
        text = json.dumps({**good, "sigma_floor_sensitivity": [
            {**floors[0], "crb_norm_percent": float("nan")}]})
    elif bad == "EXCLUDED":
        text = json.dumps({**good, "excluded_entries": 1.5})
    else:
        text = bad
    path.write_text(text)
    report = build_report([copy], tmp_path / "r", registry=registry, short=True)
    md = report.report_md.read_text()
    assert "## Identifiability" in md  # the other design is still there
    designs = [r["design"] for r in _csv(tmp_path / "r" / "tables" /
                                         "identifiability_designs.csv")]
    assert designs == [SHORT]
    assert md.count("long4/identifiability.json") == 1  # one line says which and why
    assert "Skipped: skipped" in md or "Not built" in md


def test_a_bad_optimum_file_costs_its_instance_only(sweep, tmp_path, registry):
    copy = tmp_path / "copy"
    shutil.copytree(sweep, copy)
    victim = sorted((copy / "optima").glob("*.json"))[0]
    data = json.loads(victim.read_text())
    victim.write_text(json.dumps({**data, "x_opt": data["x_opt"][:3]}))
    build_report([copy], tmp_path / "r", registry=registry, short=True)
    counts = sorted(int(r["instances"]) for r in _csv(tmp_path / "r" / "tables" /
                                                      "identifiability_designs.csv"))
    assert counts == [RUNS - 1, RUNS]


def test_a_problem_without_bounds_gets_no_section(tmp_path, registry, compose_config):
    cfg = compose_config(["problem=functions", "optimizer=random", "problem.iterations=1",
                          "runs=2", "progress=false", "report=false"])
    run_from_config(cfg, tmp_path / "job", registry)
    report = build_report([tmp_path / "job"], tmp_path / "r", registry=registry, short=True)
    assert "## Identifiability" not in report.report_md.read_text()


def test_the_first_screen_bound_is_each_contexts_own_whatever_the_record_order(sweep):
    """The first screen's Cramér–Rao norm per context comes from that context's job, also
    when the records are read in another order than the rows' (sorted by context): a
    pairing by position once gave each verdict its neighbour's bound."""
    from vpid_bench.report.identifiability import crb_norm_by_context
    from vpid_bench.report.load import load_records, run_rows

    records = load_records([sweep]).records
    own = {"short4": "vehicle ps=4 record.extra=0", "short6": "vehicle ps=6 record.extra=0",
           "long4": "vehicle ps=4 record.extra=0.5"}
    expected = {ctx: json.loads((sweep / job / "identifiability.json").read_text())
                ["crb_norm_percent"] for job, ctx in own.items()}
    assert len(set(expected.values())) > 1  # the designs differ, so a mix-up would show
    for order in (records, records[::-1], records[1::2] + records[::2]):
        got = crb_norm_by_context(order, run_rows(order))
        assert got == pytest.approx(expected, rel=1e-12)


def test_a_structural_symmetry_is_named_in_the_section(tmp_path, registry, full):
    """The BMW on a hump both tracks meet alike cannot show its roll inertia: the section
    says the record is blind to a parameter combination; the paper's design does not."""
    from vpid_vehicle.ride.full import RideFullConfig

    problem = hydra_node(RideFullConfig, "ride_full") | {
        "iterations": 1, "parameter_set": "bmw320i", "road": "hump", "duration_s": 1.0}
    cfg = {"problem": problem, "optimizer": {"name": "random"}, "seed": 0, "runs": 1,
           "progress": False, "report": False}
    run_from_config(cfg, tmp_path / "bmw", registry)
    md = " ".join(build_report([tmp_path / "bmw"], tmp_path / "report", registry=registry,
                               short=True).report_md.read_text().split())
    assert "The record is blind to a combination of the parameters" in md
    assert "Ix (" in md.split("## Identifiability")[1]
    assert "blind to a combination" not in " ".join(full.report_md.read_text().split())


def test_a_design_is_labelled_from_its_settings_not_by_stripping_its_context_text(tmp_path):
    """A design's label is its problem and varying settings without the protocol, made from
    the rows' columns: a setting whose value reads like a protocol token (``a ps=7``) is
    kept whole (stripping ``ps=`` words from the context label once cut it to ``a``)."""
    from report_synth import record, write_job

    from vpid_bench.report.identifiability import _design_label
    from vpid_bench.report.load import load_records, run_rows

    for note in ("a ps=7", "b"):
        for ps in (10, 20):
            write_job(tmp_path / f"{note[0]}{ps}", [record(
                problem="toy", optimizer="o", ps=ps, run_index=0, x=np.ones(2), f=1.0,
                names=["x1", "x2"], true=None, problem_extra={"note": note})])
    rows = run_rows(load_records([tmp_path]).records)
    assert {r["context"] for r in rows} >= {"toy ps=10 note=a ps=7", "toy ps=20 note=b"}
    design = [r for r in rows if r["problem.note"] == "a ps=7"]
    assert _design_label(design) == "toy note=a ps=7"
    assert _design_label(rows) == "toy note=a ps=7 / toy note=b"
