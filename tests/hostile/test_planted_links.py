"""Issue 35, failure 15: a symbolic link named ``optima`` in a sweep folder was followed, so
the instance optima were written outside the sweep (and so was the report, through a link
named ``report``). A link planted where the command keeps a folder of its own is now removed
(the link only, never what it points to) with one warning line, before the sweep and again
wherever such a folder is written, so a link planted while the sweep runs is not followed
either. Nothing is written outside the output folder."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from hostile_helpers import TINY, run_cli

from vpid_bench.experiment import run_from_config

#: A problem with residuals and a truth: its jobs write instance optima.
SMALL = [*TINY, "problem=smoke_quarter", "runs=2"]


def _plant(folder: Path, name: str, outside: Path) -> Path:
    (outside / name).mkdir(parents=True)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).symlink_to(outside / name, target_is_directory=True)
    return outside / name


@pytest.mark.parametrize("multirun", [True, False], ids=["sweep", "single-job"])
def test_15_links_planted_before_the_command_are_not_followed(multirun, tmp_path):
    out, outside = tmp_path / "out", tmp_path / "outside"
    for name in ("optima", "report"):
        _plant(out, name, outside)
    key = "hydra.sweep.dir" if multirun else "hydra.run.dir"
    argv = (["-m", "optimizer=random,centre"] if multirun else ["optimizer=random"])
    done = run_cli([*argv, *[a for a in SMALL if a != "report=false"], f"{key}={out}"],
                   tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert [p for p in outside.rglob("*") if p.is_file()] == []  # nothing written outside
    for name in ("optima", "report"):
        assert (out / name).is_dir() and not (out / name).is_symlink()
        (line,) = [w for w in done.stderr.splitlines() if f"{out / name} was a symbolic" in w]
        assert line.startswith("warning: ")
    assert list((out / "optima").glob("*.json"))  # the optima are in the sweep
    assert (out / "report" / "report.md").is_file()


def test_15_a_link_planted_while_the_sweep_runs_is_not_followed(tmp_path, compose_config,
                                                                registry, capsys):
    """The sweep's jobs write their optima through :func:`vpid_bench.fileio.own_folder`: a
    link planted after the pre-flight, between two jobs, is removed there too."""
    sweep, outside = tmp_path / "sweep", tmp_path / "outside"
    run_from_config(compose_config([*SMALL, "optimizer=random"]), sweep / "a", registry,
                    optima_dir=sweep / "optima")
    planted = sweep / "optima"
    shutil.rmtree(planted)
    target = _plant(sweep, "optima", outside)
    capsys.readouterr()
    run_from_config(compose_config([*SMALL, "optimizer=centre"]), sweep / "b", registry,
                    optima_dir=planted)
    assert list(target.iterdir()) == []
    assert planted.is_dir() and not planted.is_symlink() and list(planted.glob("*.json"))
    assert f"warning: {planted} was a symbolic link" in capsys.readouterr().err


def test_15_the_report_folder_of_a_sweep_is_never_a_link(tmp_path, compose_config, registry):
    from vpid_bench.shell.callbacks import write_report

    sweep, outside = tmp_path / "sweep", tmp_path / "outside"
    run_from_config(compose_config([*SMALL, "optimizer=random"]), sweep / "a", registry)
    target = _plant(sweep, "report", outside)
    write_report(sweep, short=True, archive=False)
    assert list(target.iterdir()) == []
    assert (sweep / "report" / "report.md").is_file()


def test_15_the_per_problem_files_of_a_sweep_are_never_written_through_a_link(
        tmp_path, compose_config, registry, capsys):
    """The bounds and floors a sweep makes once per problem live in ``optima/per-problem``
    (``vpid_bench.job_analysis.shared_file``): a link planted there between two jobs is
    removed like one named ``optima``, and the second job still gets its files."""
    sweep, outside = tmp_path / "sweep", tmp_path / "outside"
    run_from_config(compose_config([*SMALL, "optimizer=random"]), sweep / "a", registry,
                    optima_dir=sweep / "optima")
    shutil.rmtree(sweep / "optima" / "per-problem")
    target = _plant(sweep / "optima", "per-problem", outside)
    capsys.readouterr()
    run_from_config(compose_config([*SMALL, "optimizer=centre"]), sweep / "b", registry,
                    optima_dir=sweep / "optima")
    assert list(target.iterdir()) == []
    shared = sweep / "optima" / "per-problem"
    assert shared.is_dir() and not shared.is_symlink() and list(shared.glob("*.json"))
    assert (sweep / "b" / "estimators.json").read_text() == \
        (sweep / "a" / "estimators.json").read_text()
    assert f"warning: {shared} was a symbolic link" in capsys.readouterr().err
