"""A third-party plugin round trip: the example package examples/vpid-example-plugins (whose
files the README shows verbatim) is pip-installed with ``--target`` into a folder outside the
repository and driven through the ``vpid-bench`` command with that folder on PYTHONPATH.

It holds both kinds of plugin: ``optimizer=one_plus_one``, a (1+1)-ES that stops itself when
its step collapses, and ``problem=quarter_car``, a 2-DOF quarter car crossing a bump.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from extras import limit, needs_archive_runs

from vpid_bench.api import ConfigError, OptimizerParams
from vpid_bench.runner import run

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent
EXAMPLE = ROOT / "examples" / "vpid-example-plugins"
FILES = ("pyproject.toml", "vpid_example_plugins/one_plus_one.py",
         "vpid_example_plugins/quarter_car.py")


def readme_example_blocks() -> dict[str, str]:
    """The README's code blocks marked ``<!-- example: <path under the example package> -->``."""
    text = (ROOT / "docs" / "plugins.md").read_text(encoding="utf-8")
    pattern = re.compile(r"<!-- example: (\S+) -->\s*```\w*\n(.*?)```", re.S)
    return dict(pattern.findall(text))


def test_readme_shows_the_example_package_files_verbatim():
    blocks = readme_example_blocks()
    assert set(blocks) == set(FILES)
    for name in FILES:
        assert blocks[name] == (EXAMPLE / name).read_text(encoding="utf-8"), name


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The example package, copied out of the repository and pip-installed into a folder."""
    src = tmp_path_factory.mktemp("src") / "vpid-example-plugins"
    shutil.copytree(EXAMPLE, src, ignore=shutil.ignore_patterns("*.egg-info", "build",
                                                                 "__pycache__"))
    target = tmp_path_factory.mktemp("site")
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
         "--target", str(target), str(src)],
        check=True, capture_output=True, text=True, cwd=src.parent,
    )
    (entry_points,) = target.glob("vpid_example_plugins-*.dist-info/entry_points.txt")
    assert "one_plus_one = vpid_example_plugins.one_plus_one" in entry_points.read_text()
    return target


@pytest.fixture(scope="module")
def example(site):
    """The installed example modules, imported in this process from the target folder."""
    sys.path.insert(0, str(site))
    try:
        from vpid_example_plugins import one_plus_one, quarter_car
    finally:
        sys.path.remove(str(site))
    assert Path(quarter_car.__file__).is_relative_to(site)
    return one_plus_one, quarter_car


def _run(site: Path, args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(site), "MPLBACKEND": "Agg",
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    return subprocess.run([str(BIN / "vpid-bench"), *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=limit(300))


def _records(folder: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted(folder.glob("**/records/run-*.json"))]


# --- through the command line ---------------------------------------------------------------

def test_help_lists_both_example_plugins(site, tmp_path):
    proc = _run(site, ["--help"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    choices = proc.stdout.split("== Choices (group=option) ==")[1].split("== Config")[0]
    assert "one_plus_one" in choices and "quarter_car" in choices and "random" in choices


def test_quarter_car_runs_with_installed_optimizers_and_a_report(site, tmp_path):
    proc = _run(site, ["-m", "problem=quarter_car", "optimizer=one_plus_one,random", "runs=2",
                       "progress=false", f"hydra.sweep.dir={tmp_path}/sweep"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    records = _records(tmp_path / "sweep")
    assert len(records) == 4
    for rec in records:
        assert rec["problem"]["name"] == "quarter_car"
        assert rec["parameters"]["names"] == ["ms", "ks", "cs"]
        assert rec["parameters"]["units"] == ["kg", "N/m", "N s/m"]
        assert rec["problem"]["info"]["samples"] == 750
        assert rec["budget"] == 20 * 51
        result = rec["result"]
        if rec["optimizer"]["name"] == "one_plus_one":  # it stops itself: its step collapsed
            plugin = rec["optimizer"]["plugin"]
            assert plugin["distribution"] == "vpid-example-plugins"
            assert plugin["version"] and "vpid-bench" in plugin["requires"]
            assert result["stopped_by"] == "optimizer" and result["evaluations"] < 20 * 51
        else:
            assert result["stopped_by"] == "budget" and result["evaluations"] == 20 * 51
    (reference,) = (tmp_path / "sweep").glob("*one_plus_one*/reference.csv")
    assert reference.read_text().splitlines()[0] == "t_s,zs_dd_m_s2"
    assert (tmp_path / "sweep" / "report" / "report.md").is_file()


@needs_archive_runs
@pytest.mark.parametrize("selection", [
    pytest.param("problem=smoke_quarter", id="one-member"),
    pytest.param("suite=smoke", id="suite", marks=pytest.mark.slow),  # 5 min on 2 cores
])
def test_on_the_smoke_suite_it_is_ranked_among_the_archived_builtins(site, tmp_path, selection):
    """The archive's promise: a newcomer's optimizer, installed from outside the repository
    and run alone on ``suite=smoke`` (or one of its members: the default run's fast twin of
    the same path), is ranked beside every built-in optimizer from the archive shipped with
    vpid-bench, and nothing but its own jobs runs."""
    from vpid_bench.store.archive import default_root
    from vpid_bench.store.archive_records import read_archive

    shipped = read_archive(default_root() / "smoke")
    builtins = set(shipped.manifest["optimizers"])
    proc = _run(site, ["-m", selection, "optimizer=one_plus_one", "runs=3",
                       "progress=false", f"hydra.sweep.dir={tmp_path}/sweep"], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    sweep = tmp_path / "sweep"
    assert {r["optimizer"]["name"] for r in _records(sweep)} == {"one_plus_one"}
    members = sorted(shipped.problems) if selection.startswith("suite") \
        else [selection.split("=")[1]]
    assert len([j for j in sweep.iterdir() if (j / "job.json").is_file()]) == len(members)
    for member in members:
        assert f"{member}: " in proc.stderr and "from the archive of suite smoke" in proc.stderr
    import csv

    with open(sweep / "report" / "runs.csv", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    for member in members:
        ranked = {r["algorithm"] for r in rows if r["problem"] == member}
        assert ranked == builtins | {"one_plus_one"}, member
        instances = {r["instance"] for r in rows if r["problem"] == member}
        assert len(instances) == 3  # the archived runs on this sweep's instances only
    headline = (sweep / "report" / "tables" / "headline.csv").read_text(encoding="utf-8")
    assert headline.count("one_plus_one") == len(members)


@pytest.mark.slow  # an archive build, then the newcomer's sweep: a few minutes
def test_on_a_vpid1_member_at_its_defaults_it_is_ranked_among_an_archive_build(site, tmp_path):
    """``vpid-bench -m suite=vpid1 optimizer=mine`` needs nothing but the member's defaults to
    meet ``archive/vpid1``: an archive built by tools/build_archive.py (a slice: one
    member, two built-ins, with stop at the final target) ranks the newcomer's runs at the
    member's default budget (1,000·D) beside its built-ins, and only the newcomer runs."""
    archives = tmp_path / "archives"
    build = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "build_archive.py"), "--suite", "vpid1",
         "--problems", "vpid1_q_golden_hump", "--optimizers", "random,de1", "--runs", "2",
         "--target", "1e-8", "--sweep", str(tmp_path / "build"), "--out",
         str(archives / "vpid1"), "--", "progress=false"],
        cwd=ROOT, capture_output=True, text=True, timeout=limit(900),
        env={**os.environ, "MPLBACKEND": "Agg"})
    assert build.returncode == 0, build.stderr[-3000:]
    env_dir = {"VPID_BENCH_ARCHIVE_DIR": str(archives)}
    proc = subprocess.run(
        [str(BIN / "vpid-bench"), "-m", "problem=vpid1_q_golden_hump", "optimizer=one_plus_one",
         "runs=2", "progress=false", f"hydra.sweep.dir={tmp_path}/sweep"], cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(site), "MPLBACKEND": "Agg", **env_dir},
        capture_output=True, text=True, timeout=limit(600))
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "from the archive of suite vpid1" in proc.stderr
    assert {r["optimizer"]["name"] for r in _records(tmp_path / "sweep")} == {"one_plus_one"}
    assert {r["budget"] for r in _records(tmp_path / "sweep")} == {4000}
    import csv

    with open(tmp_path / "sweep" / "report" / "runs.csv", encoding="utf-8") as fh:
        ranked = {r["algorithm"] for r in csv.DictReader(fh)}
    assert ranked == {"one_plus_one", "random", "de1"}

