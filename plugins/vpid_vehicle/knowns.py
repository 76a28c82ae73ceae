"""Known quantities and boxes: what a vehicle problem states rather than identifies, explicit
and settable because the answer depends on them (scaling every mass, stiffness and damping by
one factor leaves a ride record unchanged): ``problem.known.<name>=value`` states a quantity
or fixes an identified one, ``=free`` identifies a known one, ``problem.bounds.<name>=[lo,hi]``
sets a box (SI units; docs/own-record.md). :func:`plan` checks the keys into a :class:`Plan`;
:class:`StatedModel` presents a ride model under it; the records keep
:meth:`Plan.known_list` and :meth:`Plan.box_list` (the report's "Assumed").
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from vpid_bench import ConfigError

#: The value of ``problem.known.<name>`` that identifies a known quantity instead.
FREE = "free"

#: Known quantities: unit (SI) and what they are.
QUANTITIES: dict[str, tuple[str, str]] = {
    "kt": ("N/m", "tyre stiffness"),
    "ct": ("N s/m", "tyre damping"),
    "kt1": ("N/m", "front tyre stiffness"),
    "kt2": ("N/m", "rear tyre stiffness"),
    "kR": ("N m/rad", "front anti-roll bar"),
    "m": ("kg", "vehicle mass (weighed)"),
    "L": ("m", "wheelbase"),
    "a1": ("m", "centre of gravity to the front axle"),
    "a2": ("m", "centre of gravity to the rear axle"),
    "yL": ("m", "centre of gravity to the left wheels"),
    "yR": ("m", "centre of gravity to the right wheels"),
    "lf": ("m", "centre of gravity to the front axle"),
    "E": ("1", "tyre curvature factor (Magic Formula)"),
}
#: Units of quantities that scale together, leaving a record unchanged (masses, stiffnesses,
#: dampings); every other unit is geometry (a length or shape factor, never freed).
SCALE_UNITS = frozenset({"kg", "kg m²", "kg m^2", "N/m", "N s/m", "N/rad", "N", "N m/rad"})
#: Units of quantities that may be zero (a damping, an anti-roll bar, a curvature factor).
MAY_BE_ZERO = frozenset({"N s/m", "N m/rad", "1"})


@dataclasses.dataclass(frozen=True)
class Plan:
    """What a problem identifies (the model's names not fixed, then those freed) and states
    under a config: every quantity's value and unit, each stated one's source, the boxes."""

    parameter_set: str
    model_names: tuple[str, ...]
    identified: tuple[str, ...]
    units: dict[str, str]
    values: dict[str, float]
    sources: dict[str, str]
    boxes: dict[str, tuple[float, float]]

    @property
    def reparametrised(self) -> bool:
        """Whether a quantity is fixed or freed."""
        return self.identified != self.model_names

    @property
    def freed(self) -> tuple[str, ...]:
        return tuple(n for n in self.identified if n not in self.model_names)

    def known_list(self) -> list[dict[str, Any]]:
        """The stated quantities as ``problem.info.known`` keeps them."""
        return [{"name": n, "value": float(self.values[n]), "unit": self.units[n],
                 "source": self.sources[n],
                 "what": QUANTITIES[n][1] if n in QUANTITIES else "fixed by you"}
                for n in self.values if n not in self.identified]

    def box_list(self, lower: Sequence[float], upper: Sequence[float]) -> list[dict[str, Any]]:
        """The box of each identified quantity with its source (``problem.info.box``)."""
        return [{"name": n, "lower": float(lo), "upper": float(hi), "unit": self.units[n],
                 "source": (f"set by you (problem.bounds.{n})" if n in self.boxes else
                            f"[0.5, 1.5] x parameter set {self.parameter_set}")}
                for n, lo, hi in zip(self.identified, lower, upper, strict=True)]


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _check_value(name: str, value: Any, unit: str, geometry_of: dict[str, float]) -> float:
    key = f"problem.known.{name}"
    x = _number(value)
    zero_ok = unit in MAY_BE_ZERO
    if x is None or x < 0 or (x == 0 and not zero_ok):
        raise ConfigError(key, value, f"a finite value {'>= 0' if zero_ok else '> 0'} "
                          f"({unit}), or {FREE} to identify it")
    if name in ("a1", "lf") and "L" in geometry_of and not x < geometry_of["L"]:
        raise ConfigError(key, value, f"a length < the wheelbase L = {geometry_of['L']:g} m")
    return x


def _check_identifiable(problem: str, identified: Sequence[str], values: Mapping[str, float],
                        units: Mapping[str, str], freed: Sequence[str]) -> None:
    group = [n for n in values if units[n] in SCALE_UNITS]
    stated = [n for n in group if n not in identified and values[n] != 0]
    if freed and not stated:
        name = freed[0]
        others = ", ".join(n for n in group if n != name and values[n] != 0)
        raise ConfigError(f"problem.known.{name}", FREE,
                          f"a stated value: freeing it leaves {problem} unidentifiable by "
                          "scaling (every mass, stiffness and damping times one factor gives "
                          f"the same record); state one of {others} with problem.known.<name>"
                          "=value first")
    if not identified:
        raise ConfigError("problem.known", dict(values), "at least one quantity left to "
                          "identify")


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


def _boxes(raw: Mapping[str, Any], identified: Sequence[str]) -> dict[str, tuple[float, float]]:
    out = {}
    for name, value in raw.items():
        key = f"problem.bounds.{name}"
        if name not in identified:
            raise ConfigError(key, _plain(value), "the name of an identified quantity, one of "
                              + ", ".join(identified))
        pair = list(value) if isinstance(value, Sequence) and not isinstance(value, str) \
            else None
        nums = [_number(v) for v in pair] if pair is not None else []
        if len(nums) != 2 or None in nums or not 0 < nums[0] < nums[1]:
            raise ConfigError(key, _plain(value), "[lo, hi] with 0 < lo < hi, finite (the box of "
                              f"{name} in SI units)")
        out[name] = (float(nums[0]), float(nums[1]))
    return out


def plan(config: Any, model: Any, problem: str = "this problem") -> Plan:
    """The :class:`Plan` of ``config.known`` and ``config.bounds`` (frozen by
    :func:`~vpid_bench.freeze_fields`), or a :class:`ConfigError`."""
    pset = config.parameter_set
    published = dict(model.sets[pset])
    units = dict(zip(model.names, model.units, strict=True))
    units.update({n: QUANTITIES[n][0] if n in QUANTITIES else "" for n in published
                  if n not in units})
    values, sources = dict(published), {n: f"parameter set {pset}" for n in published}
    fixed, freed = [], []
    for name, value in config.known.items():
        if name not in published:
            raise ConfigError(f"problem.known.{name}", value, "one of "
                              + ", ".join(published) + f" (the quantities of {problem})")
        if value == FREE:
            if name in model.names:
                continue  # identified already
            if units[name] not in SCALE_UNITS:
                raise ConfigError(f"problem.known.{name}", value, f"a value ({units[name]}):"
                                  f" {name} is geometry {problem} states and cannot identify")
            freed.append(name)
            continue
        values[name] = _check_value(name, value, units[name], values)
        sources[name] = f"set by you (problem.known.{name})"
        if name in model.names:
            fixed.append(name)
    identified = tuple([n for n in model.names if n not in fixed] + freed)
    _check_identifiable(problem, identified, values, units, freed)
    boxes = _boxes(dict(config.bounds), identified)
    for name in freed:
        if values[name] == 0 and name not in boxes:
            raise ConfigError(f"problem.known.{name}", FREE, f"a box for it too: its value in "
                              f"parameter set {pset} is 0, so give problem.bounds.{name}="
                              "[lo,hi]")
    return Plan(pset, tuple(model.names), identified, units, values, sources, boxes)


class StatedModel:
    """A ride model under a :class:`Plan`: the identified names, the plan's values, the
    user's boxes; ``simulate``, ``system``, ``physical`` take identified rows and call the
    model with its own rows and known values; everything else is the model's."""

    def __init__(self, base: Any, plan: Plan) -> None:
        self.base = base
        self.plan = plan
        self.names = plan.identified
        self.units = tuple(plan.units[n] for n in plan.identified)
        self.sets = {plan.parameter_set: dict(plan.values)}
        self._col = {n: j for j, n in enumerate(plan.identified)}

    def __getattr__(self, name: str) -> Any:
        base = self.__dict__.get("base")
        if base is None or name.startswith("__"):  # copy and pickle probe before __init__
            raise AttributeError(name)
        return getattr(base, name)

    def _model_rows(self, X: np.ndarray, known: Mapping[str, float]
                    ) -> list[tuple[np.ndarray, dict[str, float]]]:
        """The model's rows with their known values: one group, or one per row if one is freed."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if not self.plan.reparametrised:
            return [(X, dict(known))]
        full = np.empty((X.shape[0], len(self.plan.model_names)))
        for j, name in enumerate(self.plan.model_names):
            full[:, j] = X[:, self._col[name]] if name in self._col else known[name]
        base_known = {k: v for k, v in known.items() if k not in self.plan.model_names}
        if not self.plan.freed:
            return [(full, base_known)]
        return [(full[i:i + 1], {**base_known, **{n: float(X[i, self._col[n]])
                                                  for n in self.plan.freed}})
                for i in range(X.shape[0])]

    def box(self, nominal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The model's box, ``[0.5, 1.5] x`` a freed quantity's value, then the user's."""
        v = self.plan.values
        lo, hi = self.base.box(np.array([v[n] for n in self.plan.model_names]))
        lower = {n: lo[j] for j, n in enumerate(self.plan.model_names)}
        upper = {n: hi[j] for j, n in enumerate(self.plan.model_names)}
        for n in self.plan.freed:
            lower[n], upper[n] = 0.5 * v[n], 1.5 * v[n]
        for n, (a, b) in self.plan.boxes.items():
            lower[n], upper[n] = a, b
        return (np.array([lower[n] for n in self.names], dtype=float),
                np.array([upper[n] for n in self.names], dtype=float))

    def physical(self, X: np.ndarray, known: dict[str, float]) -> np.ndarray:
        ok = [self.base.physical(rows, k) for rows, k in self._model_rows(X, known)]
        out = np.concatenate(ok)
        if self.plan.freed:
            F = np.atleast_2d(X)[:, [self._col[n] for n in self.plan.freed]]
            out &= np.all(np.isfinite(F) & (F >= 0), axis=1)
        return out

    def system(self, X: np.ndarray, known: dict[str, float], sensors: str, *args: Any) -> Any:
        groups = self._model_rows(X, known)
        if len(groups) != 1:
            raise NotImplementedError("one system per row where a known quantity is freed")
        rows, k = groups[0]
        return self.base.system(rows, k, sensors, *args)

    def simulate(self, X: np.ndarray, known: dict[str, float], sensors: str, u: np.ndarray,
                 dt: float, solver: str) -> np.ndarray:
        return np.concatenate([self.base.simulate(rows, k, sensors, u, dt, solver)
                               for rows, k in self._model_rows(X, known)])


def check_config(config: Any, model: Any) -> Plan:
    """:func:`plan` of a ride config as it is built (the pre-flight refuses a bad key); no
    quantity fixed or freed for a richer model's simulated record (made from the model's
    own vector)."""
    p = plan(config, model)
    richer = getattr(config, "record_model", "linear")
    if p.reparametrised and config.reference.file is None and richer != "linear":
        name = next(n for n in (*p.model_names, *p.freed) if n not in p.identified
                    or n in p.freed)
        raise ConfigError(f"problem.known.{name}", config.known.get(name),
                          f"no fixed or freed quantity with record_model={richer} (a "
                          "simulated record of a richer model); state values only, or fit "
                          "a record of your own (problem.reference.file)")
    return p


def input_text(config: Any, input_names: Sequence[str], columns: Mapping[str, str]) -> str:
    """Which input a fit of a user's record used, in words (``problem.info.input``)."""
    if input_names:
        named = [n if columns.get(n, n) == n else f"{n} (column {columns[n]})"
                 for n in input_names]
        return "the record's " + ", ".join(named)
    what = []
    for key in ("road", "road_class", "manoeuvre", "steer_deg", "speed_kmh"):
        if hasattr(config, key):
            what.append(f"{key}={getattr(config, key)}")
    return "the configured input (problem.reference.input=config: " + ", ".join(what) + ")"


def info(problem: Any) -> dict[str, Any]:
    """What a ride problem's ``describe()`` adds: ``known``, ``box`` and, if given, ``input``."""
    model, config = problem.model, problem.config
    p = model.plan if isinstance(model, StatedModel) else plan(config, model)
    lower, upper = model.box(problem.nominal)
    out: dict[str, Any] = {"known": p.known_list(), "box": p.box_list(lower, upper)}
    source = getattr(problem, "input_source", None)
    if source:
        out["input"] = source
    return out
