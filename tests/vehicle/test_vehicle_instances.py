"""Instances of the vehicle problem: one noise record per instance (``problem.noise.per_run``),
paired across optimizers, named in every record; the equivalent noise σ; the data digest."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest
from vehicle_helpers import make
from vpid_vehicle.config import VehicleConfig
from vpid_vehicle.objective import add_noise
from vpid_vehicle.problem import VehicleProblem

from vpid_bench.params import hydra_node


@pytest.fixture(scope="module")
def problem() -> VehicleProblem:
    return make()


def test_same_index_same_record_for_every_problem_built_from_the_config(problem):
    """Every optimizer's job builds its own problem from the same config: instance i of each
    holds the same record (bit for bit); different indices hold different records."""
    other = make()
    for i in (0, 1, 7, 29):
        np.testing.assert_array_equal(problem.instance(i).reference, other.instance(i).reference)
    records = [problem.instance(i).reference for i in range(5)]
    for i in range(5):
        for j in range(i + 1, 5):
            assert not np.array_equal(records[i], records[j])


def test_instance_i_draws_from_the_seed_sequence_child_i(problem):
    """The documented stream: SeedSequence(noise.seed, spawn_key=(i,)); the clean record and
    the settings are shared."""
    for i in (0, 3):
        rng = np.random.default_rng(np.random.SeedSequence(0, spawn_key=(i,)))
        expected = add_noise(problem.reference_clean, 0.05, "multiplicative", rng)
        np.testing.assert_array_equal(problem.instance(i).reference, expected)
        assert problem.instance(i).reference_clean is problem.reference_clean
    q = make(**{"noise.seed": 4})
    assert not np.array_equal(q.instance(3).reference, problem.instance(3).reference)


def test_instances_are_cheap_cached_copies_sharing_the_simulator(problem):
    inst = problem.instance(5)
    assert inst is problem.instance(5) and inst is problem.instance(2).instance(5)
    assert problem.instance(0) is problem  # the job's problem is instance 0
    assert inst.model is problem.model and inst.config is problem.config
    assert inst.name == problem.name
    # its own record, its own objective: f at the truth is instance 5's noise floor
    f = inst.evaluate(inst.x_true[None])[0]
    num = np.linalg.norm(inst.reference - problem.reference_clean, axis=1).sum()
    assert f == pytest.approx(num / np.linalg.norm(inst.reference, axis=1).sum(), rel=1e-12)
    assert inst.describe()["f_at_true"] == pytest.approx(f, rel=1e-12)
    with pytest.raises(ValueError, match="instance index"):
        problem.instance(-1)


def test_instance_ids_name_the_record(problem):
    assert problem.instance_id() == "noise.seed=0/0"
    assert problem.instance(12).instance_id() == "noise.seed=0/12"
    assert make(**{"noise.seed": 3}).instance(2).instance_id() == "noise.seed=3/2"
    assert problem.instance(12).describe()["noise"]["record"] == "noise.seed=0/12"


def test_per_run_false_keeps_one_record_drawn_from_the_seed():
    """One record for every run, the one earlier versions drew: default_rng(noise.seed)."""
    q = make(**{"noise.per_run": False})
    assert q.instance(3) is q and q.instance_id() is None
    expected = add_noise(q.reference_clean, 0.05, "multiplicative", np.random.default_rng(0))
    np.testing.assert_array_equal(q.instance(7).reference, expected)


def test_without_noise_every_instance_is_identical():
    q = make(**{"noise.level": 0.0})
    assert q.instance(4) is q and q.instance_id() is None and q.residual_sigma() is None


@pytest.mark.parametrize("model", ["multiplicative", "additive", "uniform"])
def test_residual_sigma_is_the_standard_deviation_of_the_added_noise(problem, model):
    """σ_k, per sample, is the standard deviation of the noise actually drawn: over 100
    instances the mean of (noise_k / σ_k)² is 1 within 4 standard errors in each channel
    (``var((n/σ)²) = 2`` for normal noise, ``9 × 4/45`` for ``√3 u`` with u uniform on
    [-1, 1]); where σ_k = 0 (multiplicative noise on a zero sample) no noise was drawn; and
    σ_k is the stated formula (level |z_k|, level rms(z_c), level |z_k| / √3)."""
    q = make(**{"noise.model": model, "noise.level": 0.1})
    sigma = q.residual_sigma()
    clean = q.reference_clean
    assert sigma.shape == (clean.size,)
    sigma = sigma.reshape(clean.shape)
    n = 100
    noise = np.stack([q.instance(i).reference - clean for i in range(n)])
    var = 9 * 4 / 45 if model == "uniform" else 2.0
    for c in range(2):
        noisy = sigma[c] > 0
        z2 = (noise[:, c, noisy] / sigma[c, noisy]) ** 2
        se = np.sqrt(var / z2.size)
        assert abs(z2.mean() - 1) < 4 * se, (z2.mean(), se)
        assert se < 0.01  # the check has teeth: a wrong factor (e.g. sqrt 3) fails it
        assert np.all(noise[:, c, ~noisy] == 0)
    rms = np.sqrt(np.mean(clean**2, axis=1, keepdims=True))
    expected = {"multiplicative": 0.1 * np.abs(clean),
                "additive": 0.1 * rms * np.ones_like(clean),
                "uniform": 0.1 * np.abs(clean) / np.sqrt(3)}[model]
    np.testing.assert_allclose(sigma, expected, rtol=1e-12)


def test_a_measured_record_has_no_sigma_and_one_instance(tmp_path, problem):
    (path,) = problem.write_artifacts(tmp_path)
    q = make(**{"reference.file": str(path)})
    assert q.residual_sigma() is None and q.instance(3) is q and q.instance_id() is None


def test_content_digest_is_the_files_sha256_and_follows_its_bytes(tmp_path, problem):
    assert problem.content_digest() is None
    (path,) = problem.write_artifacts(tmp_path)
    q = make(**{"reference.file": str(path)})
    assert q.content_digest() == hashlib.sha256(path.read_bytes()).hexdigest()
    lines = path.read_text().splitlines()
    cells = lines[5].split(",")
    cells[3] = repr(float(cells[3]) * 1.001)  # one noisy sample of z1'' changes
    lines[5] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    changed = make(**{"reference.file": str(path)})
    assert changed.content_digest() != q.content_digest()
    assert changed.reference[0, 4] != q.reference[0, 4]


def _job(registry, tmp_path, name, runs=3, **problem_keys):
    from vpid_bench.experiment import run_from_config

    cfg = {
        "problem": hydra_node(VehicleConfig, "vehicle") | {"iterations": 1, "ps": 4},
        "optimizer": {"name": "random"},
        "seed": 0, "runs": runs, "progress": False, "report": False, "resume": True,
    }
    for key, value in problem_keys.items():
        node = cfg["problem"]
        *parents, leaf = key.split("__")
        for part in parents:
            node = node[part]
        node[leaf] = value
    return run_from_config(cfg, tmp_path / name, registry=registry)


def test_each_record_names_and_fits_its_instance(registry, tmp_path, problem):
    """Run i's record names instance i, and its f_best is the objective of its x_best on
    record i (not on record 0)."""
    summary = _job(registry, tmp_path, "paired")
    for i, path in enumerate(summary.record_paths):
        record = json.loads(path.read_text())
        assert record["instance"] == {"index": i, "id": f"noise.seed=0/{i}"}
        x = np.asarray(record["result"]["x_best"])
        f_i = problem.instance(i).evaluate(x[None])[0]
        assert record["result"]["f_best"] == pytest.approx(f_i, rel=1e-12)
        if i:
            assert abs(problem.evaluate(x[None])[0] - f_i) > 1e-9
    one = _job(registry, tmp_path, "one-record", noise__per_run=False)
    ids = {json.loads(p.read_text())["instance"]["id"] for p in one.record_paths}
    assert ids == {None}


def test_editing_the_measured_file_makes_a_resume_run_again(registry, tmp_path, problem):
    (path,) = problem.write_artifacts(tmp_path / "data")
    first = _job(registry, tmp_path, "file", runs=1, reference__file=str(path))
    again = _job(registry, tmp_path, "file", runs=1, reference__file=str(path))
    assert (first.ran, again.ran, again.skipped) == (1, 0, 1)
    path.write_text(path.read_text().replace("\n", "\r\n", 3))  # same numbers, other bytes
    edited = _job(registry, tmp_path, "file", runs=1, reference__file=str(path))
    assert (edited.ran, edited.skipped) == (1, 0)
