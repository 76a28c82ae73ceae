"""Issue 24: a user's own config (``-cp``/``-cd``/``-cn``) is honoured, checked by the
pre-flight like the shipped one (one ``error:`` line, exit 2, no ``report:`` line) and locked
the same way. Before, it went straight to Hydra: unchecked, unlocked, its mistakes printed
as Hydra's 2-48 lines, a refused value exited 0 or 1, and ``-cd`` with a ``config.yaml`` was
silently shadowed by the shipped config."""

from __future__ import annotations

from pathlib import Path

import pytest
from hostile_helpers import error_lines, main_in_process

from vpid_bench.shell.resume import FolderLock

HEAD = "defaults:\n  - vpid_bench_spec\n  - problem: functions\n  - optimizer: random\n  - _self_\n"
BODY = "runs: 3\nprogress: false\nproblem:\n  iterations: 2\n"


def _config(folder: Path, name: str, text: str = HEAD + BODY) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.yaml").write_text(text)
    return folder


def _records(job: Path) -> list[Path]:
    return sorted((job / "records").glob("run-*.json"))


def test_a_config_yaml_in_a_config_dir_is_the_one_used(in_tmp, capsys):
    """``-cd DIR`` with ``DIR/config.yaml``: the user's file, not the shipped one (its
    ``runs: 3`` once gave 30 runs); the spec node brings the report."""
    _config(in_tmp / "mine", "config")
    code, err = main_in_process(["-cd", "mine", "hydra.run.dir=out"], capsys)
    assert code == 0, err
    assert len(_records(in_tmp / "out")) == 3
    assert (in_tmp / "out" / "report" / "report.md").is_file()


def test_a_relative_config_path_is_read_from_the_current_folder(in_tmp, capsys):
    """Hydra reads a relative ``-cp`` from the installed package's folder; vpid-bench from
    the current one. A sweep of the user's config writes its jobs and its report."""
    _config(in_tmp / "conf_here", "exp")
    code, err = main_in_process(["-cp", "conf_here", "-cn", "exp", "-m",
                                 "optimizer=random,de1", "hydra.sweep.dir=sw"], capsys)
    assert code == 0, err
    jobs = sorted(p for p in (in_tmp / "sw").iterdir() if p.name.startswith("optimizer="))
    assert [len(_records(j)) for j in jobs] == [3, 3]
    assert (in_tmp / "sw" / "report" / "report.md").is_file()


def test_a_config_dir_adds_choices_to_the_shipped_config(in_tmp, capsys):
    """``-cd DIR`` without a config of that name adds ``DIR/<group>/*.yaml`` as choices,
    which ``glob()`` sees too."""
    (in_tmp / "extra" / "optimizer").mkdir(parents=True)
    (in_tmp / "extra" / "optimizer" / "my_random.yaml").write_text(
        "defaults:\n  - random\n  - _self_\n")
    code, err = main_in_process(["-cd", "extra", "-m", "optimizer=glob(my_*)",
                                 "problem=functions", "problem.iterations=2", "runs=2",
                                 "progress=false", "hydra.sweep.dir=sw"], capsys)
    assert code == 0, err
    job = in_tmp / "sw" / "optimizer=my_random,problem.iterations=2,problem=functions,runs=2"
    assert len(_records(job)) == 2


@pytest.mark.parametrize(("text", "key"), [
    (HEAD + BODY.replace("runs: 3", "runs: abc"), "runs='abc'"),
    (HEAD + BODY.replace("runs: 3", "runz: 3"), "runz=3"),
    (HEAD.replace("optimizer: random", "optimizer: nosuch") + BODY, "optimizer='nosuch'"),
    (HEAD.replace("  - vpid_bench_spec\n", "") + BODY, "--config-name='bad'"),
    ("defaults: [vpid_bench_spec\n", "config file="),  # not YAML
])
def test_a_bad_custom_config_is_one_line_and_exit_2(in_tmp, capsys, text, key):
    """Refused by the pre-flight: one ``error:`` line naming the key, exit 2, nothing run
    and no ``report:`` line (a refused value once exited 0, then 1)."""
    _config(in_tmp / "mine", "bad", text)
    code, err = main_in_process(["-cd", "mine", "-cn", "bad", "hydra.run.dir=out"], capsys)
    assert code == 2, err
    assert len(error_lines(err)) == 1 and len(err.strip().splitlines()) == 1, err
    assert error_lines(err)[0].startswith(f"error: {key}"), err
    assert "report:" not in err and not (in_tmp / "out").exists()


@pytest.mark.parametrize("argv", [
    ["-cd", "nosuch"], ["-cp", "nosuch"], ["-cp", "mine", "-cn", "nosuch"],
    ["-cd", "mine", "-cn", "nosuch"], ["-cd", "mine", "-cn", "../x y"],
    ["-cd", "mine", "-cn", "exp", "hydra.searchpath=[pkg://x]"],
])
def test_config_flag_mistakes_are_one_line(in_tmp, capsys, argv):
    _config(in_tmp / "mine", "exp")
    code, err = main_in_process(argv, capsys)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and err.startswith("error: "), err


def test_a_custom_config_takes_the_folder_lock(in_tmp, capsys):
    """Two commands into one folder: the second is refused in one line (two ``-cd`` sweeps
    once both ran unlocked)."""
    _config(in_tmp / "mine", "exp")
    lock = FolderLock(in_tmp / "sw", "hydra.sweep.dir")
    lock.acquire()
    try:
        code, err = main_in_process(["-cd", "mine", "-cn", "exp", "-m", "optimizer=random",
                                     "hydra.sweep.dir=sw"], capsys)
    finally:
        lock.release()
    assert code == 2 and err.startswith("error: hydra.sweep.dir='sw'"), err
    assert "another one is running there" in err
    assert not [p for p in (in_tmp / "sw").iterdir() if p.name.startswith("optimizer=")]
