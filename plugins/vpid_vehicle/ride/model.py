"""What a ride model is (:class:`RideModel`, each family fills it in) and how its wheels meet
the road; below both :mod:`.problem` and :mod:`.structures`, so neither imports the other.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np

from ..record_file import Column, Record, Sampler
from . import linear, roads


@dataclasses.dataclass(frozen=True)
class Suspension:
    """A family's suspension elements: each axle's spring and damper parameter, each
    element's axle, and ``elongations(X, known)``, ``J`` ``(n, elements, dof)`` of ``e = J q``."""

    axles: tuple[tuple[str, str], ...]
    axle_of: tuple[int, ...]
    elongations: Callable[[np.ndarray, dict[str, float]], np.ndarray]


@dataclasses.dataclass(frozen=True)
class Wheel:
    """A wheel's track (0 left, 1 right) and delay behind the front axle (s)."""

    track: int
    delay_s: float


class RideModel:
    """A linear ride model: parameters, published sets, sensor sets, wheels and matrices."""

    names: ClassVar[tuple[str, ...]] = ()
    units: ClassVar[tuple[str, ...]] = ()
    sets: ClassVar[dict[str, dict[str, float]]] = {}
    sensors: ClassVar[dict[str, tuple[tuple[str, str], ...]]] = {}
    #: The springs and dampers a richer structure replaces; ``None``: none.
    suspension: ClassVar[Suspension | None] = None

    def wheels(self, known: dict[str, float], speed: float) -> tuple[Wheel, ...]:
        """The wheels of the model at ``speed`` m/s."""
        raise NotImplementedError

    #: The record columns of each wheel's road height (m), in the order of :meth:`wheels`.
    wheel_names: ClassVar[tuple[str, ...]] = ()

    def record_columns(self) -> tuple[Column, ...]:
        """The input columns a user's record may carry: each wheel's road height (m)."""
        return tuple(Column(n, "m") for n in self.wheel_names)

    def needs_record_inputs(self, config: Any) -> str | None:
        """Why a user's record must carry its inputs, or ``None`` (the configuration's serve)."""
        if getattr(config, "road", None) == "iso8608":
            return ("road=iso8608 is a random road, which a record must carry: the road "
                    "height under each wheel; or set problem.road to hump, bump or step")
        return None

    def check_record(self, record: Record) -> None:
        """Refuse a record this model cannot use beyond its columns (default: none)."""

    def inputs_from_record(self, record: Record, sampler: Sampler) -> np.ndarray:
        """The input channels from a record's heights, their rates as :func:`wheel_inputs`."""
        h = sampler.onto_steps(record.t, record.inputs)
        return np.concatenate([h, np.gradient(h, sampler.dt, axis=0)], axis=1)

    def inputs(self, config: Any, known: dict[str, float], dt: float,
               rng: np.random.Generator) -> np.ndarray:
        """The input channels ``(N, r)`` every ``dt`` s (default: :func:`wheel_inputs`)."""
        return wheel_inputs(config, self.wheels(known, config.speed_kmh / 3.6), dt, rng)

    def system(self, X: np.ndarray, known: dict[str, float], sensors: str
               ) -> linear.LinearSystem:
        """The linear systems of the rows ``X``: inputs ``[h.., h'..]``, the ``sensors`` outputs."""
        raise NotImplementedError

    def physical(self, X: np.ndarray, known: dict[str, float]) -> np.ndarray:
        """Rows that describe a vehicle: every parameter finite and > 0, an identified centre
        of gravity (``a1``, ``lf``: behind the front axle) inside the wheelbase ``L``."""
        ok = np.all(np.isfinite(X) & (X > 0), axis=1)
        for j in (j for j, name in enumerate(self.names) if name in ("a1", "lf")):
            ok &= X[:, j] < known["L"]
        return ok

    def box(self, nominal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The search box around the published set (default ``[0.5, 1.5] x`` it)."""
        return 0.5 * nominal, 1.5 * nominal

    def simulate(self, X: np.ndarray, known: dict[str, float], sensors: str, u: np.ndarray,
                 dt: float, solver: str) -> np.ndarray:
        """The ``sensors`` channels ``(n, N, p)`` from rest, by ``exact`` or ``newmark``."""
        system = self.system(X, known, sensors)
        if solver == "exact":
            return linear.simulate(linear.exact_foh(system, dt), u)
        return linear.newmark_outputs(system, dt, u)


def wheel_inputs(cfg: Any, wheels: tuple[Wheel, ...], dt: float,
                 rng: np.random.Generator) -> np.ndarray:
    """``[h_1..h_w, h'_1..h'_w]`` (m, m/s) every ``dt`` s over the record, ``(N, 2 w)``."""
    v = cfg.speed_kmh / 3.6
    t = np.arange(round(cfg.duration_s / dt)) * dt
    tracks = 1 + max(w.track for w in wheels)
    lead = max(w.delay_s for w in wheels)
    x_track = np.arange(-lead * v - 1.0, v * t[-1] + 1.0, min(roads.ISO8608_DX, v * dt))
    x, start = np.maximum(x_track, 0.0), 0.2 * v  # the event 0.2 s into the record
    event = {"hump": roads.hump, "bump": roads.bump, "step": roads.step}.get(cfg.road)
    profiles = [event(x, start) if event else roads.iso8608(x, cfg.road_class, rng)
                for _ in range(tracks)]
    h = np.stack([np.interp(v * (t - w.delay_s), x_track, profiles[w.track]) for w in wheels],
                 axis=1)
    return np.concatenate([h, np.gradient(h, dt, axis=0)], axis=1)
