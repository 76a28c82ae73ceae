"""``vpid-bench-compile`` (what ``make install`` runs): it fills numba's on-disk cache with the
loops a run takes, skips a problem that needs the user's own settings with the reason, and
refuses a name it does not know."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from vpid_bench.shell.compile import main


def _cached(root: Path, package: str) -> list[Path]:
    """numba's cache index files written for ``package`` below ``root``."""
    return [p for p in root.rglob("*.nbi") if package in str(p)]


def test_the_command_fills_numbas_cache_for_the_named_optimizer(tmp_path):
    cache = tmp_path / "numba"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    done = subprocess.run([sys.executable, "-c", "from vpid_bench.shell.compile import main; "
                           "raise SystemExit(main(['de4', '--jobs', '1']))"],
                          env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "optimizer=de4:" in done.stderr and "problem=" not in done.stderr
    assert "skipped" not in done.stderr and "failed" not in done.stderr
    assert _cached(cache, "vpid_de"), "DE's generation loop is not in the cache"


def test_a_problem_that_needs_the_users_settings_is_skipped_with_the_reason(capsys):
    assert main(["fmu", "--jobs", "1"]) == 0
    err = capsys.readouterr().err
    assert "problem=fmu: skipped (problem.fmu" in err


@pytest.mark.parametrize("argv, said", [(["nosuch"], "nosuch: not an installed problem"),
                                        (["--jobs", "0"], "--jobs: 0 is not a positive")])
def test_a_bad_argument_is_one_error_line_and_exit_2(argv, said, capsys):
    with pytest.raises(SystemExit) as ended:
        main(argv)
    assert ended.value.code == 2
    assert said in capsys.readouterr().err
