"""Ctrl-C at any moment of a command, from its first hundredths of a second (while the heavy
imports, the plugin registry and the pre-flight run) to the middle of its runs: one line,
status 130, no traceback (issue 24: 23 of 31 early tries printed a 35-54-line traceback)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from extras import limit

BIN = Path(sys.executable).parent


def wait_for_the_commands_code(proc: subprocess.Popen, limit: float = 30.0) -> None:
    """Return once the command's own code runs: numpy is mapped into the process, which the
    package's import does after ``vpid_bench_command.main`` took over Ctrl-C. Before that it
    is Python's own start-up (the interpreter, ``site`` and the installs' ``.pth`` files,
    some 0.03-0.08 s on a loaded 2-core machine), which no line of the project can reach, so a
    delay counted from the spawn landed there under load (exit 1, ``site``'s traceback)."""
    maps = Path(f"/proc/{proc.pid}/maps")
    end = time.monotonic() + limit
    while time.monotonic() < end and proc.poll() is None:
        try:
            if "numpy" in maps.read_text():
                return
        except OSError:  # the process is ending
            break
        time.sleep(0.002)
    raise AssertionError(f"the command's code never ran (status {proc.poll()})")


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs Linux's /proc")
@pytest.mark.parametrize("delay", [0.0, 0.05, 0.15, 0.4, 0.9])
def test_an_early_ctrl_c_is_one_line_and_130(tmp_path, delay):
    """``delay`` counts from the moment the command's code runs: 0, 0.05 and 0.15 s land in
    the imports before the package's own handler is set, later ones in the pre-flight and
    the runs."""
    proc = subprocess.Popen(
        [str(BIN / "vpid-bench"), "-m", "optimizer=random,de1", "problem=vehicle",
         "runs=30", "progress=false", "report=false", "hydra.sweep.dir=sweep"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for_the_commands_code(proc)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=limit(60))
    assert proc.returncode == 130, err[-2000:]
    assert "Traceback" not in err, err[-3000:]
    assert err.strip().splitlines()[-1].startswith("interrupted:")


SWALLOWER = '''\
"""A plugin whose import is slow and wraps it in a bare except, as some libraries do."""
import time

import pluggy

try:
    time.sleep(4)
except:  # noqa: E722 - on purpose: it swallowed the user's Ctrl-C
    pass

hookimpl = pluggy.HookimplMarker("vpid_bench")


@hookimpl
def vpid_bench_register_optimizers(register):
    pass
'''

PYPROJECT = """\
[build-system]
requires = ["setuptools>=68"]
build-backend = "setuptools.build_meta"

[project]
name = "swallowing-plugin"
version = "0.1"

[project.entry-points.vpid_bench]
swallower = "swallowing_plugin"
"""


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    src = tmp_path_factory.mktemp("src")
    (src / "pyproject.toml").write_text(PYPROJECT)
    (src / "swallowing_plugin.py").write_text(SWALLOWER)
    target = tmp_path_factory.mktemp("site")
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--no-build-isolation", "--target", str(target), str(src)],
                   check=True, capture_output=True, text=True)
    return target


def test_a_ctrl_c_during_a_plugins_import_is_not_swallowed(site, tmp_path):
    """A Ctrl-C while a plugin imports (inside its bare ``except:``) stops the command with
    one line and 130; it once went into the plugin's except, and the sweep ran on to exit 0."""
    import os

    env = {**os.environ, "PYTHONPATH": str(site), "MPLBACKEND": "Agg"}
    env.pop("VPID_BENCH_DEBUG", None)
    proc = subprocess.Popen(
        [str(BIN / "vpid-bench"), "-m", "optimizer=random", "problem=functions", "runs=2",
         "progress=false", "report=false", "hydra.sweep.dir=sweep"],
        cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(2.5)  # inside the plugin's 4 s import
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=limit(60))
    assert proc.returncode == 130, err[-2000:]
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("interrupted:")
    assert not (tmp_path / "sweep").exists()


# ---- a Ctrl-C that a library turns into its own error while Hydra composes a job ----


def _entry_raising(exc, signalled, seen_env):
    """A stand-in for Hydra's run: notes HYDRA_FULL_ERROR, then raises ``exc`` as if a Ctrl-C
    (``signalled``) had landed inside omegaconf's clean-up while Hydra composed a config."""
    from vpid_bench import interrupts

    def entry(args, task):
        seen_env.append(os.environ.get("HYDRA_FULL_ERROR"))
        interrupts._Watch.installed, interrupts._Watch.signalled = True, signalled
        raise exc

    return entry


@pytest.mark.parametrize("signalled", [True, False])
def test_an_error_over_the_users_ctrl_c_is_the_interrupt_and_any_other_a_refusal(
        monkeypatch, capsys, signalled):
    """Hydra is made to raise its errors (HYDRA_FULL_ERROR, the user's value restored after),
    so a ConfigKeyError raised over a Ctrl-C once pressed (it once printed Hydra's traceback
    and exited 1) becomes the interrupt (status 130 at the command's top), and the same error
    without a Ctrl-C stays one refusal line, status 2."""
    from omegaconf.errors import ConfigKeyError

    from vpid_bench import interrupts
    from vpid_bench.shell import main as shell

    monkeypatch.setattr(interrupts._Watch, "installed", False)
    monkeypatch.setattr(interrupts._Watch, "signalled", False)
    monkeypatch.setenv("HYDRA_FULL_ERROR", "0")
    monkeypatch.delenv("VPID_BENCH_DEBUG", raising=False)
    seen_env: list = []
    monkeypatch.setattr(shell, "_hydra_entry", _entry_raising(
        ConfigKeyError("Key 'sweep' is not in struct"), signalled, seen_env))
    if signalled:
        with pytest.raises(KeyboardInterrupt):
            shell._run_hydra(["x=1"], None)
    else:
        with pytest.raises(SystemExit) as info:
            shell._run_hydra(["x=1"], None)
        assert info.value.code == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert seen_env == ["1"] and os.environ["HYDRA_FULL_ERROR"] == "0"


def test_an_error_over_the_users_ctrl_c_before_hydra_ends_the_command_with_130(
        monkeypatch, capsys):
    """The same in the command's own code (the pre-flight composes configs too): an error
    raised once the user's Ctrl-C was seen ends the command as the Ctrl-C does."""
    from vpid_bench import interrupts
    from vpid_bench.shell import main as shell

    def preflight_hit(argv):
        interrupts._Watch.installed, interrupts._Watch.signalled = True, True
        raise KeyError("a library's error over the Ctrl-C")

    monkeypatch.setattr(interrupts._Watch, "installed", False)
    monkeypatch.setattr(interrupts._Watch, "signalled", False)
    monkeypatch.setattr(shell, "_main", preflight_hit)
    with pytest.raises(SystemExit) as info:
        shell.main(["-m", "optimizer=de1"])
    assert info.value.code == 130
    assert capsys.readouterr().err.startswith("interrupted:")


def test_a_hydra_error_reaches_the_command_as_one_line(tmp_path, monkeypatch, capsys):
    """Real Hydra, with an override its composition refuses (the pre-flight is not run
    here): Hydra raises instead of printing (HYDRA_FULL_ERROR), the command says one line."""
    from vpid_bench.plugins import Registry
    from vpid_bench.shell import main as shell
    from vpid_bench.shell.config_store import register_configs

    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("HYDRA_FULL_ERROR", raising=False)
    monkeypatch.delenv("VPID_BENCH_DEBUG", raising=False)
    registry = Registry()
    register_configs(registry)
    with pytest.raises(SystemExit) as info:
        shell._run_hydra(["no_such_key=1"], shell.JobTask(registry))
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "no_such_key" in err, err
    assert "Traceback" not in err and err.count("\n") == 1
    assert "HYDRA_FULL_ERROR" not in os.environ
