"""The wheel: what ``pip install vpid-bench`` installs without the archives' runs (issue 45:
under 5 MB; the runs and IOH exports are the ``vpid-archive-runs`` data distribution)."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from extras import limit

ROOT = Path(__file__).parents[2]
#: The most bytes the installed files of the wheel may take (issue 45).
MAX_INSTALLED_BYTES = 5_000_000


def _tracked_copy(dest: Path) -> Path:
    """The files git tracks, copied to ``dest`` (the build writes build/ and egg-info beside
    its sources: never into the checkout under test)."""
    names = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True,
                           check=True).stdout.decode().split("\0")
    for name in filter(None, names):
        src = ROOT / name
        if src.is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / name)
    return dest


def test_the_installed_wheel_is_under_5_mb_and_holds_no_archived_run(tmp_path):
    """Built from the tracked files as pip builds it (setuptools and wheel come with the test
    extra); the sum of its files' sizes, what an install writes, is under 5 MB, and no
    archive run file or IOH export is among them."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs the git checkout (the wheel is built from its tracked files)")
    src = _tracked_copy(tmp_path / "src")
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", str(src), "--no-deps",
                           "--no-build-isolation", "-q", "-w", str(tmp_path / "dist")],
                          capture_output=True, text=True, timeout=limit(300))
    assert done.returncode == 0, done.stderr[-2000:]
    (wheel,) = (tmp_path / "dist").glob("vpid_bench-*.whl")
    with zipfile.ZipFile(wheel) as zf:
        infos = zf.infolist()
    installed = sum(i.file_size for i in infos)
    assert installed < MAX_INSTALLED_BYTES, f"{installed / 1e6:.2f} MB installed"
    names = [i.filename for i in infos]
    assert not [n for n in names if n.endswith(("records.jsonl.gz", "ioh.zip"))]
    assert any(n.endswith("vpid_bench/archive/vpid1/optima.jsonl") for n in names)
