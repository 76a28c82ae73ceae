"""Ctrl-C at any moment of a command, from its first fraction of a second (while the heavy
imports, the plugin registry and the pre-flight run) to the middle of its runs: one line,
status 130, no traceback (issue 24: 23 of 31 early tries printed a 35-54-line traceback)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

BIN = Path(sys.executable).parent


@pytest.mark.parametrize("delay", [0.4, 0.9])
def test_an_early_ctrl_c_is_one_line_and_130(tmp_path, delay):
    proc = subprocess.Popen(
        [str(BIN / "vpid-bench"), "-m", "optimizer=random,de1", "problem=vehicle",
         "runs=30", "progress=false", "report=false", "hydra.sweep.dir=sweep"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err[-2000:]
    assert "Traceback" not in err, err[-3000:]
    assert err.strip().splitlines()[-1].startswith("interrupted:")
