"""Issue 13: a property-based fuzz of override strings through the real command's entry point
(in-process, Hydra's run replaced by nothing, so an accepted command runs no job). Whatever
the strings: no traceback, no hang, exit status 0, 1 or 2, a refusal is exactly one line.

The default run tries 100 strings (Hypothesis's own default; about 10 s of CPU), ``-m slow``
1,000 more from the same strategy."""

from __future__ import annotations

import contextlib
import io
import os
import signal
from unittest import mock

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

KEYS = ["runs", "seed", "budget", "resume", "progress", "report", "threads", "run_timeout_s",
        "problem", "optimizer", "problem.ps", "problem.iterations", "problem.dim",
        "problem.function", "problem.half_width", "problem.noise.level", "problem.dt",
        "problem.bump.h", "problem.record.extra", "problem.reference.file",
        "problem.reference.dt", "optimizer.F", "optimizer.CR", "optimizer.K",
        "optimizer.bounds", "optimizer.R_max", "hydra.sweep.dir", "hydra.run.dir",
        "hydra/launcher", "hydra/sweeper", "hydra.launcher.n_jobs", "hydra.sweep.subdir",
        "foo", "problem.name", "problem.nosuch.x", "optimizer.ps", "hydra.job.chdir",
        "isolation", "workers", "grace_s", "archive", "target", "budget_per_dim", "suite"]
VALUES = ["", "0", "1", "-1", "2.0", "2.5", "1e3", "1e308", "-1e308", "inf", "-inf", "nan",
          "abc", "'x y'", '"q"', "a,b", "1,2", "0,1,-3", "range(0,3)", "range(0,1,0)",
          "range(5,1)", "range(0,1000000)", "interval(0,1)", "choice(1,2)", "glob(*)",
          "glob(zz*)", "${oc.env:HOME}", "${now:%H}", "${oc.decode:'1'}", "[1,2]", "{a:1}",
          "null", "true", "random", "de1", "de6", "ga", "functions", "vehicle", "../x",
          "/dev/null", "/etc/passwd", "'clip',reflect", "sphere", "basic", "joblib", "nosuch",
          "1e-11", "100000", "de1,choice(-1,1)", "1,range(0,2)", "a,glob(x*)",
          "1,interval(0,1)", "[1,choice(2,3)]",
          "\\", "%", "'", "ü", "a=b", "=", ",", "process", "none", "auto",
          "thread", "1025", "1e10", "1e-8", "smoke", "smoke_quarter", "0.5"]
PREFIX = st.sampled_from(["", "", "", "+", "++", "~"])
override = st.one_of(
    st.builds(lambda p, k, v: f"{p}{k}={v}", PREFIX, st.sampled_from(KEYS),
              st.one_of(st.sampled_from(VALUES), st.text(max_size=8))),
    st.builds(lambda p, k: f"{p}{k}", PREFIX, st.sampled_from(KEYS)),
    st.text(max_size=16),
    # Hydra's config flags, alone (the next element is their value) or with a folder
    st.sampled_from(["-cd", "--config-dir", "-cn", "--config-name", "-cp", "--config-path"]),
    st.builds(lambda f, v: f"{f}={v}", st.sampled_from(["--config-dir", "--config-name"]),
              st.sampled_from(["/dev/null", "../x", ".", "/etc", "nosuch", "", "config"])),
)
#: A tiny job, so an accepted point is cheap to plan.
BASE = ["problem=functions", "optimizer=random", "runs=1", "problem.iterations=2",
        "progress=false", "report=false"]


@contextlib.contextmanager
def _alarm(seconds: int):
    def hang(signum, frame):
        raise AssertionError(f"the pre-flight took longer than {seconds} s (a hang)")

    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


#: Every fuzz run: reproducible (derandomized), no per-example deadline (a hang is _alarm's).
FUZZ = {"deadline": None, "derandomize": True,
        "suppress_health_check": [HealthCheck.too_slow, HealthCheck.function_scoped_fixture]}
COMMANDS = {"multirun": st.booleans(), "overrides": st.lists(override, min_size=1, max_size=3)}


@settings(max_examples=100, **FUZZ)
@given(**COMMANDS)
def test_fuzzed_overrides_never_trace_back_or_hang(multirun, overrides, workdir):
    _one_command(multirun, overrides, workdir)


@pytest.mark.slow  # about 100 s of CPU
@settings(max_examples=1000, **FUZZ)
@given(**COMMANDS)
def test_fuzzed_overrides_never_trace_back_or_hang_thoroughly(multirun, overrides, workdir):
    _one_command(multirun, overrides, workdir)


def _one_command(multirun: bool, overrides: list[str], workdir) -> None:
    """``vpid-bench [-m] BASE overrides`` in-process: no traceback, status 0, 1 or 2, and a
    refusal (2) is one ``error:`` line ending the output."""
    from vpid_bench.shell import main as shell

    argv = (["-m"] if multirun else []) + BASE + overrides
    err = io.StringIO()
    old_cwd, old_env = os.getcwd(), dict(os.environ)
    os.environ.pop("VPID_BENCH_DEBUG", None)
    os.chdir(workdir)
    try:
        with (mock.patch.object(shell, "_run_hydra", lambda args, task: None),
              contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()),
              _alarm(30)):
            try:
                shell.main(argv)
                code = 0
            except SystemExit as exc:
                code = 0 if exc.code is None else exc.code
    finally:
        os.chdir(old_cwd)
        os.environ.clear()
        os.environ.update(old_env)
    text = err.getvalue()
    hypothesis.event(f"exit {code}")
    assert "Traceback" not in text, (argv, text)
    assert code in (0, 1, 2), (argv, code, text)
    if code == 2:
        errors = [line for line in text.splitlines() if line.startswith("error:")]
        assert len(errors) == 1 and text.endswith(errors[0] + "\n"), (argv, text)