@pytest.mark.parametrize("override, line", [
    ("problem.noise=0.05,-1", "error: problem.noise=-1.0 is not allowed: a level in [0, 1]"),
    ("optimizer.sigma0=0.2,2", "error: optimizer.sigma0=2.0 is not allowed: a fraction in (0, 1]"),
])
def test_a_bad_range_value_anywhere_in_a_sweep_stops_it_before_any_job(site, tmp_path, override,
                                                                        line):
    """A third-party plugin's own range check (in its dataclass) runs in the pre-flight for
    every sweep point: one line, exit 2, no job folder."""
    proc = _run(site, ["-m", "problem=quarter_car", "optimizer=one_plus_one", override,
                       "runs=1", "report=false", f"hydra.sweep.dir={tmp_path}/sweep"], tmp_path)
    assert "Traceback" not in proc.stderr
    assert proc.returncode == 2 and proc.stderr.startswith(line), proc.stderr
    assert proc.stderr.count("\n") == 1
    assert not (tmp_path / "sweep").exists()


def test_an_unknown_key_is_one_line_naming_the_known_ones(site, tmp_path):
    proc = _run(site, ["problem=quarter_car", "optimizer=one_plus_one", "+optimizer.sigmaa=1",
                       "runs=1", "report=false", f"hydra.run.dir={tmp_path}/job"], tmp_path)
    assert proc.returncode == 2
    assert "optimizer.sigmaa" in proc.stderr and "sigma_min" in proc.stderr
    assert "Traceback" not in proc.stderr


