"""What the two single-track models share (so :mod:`.lateral` imports :mod:`.magic`, never
the reverse): the sensor sets, the manoeuvres at the road wheels, or a user's record's steer
angle and speed (:class:`SteeredRecord`).
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar, Literal

import numpy as np

from vpid_bench import ConfigError

from ..record_file import Column, Record, Sampler
from .problem import SuiteConfig, _check


@dataclasses.dataclass(frozen=True)
class SteeredConfig(SuiteConfig):
    """The channels and the manoeuvre (``steer_deg`` at the road wheels, at ``speed_kmh``)."""

    sensors: Literal["yaw", "yaw_ay", "yaw_ay_beta"] = "yaw_ay"
    manoeuvre: Literal["step", "sine"] = "sine"
    steer_deg: float = 2.0
    sine_hz: float = 0.5
    speed_kmh: float = 72.0
    #: The largest steer (degrees) and why.
    MAX_STEER: ClassVar[tuple[float, str]] = (10.0, " (linear tyres: small slip angles)")

    def _check_own(self) -> None:
        top, why = self.MAX_STEER
        _check([
            ("steer_deg", 0 < self.steer_deg <= top, f"an angle in (0, {top:g}] degrees{why}"),
            ("sine_hz", 0 < self.sine_hz <= 5, "a frequency in (0, 5] Hz"),
            ("speed_kmh", 10 <= self.speed_kmh <= 200, "a speed in [10, 200] km/h"),
        ], self)


#: How far a record's speed may stray from its mean (fraction): both single-track models hold
#: the forward speed constant.
SPEED_TOLERANCE = 0.02


class SteeredRecord:
    """What the single-track models share: the sensor sets, the forward speed ``vx`` (m/s:
    the problem's, or a user's record's mean) and the inputs, the configured manoeuvre or a
    record's ``delta`` at the road wheels (rad) and ``vx``."""

    #: The measured channels of each sensor set, with their units.
    sensors: ClassVar[dict[str, tuple[tuple[str, str], ...]]] = {
        "yaw": (("r", "rad/s"),),
        "yaw_ay": (("r", "rad/s"), ("ay", "m/s²")),
        "yaw_ay_beta": (("r", "rad/s"), ("ay", "m/s²"), ("beta", "rad")),
    }

    def __init__(self, vx: float = 20.0) -> None:
        self.vx = vx

    def inputs(self, config: Any, known: dict[str, float], dt: float,
               rng: np.random.Generator) -> np.ndarray:
        """The steer angle at the road wheels (rad) ``(N, 1)`` of the configured manoeuvre:
        ``step`` to ``steer_deg`` over 0.2 s from 0.5 s, held, or ``sine`` at ``sine_hz`` from
        0.5 s."""
        t = np.arange(round(config.duration_s / dt)) * dt
        amp = np.deg2rad(config.steer_deg)
        if config.manoeuvre == "step":
            delta = amp * np.clip((t - 0.5) / 0.2, 0.0, 1.0)
        else:
            delta = np.where(t >= 0.5, amp * np.sin(2 * np.pi * config.sine_hz * (t - 0.5)), 0)
        return delta[:, None]

    def record_columns(self) -> tuple[Column, ...]:
        return (Column("delta", "rad"), Column("vx", "m/s"))

    def needs_record_inputs(self, config: Any) -> str | None:
        return None  # the configured manoeuvre is deterministic

    def check_record(self, record: Record) -> None:
        """Refuse a ``vx`` straying more than :data:`SPEED_TOLERANCE` from its mean."""
        if record.inputs is None:
            return
        vx = record.inputs[:, 1]
        mean = float(np.mean(vx))
        off = np.abs(vx - mean) > SPEED_TOLERANCE * abs(mean)
        if mean <= 0 or np.any(off):
            k = int(np.flatnonzero(off)[0]) if np.any(off) else 0
            raise ConfigError("problem.reference.file", record.path,
                              f"a column vx (m/s) > 0 held within {100 * SPEED_TOLERANCE:g} % "
                              f"of its mean {mean:.4g} m/s (the single-track models hold the "
                              f"speed constant); data row {k + 1} has {vx[k]:.4g} m/s")

    def inputs_from_record(self, record: Record, sampler: Sampler) -> np.ndarray:
        """The steer angle onto the model's steps; the speed becomes the record's mean ``vx``."""
        self.vx = float(np.mean(record.inputs[:, 1]))
        return sampler.onto_steps(record.t, record.inputs[:, :1])
