"""The two EMPS records shipped with this plugin (the EMPS data set of Janot, Gautier and
Brunot, byte for byte from forgi86/sysid-neural-continuous at 956aa7ec, Apache-2.0:
``data/LICENSE``), each verified against its SHA-256 before it is read.
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np

from vpid_bench import VpidBenchError, file_sha256

DATA = Path(__file__).parent / "data"
#: The files this plugin reads and their SHA-256: the one list of them.
SHA256 = {
    "DATA_EMPS.mat": "6cf6814ae14618795da0101aae2bb97ff0c6351b0501b5492751b02b07facf7e",
    "DATA_EMPS_PULSES.mat": "0eab75bb1f6b16228ee78791343a88bf9bfd9a51036ac9807d7b5fc11c0e1704",
}
#: The sampling step of both records (s): the controller's period.
DT = 1e-3


@dataclasses.dataclass(frozen=True)
class EmpsRecord:
    """One record: ``t`` (s, 1 kHz), the motor position ``qm`` (m, encoder quantum 0.05 µm),
    the reference ``qg`` (m), the logged voltage ``vir`` (V), the pulse column as stored (0
    or 5), the loop's ``gtau`` (N/V), ``kp`` (1/s), ``kv`` (V s/m)."""

    name: str
    t: np.ndarray
    qm: np.ndarray
    qg: np.ndarray
    vir: np.ndarray
    pulse: np.ndarray
    gtau: float
    kp: float
    kv: float

    def controller(self) -> np.ndarray:
        """The controller's voltage (V) recomputed from ``qm``: the logged minus it reads pulses."""
        q = self.qm
        qf = 0.5 * (q + np.concatenate([q[:1], q[:-1]]))
        dq = np.diff(qf, prepend=qf[0]) / DT
        return self.kv * (self.kp * (self.qg - q) - dq)


def verified(name: str, folder: Path = DATA) -> Path:
    """The path of data file ``name`` after checking its SHA-256; one-line error otherwise."""
    expected = SHA256[name]
    path = folder / name
    if not path.is_file():
        raise VpidBenchError(f"the EMPS data file {path} is missing (expected SHA-256 "
                             f"{expected}); reinstall vpid-bench")
    found = file_sha256(path)
    if found != expected:
        raise VpidBenchError(f"the EMPS data file {path} has SHA-256 {found}, expected "
                             f"{expected}: it is not the file of the data set")
    return path


def _column(data: dict, key: str, name: str) -> np.ndarray:
    value = np.asarray(data.get(key, np.empty(0)), dtype=float).reshape(-1)
    if value.size == 0 or not np.all(np.isfinite(value)):
        raise VpidBenchError(f"the EMPS data file {name} has no finite column {key!r}")
    return value


@functools.lru_cache(maxsize=4)
def load(name: str, folder: Path = DATA) -> EmpsRecord:
    """Record ``name``, verified and checked: equal lengths, a 1 ms grid from 0, constants > 0."""
    from scipy.io import loadmat

    path = verified(name, folder)
    data = loadmat(path)
    cols = {k: _column(data, k, name) for k in ("t", "qm", "qg", "vir", "gtau", "kp", "kv")}
    N = cols["t"].size
    pulse = (_column(data, "pulses_N", name) if "pulses_N" in data else np.zeros(N))
    if any(cols[k].size != N for k in ("qm", "qg", "vir")) or pulse.size != N:
        raise VpidBenchError(f"the EMPS data file {name}: columns of unequal length")
    if not np.allclose(cols["t"], np.arange(N) * DT, rtol=0, atol=1e-6):
        raise VpidBenchError(f"the EMPS data file {name}: t is not a 1 ms grid from 0")
    consts = {k: float(cols[k][0]) for k in ("gtau", "kp", "kv")}
    if not all(v > 0 for v in consts.values()):
        raise VpidBenchError(f"the EMPS data file {name}: gtau, kp and kv must be > 0")
    for a in (cols["t"], cols["qm"], cols["qg"], cols["vir"], pulse):
        a.setflags(write=False)
    return EmpsRecord(name, cols["t"], cols["qm"], cols["qg"], cols["vir"], pulse, **consts)