# --- the example modules themselves ---------------------------------------------------------

def test_quarter_car_matches_an_independent_ode_solution(example):
    from scipy.integrate import solve_ivp

    _, qc = example
    problem = qc.QuarterCar(qc.QuarterCarConfig())
    c, t = problem.config, problem.t
    X = problem.bounds.sample(np.random.default_rng(1), 2)

    def rhs(_t, s, ms, ks, cs, y):  # the two equations of the module docstring
        zs, zu, vs, vu = s
        force = ks * (zs - zu) + cs * (vs - vu)
        return [vs, vu, -force / ms, (force - c.kt * (zu - y)) / c.mu]

    computed = problem.responses(X)
    for x, acc in zip(X, computed):
        kw = dict(rtol=1e-11, atol=1e-13, dense_output=True)
        on = solve_ivp(rhs, (0, problem.t_off), [0, 0, 0, 0], args=(*x, c.bump_height), **kw)
        off = solve_ivp(rhs, (problem.t_off, t[-1]), on.y[:, -1], args=(*x, 0.0), **kw)
        states = np.where(t < problem.t_off, on.sol(np.minimum(t, problem.t_off)),
                          off.sol(np.maximum(t, problem.t_off)))
        expected = np.array([rhs(0, s, *x, 0.0)[2] for s in states.T])
        assert np.linalg.norm(acc - expected) / np.linalg.norm(expected) < 1e-8


