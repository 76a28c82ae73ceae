"""The shared core's compiled Newmark path (``linear.newmark_outputs``: the table per
candidate, then a time loop written out for the sizes, generated at first use by
``ride/codegen.py``) against the plain statement of the scheme
(``linear.simulate(linear.newmark(...))``), on every built-in linear model and sensor set;
the generated file (what runs, where it is written, written whole)."""

from __future__ import annotations

import inspect
import os
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from vpid_vehicle.ride import codegen, kernel, linear
from vpid_vehicle.ride.full import FullCar
from vpid_vehicle.ride.half import HalfCar
from vpid_vehicle.ride.lateral import SingleTrack
from vpid_vehicle.ride.quarter import QuarterCar, quarter_system

RUNS = codegen.runs()

#: Largest difference allowed, relative to the largest output of the channel: the two paths
#: sum the same terms in another order (and the compiled one shifts the state by V u).
RTOL = 1e-10


def _systems():
    """(label, system, inputs) for every built-in linear model and sensor set."""
    rng = np.random.default_rng(3)
    out = []
    for model in (QuarterCar(), HalfCar(), FullCar(), SingleTrack()):
        for set_name, known in model.sets.items():
            names = list(model.names)
            nominal = np.array([known[k] for k in names])
            X = nominal * rng.uniform(0.7, 1.3, (6, nominal.size))
            for k, sensors in enumerate(model.sensors):
                system = (quarter_system(X, known["kt"], known.get("ct", 0.0), sensors)
                          if isinstance(model, QuarterCar) else
                          model.system(X, known, sensors))
                r = system.F.shape[-1]
                u = np.zeros((600, r))
                u[50:250] = rng.normal(0.0, 0.01, (200, r))  # zero stretches too
                out.append((f"{type(model).__name__}-{set_name}-{sensors}", system, u,
                            isinstance(model, FullCar) and k > 0))
            break  # one published set per model: the sizes do not depend on it
    return out


#: (label, system, inputs, slow): the full car's further sensor sets compile 15-20 s each,
#: so they run under ``-m slow``.
_ALL = _systems()
SYSTEMS = [s[:3] for s in _ALL]
CASES = [pytest.param(system, u, id=label, marks=pytest.mark.slow if slow else ())
         for label, system, u, slow in _ALL]


@pytest.mark.parametrize(("system", "u"), CASES)
def test_compiled_newmark_equals_the_plain_scheme(system, u, request):
    label = request.node.callspec.id
    plain = linear.simulate(linear.newmark(system, 1e-3), u)
    fast = linear.newmark_outputs(system, 1e-3, u)
    scale = np.max(np.abs(plain), axis=(0, 1))
    assert np.all(scale > 0)
    assert np.max(np.abs(fast - plain) / scale) < RTOL
    sizes = (2 * system.dof, system.Pq.shape[-2], system.F.shape[-1])
    assert sizes in RUNS, f"{label}: sizes {sizes} not written out (codegen.SIZES)"


