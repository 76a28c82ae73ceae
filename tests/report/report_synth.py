"""Synthetic run records with known answers, written as a sweep would write them."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from vpid_bench.api import relative_errors_percent
from vpid_bench.store.job_status import write_job_status
from vpid_bench.store.records import SCHEMA, record_path, stable_hash, write_record

PAPER_NAMES = ["m", "I", "m1", "m2", "k1", "k2", "c1", "c2", "a1"]
OV = np.array([505.10, 651.00, 28.58, 54.30, 15000, 15000, 1828.00, 1828.00, 1.468])
# The paper's DE4 mean vector at PS = 20 (Table II): its NoRE is 1.51 %.
DE4_PS20_MEAN = np.array([506.68, 653.84, 28.64, 54.46, 15016.74, 14894.38, 1834.80,
                          1847.71, 1.471])
UNITS = ["kg", "kg m^2", "kg", "kg", "N/m", "N/m", "N s/m", "N s/m", "m"]


def nore(x, true) -> float:
    """The norm of relative errors (%), computed here independently of the plugin."""
    return float(np.sqrt(np.sum((100.0 * (np.asarray(x) - true) / true) ** 2)))


def record(*, problem: str, optimizer: str, ps: int, run_index: int, x: np.ndarray | None,
           f: float | None, names: list[str], true: np.ndarray | None, seed: int = 0,
           problem_extra: dict[str, Any] | None = None, status: str = "ok",
           trace_best: list[float] | None = None, iterations: int = 4,
           metrics: dict[str, float] | None = None, info: dict[str, Any] | None = None,
           units: list[str] | None = None) -> dict[str, Any]:
    """One run record in the schema of vpid_bench.experiment.make_record. With true values
    and no ``metrics``, the record's metrics are ``{"NoRE": ...}`` as the vehicle's."""
    pcfg = {"ps": ps, "iterations": iterations, **(problem_extra or {})}
    params = {"ps": ps, "iterations": iterations}
    budget = ps * (iterations + 1)
    rid = stable_hash([problem, pcfg, optimizer, params, seed, run_index])
    result = None
    trace = None
    if status == "ok":
        x = np.asarray(x, dtype=float)
        result = {"x_best": x.tolist(), "f_best": f, "evaluations": budget, "batches": 5,
                  "stopped_by": "budget", "metrics": dict(metrics or {}),
                  "rel_error_percent": None}
        if true is not None:
            if metrics is None:
                result["metrics"] = {"NoRE": nore(x, true)}
            result["rel_error_percent"] = relative_errors_percent(x, true).tolist()
        best = trace_best or [f * (5 - i) for i in range(5)]
        trace = {"evaluations": [ps * (i + 1) for i in range(5)], "best": best}
    return {
        "schema": SCHEMA, "run_id": rid, "run_index": run_index, "status": status,
        "error": None if status == "ok" else {"type": "RuntimeError", "message": "boom",
                                              "traceback": ""},
        "problem": {"name": problem, "config": pcfg, "info": dict(info or {})},
        "optimizer": {"name": optimizer, "plugin": None, "params": params},
        "seeds": {"seed": seed, "spawn_key": [run_index]},
        "instance": {"index": run_index, "id": None},
        "budget": budget,
        "parameters": {"names": names, "units": list(units or [""] * len(names)),
                       "lower": [0.0] * len(names), "upper": [1.0] * len(names),
                       "true": None if true is None else list(map(float, true))},
        "result": result, "trace": trace, "config": {}, "versions": {},
        "timing": {"wall_time_s": 0.01, "run_time_s": 0.01, "started_at": "x"},
    }


def write_job(job_dir: Path, records: list[dict[str, Any]], status: str = "ok") -> Path:
    """Write the records and a job.json into ``job_dir``."""
    for r in records:
        write_record(record_path(job_dir, r["run_index"], r["run_id"]), r)
    write_job_status(job_dir, status, "synthetic")
    return job_dir


def objective_job(root: Path, optimizer: str, ps: int, values: list[float],
                  problem: str = "toy", seed: int = 0) -> Path:
    """A job whose runs have the given objective values and no true parameters."""
    recs = [record(problem=problem, optimizer=optimizer, ps=ps, run_index=i,
                   x=np.array([v, -v]), f=v, names=["x1", "x2"], true=None, seed=seed)
            for i, v in enumerate(values)]
    return write_job(root / f"optimizer={optimizer},ps={ps},seed={seed}", recs)


#: An optimizer name a record may hold: HTML and a script.
EVIL = 'de<img src=x onerror="alert(1)">&<script>alert(2)</script>'


def html_sweep(root: Path, short: bool = False, evil: str = EVIL) -> Path:
    """Two problems, three optimizers (one with a hostile name), 4 runs each; returns the
    report folder."""
    rng = np.random.default_rng(1)
    for problem in ("vehicle", "vehicle_b"):
        for algo, spread in (("de4", 0.01), ("random", 0.3), (evil, 0.05)):
            recs = [record(problem=problem, optimizer=algo, ps=20, run_index=i,
                           x=OV * (1 + spread * rng.standard_normal(9)), f=spread * (1 + i),
                           names=PAPER_NAMES, true=OV, units=["kg"] * 9,
                           info={"f_at_true": 0.004, "metric_units": {"NoRE": "%"}})
                    for i in range(4)]
            write_job(root / f"{problem}-{abs(hash(algo)) % 997}", recs)
    out = root / "report"
    from vpid_bench.report.build import build_report

    build_report([root], out, short=short, archive=False)
    return out


def optimum_file(folder: Path, problem: str, instance: str, x_opt: np.ndarray, f_opt: float,
                 true: np.ndarray) -> Path:
    """An instance optimum file as a job writes it (``optima/<name>.json``)."""
    import json

    data = {"schema": "vpid-bench/instance-optimum/1", "problem": problem,
            "instance": instance, "settings": {"ps": 20, "iterations": 4},
            "x_opt": list(map(float, x_opt)), "f_opt": f_opt, "f_true": 1.2 * f_opt,
            "metrics": {"NoRE": nore(x_opt, true)}, "starts": 3}
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{problem}-{instance}.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def paired_sweep(root: Path, problem: str = "vehicle", ps: tuple[int, ...] = (20,),
                 instances: int = 6) -> Path:
    """Two optimizers on ``problem`` at each population size of ``ps``, run i on instance i
    (ids set: the runs pair), with every instance's optimum: ``good`` reaches it, ``slow``
    ends 10 % above it in f."""
    for k in range(instances):
        x_opt = OV * (1 + 0.1 * np.cos(np.arange(9) + k))
        optimum_file(root / "optima", problem, f"inst{k}", x_opt, 0.1 + 0.01 * k, OV)
    for size in ps:
        for algo, factor in (("good", 1.0), ("slow", 1.1)):
            recs = []
            for k in range(instances):
                fo = 0.1 + 0.01 * k
                x = OV * (1 + 0.1 * np.cos(np.arange(9) + k)) * (1 + 0.01 * (factor - 1))
                r = record(problem=problem, optimizer=algo, ps=size, run_index=k, x=x,
                           f=fo * factor, names=PAPER_NAMES, true=OV,
                           trace_best=[4 * fo, 2 * fo, 1.5 * fo, 1.2 * fo, fo * factor])
                r["instance"]["id"] = f"inst{k}"
                recs.append(r)
            write_job(root / f"problem={problem},optimizer={algo},ps={size}", recs)
    return root


#: Record and plugin text that once became real images and links in report.md and on the
#: HTML pages, three of them fetched by the browser (issue 44, N5): an image, a link, an
#: autolink, a bare URL, a ``www.`` address, a reference-style link and raw HTML. The hosts
#: are the discard port of this machine: a fetch would fail, but the browser's log shows it.
LINKS = ("![n5 image](http://127.0.0.1:9/n5-image.png) [n5 link](https://127.0.0.1:9/n5-link) "
         "<http://127.0.0.1:9/n5-autolink> bare https://127.0.0.1:9/n5-bare and www.n5.invalid "
         "[n5 ref][r] <img src=\"http://127.0.0.1:9/n5-html.png\"> "
         "![n5 ref image][r]\n\n[r]: http://127.0.0.1:9/n5-ref")


def links_plugin() -> Any:
    """A plugin whose report section for problem ``vehicle`` carries :data:`LINKS` in its
    title, its text (beside a Markdown table whose cells carry them too) and a headline
    column."""
    import types

    from vpid_bench import hookimpl
    from vpid_bench.report.sections import Contribution, HeadlineColumn, Section

    def section(ctx):
        table = ctx.markdown_table(["what", "text"], [["cell", LINKS]])
        values = {(r["context"], r["algorithm"]): LINKS for r in ctx.rows}
        return Contribution(
            sections=(Section("Links [t](http://127.0.0.1:9/n5-title)", f"{LINKS}\n\n{table}"
                              f"\n\n*kept* emphasis"),),
            headline=(HeadlineColumn("n5 col", values),))

    @hookimpl
    def vpid_bench_register_report_sections(register):
        register("vehicle", section)

    return types.SimpleNamespace(
        vpid_bench_register_report_sections=vpid_bench_register_report_sections)


def links_sweep(root: Path, short: bool = False) -> Path:
    """A sweep of ``vehicle`` runs (de4, random, and an optimizer named with an image) where
    one run of each optimizer failed with :data:`LINKS` as its error message, reported with
    :func:`links_plugin`'s section; returns the report folder."""
    from vpid_bench.plugins import Registry, get_plugin_manager
    from vpid_bench.report.build import build_report

    rng = np.random.default_rng(5)
    for algo, spread in (("de4", 0.01), ("random", 0.3),
                         ("![o](http://127.0.0.1:9/n5-name.png)", 0.05)):
        recs = [record(problem="vehicle", optimizer=algo, ps=20, run_index=i,
                       x=OV * (1 + spread * rng.standard_normal(9)), f=spread * (1 + i),
                       names=PAPER_NAMES, true=OV, units=["kg"] * 9,
                       status="ok" if i < 4 else "failed",
                       info={"f_at_true": 0.004, "metric_units": {"NoRE": "%"}})
                for i in range(5)]
        recs[-1]["error"]["message"] = LINKS
        write_job(root / f"vehicle-{abs(hash(algo)) % 997}", recs)
    registry = Registry(get_plugin_manager(entry_points=[], extra_plugins=[
        ("n5links", links_plugin())]))
    out = root / "report"
    build_report([root], out, short=short, archive=False, registry=registry)
    return out