def test_quarter_car_objective_noise_and_hooks(example, tmp_path):
    _, qc = example
    clean = qc.QuarterCar(qc.QuarterCarConfig(noise=0.0))
    x_true = clean.x_true
    assert clean.evaluate(x_true[None])[0] < 1e-12
    assert clean.metrics(x_true) == {"NoRE": 0.0, "max_error_percent": 0.0}
    assert clean.metrics(x_true * [1.03, 1.0, 0.96])["max_error_percent"] == pytest.approx(4)
    noisy = qc.QuarterCar(qc.QuarterCarConfig(noise=0.05, noise_seed=3))
    # multiplicative noise of level 0.05: ||a n 0.05|| / ||a (1 + 0.05 n)|| is about 0.05
    assert noisy.evaluate(x_true[None])[0] == pytest.approx(0.05, rel=0.2)
    again = qc.QuarterCar(qc.QuarterCarConfig(noise=0.05, noise_seed=3))
    np.testing.assert_array_equal(noisy.measured, again.measured)
    signals = noisy.signals(x_true)
    assert set(signals) == {"t", "zs'':measured", "zs'':fitted"}
    np.testing.assert_allclose(signals["zs'':fitted"], clean.measured, rtol=0, atol=1e-12)
    (path,) = noisy.write_artifacts(tmp_path)
    np.testing.assert_allclose(np.loadtxt(path, delimiter=",", skiprows=1)[:, 1], noisy.measured)


@pytest.mark.parametrize("key, value, allowed", [
    ("ms", 0.0, "a number > 0 (kg)"),
    ("speed", float("nan"), "a number > 0 (km/h)"),
    ("dt", 2.0, "a step below duration"),
    ("noise", 1.5, "a level in [0, 1]"),
    ("noise_seed", -1, "an integer >= 0"),
])
def test_quarter_car_config_range_checks(example, key, value, allowed):
    _, qc = example
    with pytest.raises(ConfigError) as info:
        qc.QuarterCarConfig(**{key: value})
    assert info.value.key == f"problem.{key}" and info.value.allowed.startswith(allowed)


def test_one_plus_one_follows_the_one_fifth_rule_and_stops(example):
    es, _ = example
    from vpid_bench.api import Bounds

    box = Bounds(np.zeros(2), np.full(2, 10.0), ("a", "b"))
    params = es.OnePlusOneParams(sigma0=0.5, sigma_min=0.1, grow=2.0)
    opt = es.OnePlusOne(params, box, np.random.default_rng(0))
    start = opt.ask()
    np.testing.assert_array_equal(start[0], opt.parent)  # the start point is evaluated first
    opt.tell(start, np.array([5.0]))
    child = opt.ask()
    opt.tell(child, np.array([4.0]))  # success: parent replaced, sigma 0.5 -> 1.0 (capped)
    np.testing.assert_array_equal(opt.parent, child[0])
    assert opt.sigma == 1.0 and not opt.done
    for k in range(1, 13):  # failures: sigma = 2 ** (-k / 4); below 0.1 after k = 14
        opt.tell(opt.ask(), np.array([9.0]))
        assert opt.sigma == pytest.approx(2 ** (-k / 4)) and not opt.done
    opt.tell(opt.ask(), np.array([9.0]))
    assert not opt.done  # 2 ** -3.25 = 0.105
    opt.tell(opt.ask(), np.array([9.0]))
    assert opt.done and opt.sigma < 0.1  # 2 ** -3.5 = 0.088


def test_one_plus_one_beats_random_search_on_a_sphere_and_stops(example):
    from vpid_baselines.plugin import RandomSearch
    from vpid_functions.plugin import FunctionsConfig, FunctionsProblem

    es, _ = example
    problem = FunctionsProblem(FunctionsConfig(function="sphere", dim=5))
    wins = 0
    for seed in range(5):
        rng = np.random.default_rng
        mine = run(problem, es.OnePlusOne(es.OnePlusOneParams(), problem.bounds, rng(seed)), 1020)
        base = run(problem, RandomSearch(OptimizerParams(), problem.bounds, rng(seed)), 1020)
        wins += mine.f_best < base.f_best
        assert mine.stopped_by == "optimizer" and mine.evaluations < 1020
    assert wins == 5


@pytest.mark.parametrize("key, value", [("sigma0", 0.0), ("sigma_min", 0.3), ("grow", 1.0)])
def test_one_plus_one_params_range_checks(example, key, value):
    es, _ = example
    with pytest.raises(ConfigError) as info:
        es.OnePlusOneParams(**{key: value})
    assert info.value.key == f"optimizer.{key}"