def test_the_loops_equal_the_written_out_steps():
    """Sizes outside codegen.SIZES run the loops: same results to rounding."""
    _, system, u = SYSTEMS[len(SYSTEMS) // 2]
    n, d = system.M.shape[0], system.dof
    r, p = system.F.shape[-1], system.Pq.shape[-2]
    T, w0 = np.empty((n, 2 * d + p, 2 * d + r)), np.empty((n, 2 * d))
    kernel.newmark_table(*(linear._leading(a, shape) for a, shape in (
        (system.M, (d, d)), (system.C, (d, d)), (system.K, (d, d)), (system.F, (d, r)),
        (system.Pa, (p, d)), (system.Pv, (p, d)), (system.Pq, (p, d)), (system.Pu, (p, r)))),
        1e-3, 0.5, 0.25, u[0], T, w0)
    y_loops, y_fast = np.empty((p, len(u), n)), np.empty((p, len(u), n))
    kernel.run_table_loops(T, w0, u, y_loops)
    RUNS[(2 * d, p, r)](T, w0, u, y_fast)
    assert np.max(np.abs(y_loops - y_fast)) < RTOL * np.max(np.abs(y_fast))


def test_a_candidates_outputs_do_not_depend_on_its_batch():
    """Each lane's arithmetic is the same whatever block it lands in: a candidate alone and
    in a batch of 7 (two blocks, one partly empty) give bit-identical outputs."""
    _, system, u = next(s for s in SYSTEMS if s[0].startswith("HalfCar"))
    batch = linear.newmark_outputs(system, 1e-3, u)
    for i in (0, 3, 5):
        one = linear.LinearSystem(*(a[i:i + 1] if a is not None and a.ndim == 3 else a
                                    for a in (system.M, system.C, system.K, system.F,
                                              system.Pa, system.Pq, system.Pu, system.Pv)))
        assert np.array_equal(linear.newmark_outputs(one, 1e-3, u)[0], batch[i])


def test_a_singular_mass_matrix_gives_non_finite_outputs_not_an_error():
    _, system, u = SYSTEMS[0]
    M = system.M.copy()
    M[0] = 0.0
    bad = linear.LinearSystem(M, system.C, system.K, system.F, system.Pa, system.Pq,
                              system.Pu, system.Pv)
    y = linear.newmark_outputs(bad, 1e-3, u)
    assert not np.all(np.isfinite(y[0])) and np.all(np.isfinite(y[1:]))


def test_the_generated_module_is_what_the_generator_writes_and_what_runs():
    """Every compiled loop comes from one file that holds exactly the generator's output and
    whose name carries its hash."""
    files = {inspect.getfile(run.py_func) for run in RUNS.values()}
    assert len(files) == 1 and set(RUNS) == set(codegen.SIZES)
    path = Path(files.pop())
    source = codegen.module_source()
    assert path.read_text(encoding="utf-8") == source
    assert path == codegen.write_source(path.parent, source)


def test_a_file_with_other_content_is_rewritten_whole(tmp_path):
    """A stale or planted file under the hashed name is replaced; no temporary file stays."""
    source = codegen.module_source()
    path = codegen.write_source(tmp_path, source)
    path.write_text("RUNS = {}\n", encoding="utf-8")
    assert codegen.write_source(tmp_path, source) == path
    assert path.read_text(encoding="utf-8") == source
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


def test_the_cache_folders_follow_numba_cache_dir_then_the_user_then_the_package(
        monkeypatch, tmp_path):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    folders = codegen.cache_folders()
    assert folders[0] == tmp_path / "numba" / "vpid_vehicle"
    if os.name != "nt":
        assert folders[1] == tmp_path / "xdg" / "vpid-bench"
    assert folders[2] == Path(codegen.__file__).with_name("__pycache__")
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    assert codegen.cache_folders() == folders[1:]


def test_no_writable_cache_folder_falls_back_to_a_private_temporary_one(monkeypatch, tmp_path):
    """A read-only install with no writable home (here: every folder lies under a file, so
    none can be made, even by root): the loops are written to a fresh temporary folder."""
    (tmp_path / "file").write_text("", encoding="utf-8")
    monkeypatch.setattr(codegen, "cache_folders", lambda: [tmp_path / "file" / "cache"])
    runs = codegen.runs.__wrapped__()  # not the process's cached import
    path = Path(inspect.getfile(runs[(4, 1, 2)].py_func))
    assert path.read_text(encoding="utf-8") == codegen.module_source()
    assert path.parent.name.startswith("vpid-vehicle-") and not path.is_relative_to(tmp_path)
    shutil.rmtree(path.parent)


def test_writers_at_once_leave_one_whole_file(tmp_path):
    """Processes that generate the file at once (here: threads) each get the whole file."""
    source = codegen.module_source()
    with ThreadPoolExecutor(8) as pool:
        paths = set(pool.map(lambda _: codegen.write_source(tmp_path, source), range(32)))
    assert len(paths) == 1 and paths.pop().read_text(encoding="utf-8") == source
    assert len(list(tmp_path.iterdir())) == 1
