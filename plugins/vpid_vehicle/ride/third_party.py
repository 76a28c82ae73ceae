"""The third-party records of :mod:`.bayesrace` and :mod:`.racecar` (linklab-uva/deep-dynamics
at 88c85653, GPL-3.0), from the data distribution ``records-gpl/`` (``make install``) or a
folder named by ``problem.data_dir``, each checked against its SHA-256 before it is read.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.resources
from pathlib import Path

import numpy as np

from vpid_bench import ConfigError, file_sha256

#: The files read and their SHA-256: the one list of them.
SHA256 = {
    "DYN-PP-ETHZ.npz": "3337c2a9ef88e40613624de254e8ad1dd0d93ef44c23313de4181b99a0af68f3",
    "DYN-PP-ETHZMobil.npz": "f5be95da22cfb5cd68a85469666c20c533721f53fcc839f85bfcdd9fcbf812a8",
    "LVMS_23_01_04_B.csv": "2b160f4629eb9204ad72ac3e6adc91eb20ffeffb07bc07788f1bcc37a532d717",
    "Putnam_park2023_run4_2.csv":
        "4e35c801c16c048046662cfd63a062f24bb5ce8061ef644ea41abed956de7e07",
}
#: The installed data distribution's package (``records-gpl/`` of the repository).
PACKAGE = "vpid_records_gpl"
KEY = "problem.data_dir"


def installed_folder() -> Path | None:
    """The folder of the installed data distribution, or ``None`` when it is not installed."""
    try:
        return Path(str(importlib.resources.files(PACKAGE)))
    except ModuleNotFoundError:
        return None


@functools.lru_cache(maxsize=16)
def _digest(path: str, size: int, mtime_ns: int) -> str:
    return file_sha256(Path(path))


def verified(name: str, data_dir: str | None) -> Path:
    """The path of ``name`` in ``data_dir`` or the distribution, SHA-256 checked (once)."""
    expected = SHA256[name]
    folder = Path(data_dir).expanduser() if data_dir else installed_folder()
    if folder is None:
        raise ConfigError(KEY, data_dir, f"a folder holding {name} (SHA-256 {expected}): the "
                          f"data distribution {PACKAGE} is not installed (make install "
                          "installs it from records-gpl/)")
    path = folder / name
    if not path.is_file():
        raise ConfigError(KEY, str(folder), f"a folder holding {name} (SHA-256 {expected}); "
                          "it is not there")
    stat = path.stat()
    found = _digest(str(path.resolve()), stat.st_size, stat.st_mtime_ns)
    if found != expected:
        raise ConfigError(KEY, str(folder), f"a folder holding the published {name}: this one "
                          f"has SHA-256 {found}, expected {expected}")
    return path


@dataclasses.dataclass(frozen=True)
class SimulatorRecord:
    """A Bayesrace record: ``t`` (s), the states ``vx, vy`` (m/s), ``r`` (rad/s) ``(3, N)`` as
    the simulator's Euler made them, the drive (1) and steer (rad) held, ``(N - 1,)`` each."""

    name: str
    t: np.ndarray
    states: np.ndarray
    drive: np.ndarray
    steer: np.ndarray


def read_simulator_record(name: str, data_dir: str | None) -> SimulatorRecord:
    """Read a Bayesrace ``.npz`` (no pickles): ``dstates`` rows 3-5, the Euler trajectory."""
    path = verified(name, data_dir)
    with np.load(path, allow_pickle=False) as data:
        t = np.asarray(data["time"], dtype=float)
        states = np.asarray(data["dstates"], dtype=float)[3:6].copy()
        inputs = np.asarray(data["inputs"], dtype=float)
    N = t.size
    if states.shape != (3, N) or inputs.shape != (2, N - 1) or not (
            np.all(np.isfinite(states)) and np.all(np.isfinite(inputs))):
        raise ConfigError(KEY, data_dir, f"{name} with finite dstates (8 x N) and inputs "
                          "(2 x N-1)")
    return SimulatorRecord(name, t, states, inputs[0].copy(), inputs[1].copy())


@dataclasses.dataclass(frozen=True)
class RacecarLog:
    """A 25 Hz racecar log: ``t`` (s), ``vx``, ``vy`` (m/s), ``r`` (rad/s), ``delta`` (rad)."""

    name: str
    t: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    r: np.ndarray
    delta: np.ndarray


#: The log's columns read, by their header names (units in the header: m/s, rad/s, rad).
LOG_COLUMNS = {"vx": "vx(m/s)", "vy": "vy(m/s)", "r": "omega(rad/s)", "delta": "delta(rad)"}


def read_racecar_log(name: str, data_dir: str | None) -> RacecarLog:
    """Read a racecar CSV log by its header's column names (a header line starting ``# ``)."""
    path = verified(name, data_dir)
    with open(path, encoding="utf-8") as f:
        header = [h.strip() for h in f.readline().lstrip("# ").split(",")]
    missing = [c for c in ("time(s)", *LOG_COLUMNS.values()) if c not in header]
    if missing:
        raise ConfigError(KEY, data_dir, f"{name} with the columns {', '.join(missing)}")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    col = {h: data[:, i] for i, h in enumerate(header)}
    t = col["time(s)"] - col["time(s)"][0]
    if not (np.all(np.isfinite(data)) and np.all(np.diff(t) > 0)):
        raise ConfigError(KEY, data_dir, f"{name} with finite values and increasing time")
    return RacecarLog(name, t, *(col[c].copy() for c in LOG_COLUMNS.values()))
