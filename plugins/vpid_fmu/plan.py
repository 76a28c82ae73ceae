"""What a config makes of an FMU's variables: **identified** (``problem.parameters``; by
default every real parameter, ``fixed`` or ``tunable``, with a ``min`` and a ``max``), each
boxed by them or by ``problem.bounds.<name>``; **known**, every other real parameter at its
start value or ``problem.known.<name>``, listed with its source.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from vpid_bench import ConfigError

REAL = ("Real", "Float64")
SET_BY_YOU = "set by you (problem.known)"
FMU_START = "the FMU's start value"


@dataclasses.dataclass(frozen=True)
class Variable:
    """An FMU variable the problem uses (``None`` where the description gives nothing)."""

    name: str
    vr: int
    unit: str | None
    start: float | None
    lower: float | None
    upper: float | None


def _num(text: Any) -> float | None:
    if text is None:
        return None
    try:
        value = float(text)
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def _variable(v: Any) -> Variable:
    unit = v.unit if v.unit is not None else (
        v.declaredType.unit if getattr(v, "declaredType", None) is not None else None)
    return Variable(v.name, int(v.valueReference), unit, _num(v.start), _num(v.min),
                    _num(v.max))


def _box_of(name: str, value: Any) -> tuple[float, float]:
    key = f"problem.bounds.{name}"
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise ConfigError(key, value, "[lower, upper], two numbers")
    try:
        lo, hi = float(value[0]), float(value[1])
    except (TypeError, ValueError):
        raise ConfigError(key, value, "[lower, upper], two numbers") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ConfigError(key, value, "[lower, upper], finite with lower < upper")
    return lo, hi


@dataclasses.dataclass(frozen=True)
class Plan:
    """The identified parameters and their box, the known quantities, the inputs and outputs."""

    identified: tuple[Variable, ...]
    lower: np.ndarray
    upper: np.ndarray
    box_sources: tuple[str, ...]
    known: tuple[tuple[Variable, float, str], ...]
    inputs: tuple[Variable, ...]
    outputs: tuple[Variable, ...]

    def known_list(self) -> list[dict[str, Any]]:
        """``[{"name", "value", "unit", "source"}]`` of the known quantities."""
        return [{"name": v.name, "value": value, "unit": v.unit or "", "source": source}
                for v, value, source in self.known]

    def box_list(self) -> list[dict[str, Any]]:
        return [{"name": v.name, "lower": float(lo), "upper": float(hi), "unit": v.unit or "",
                 "source": src} for v, lo, hi, src in
                zip(self.identified, self.lower, self.upper, self.box_sources)]

    def start_values(self) -> tuple[np.ndarray, np.ndarray]:
        """The known quantities' value references and values, set before each simulation."""
        vrs = np.array([v.vr for v, _, _ in self.known], dtype=np.uint32)
        return vrs, np.array([value for _, value, _ in self.known], dtype=float)


def _chosen(params: dict[str, Variable], parameters: Sequence[str] | None,
            bounds: Mapping[str, Any]) -> list[str]:
    if parameters is None:
        chosen = [n for n, v in params.items() if (v.lower is not None and v.upper is not None
                                                   and v.lower < v.upper) or n in bounds]
        if not chosen:
            raise ConfigError("problem.parameters", None, "the parameters to identify: this "
                              "FMU has no real parameter with a min and a max; name them, "
                              "problem.parameters=[a,b] with problem.bounds.a=[lo,hi]")
        return chosen
    chosen = list(parameters)
    for name in chosen:
        if name not in params:
            raise ConfigError("problem.parameters", name, "real parameters of the FMU: "
                              + ", ".join(list(params)[:40]))
    if len(set(chosen)) != len(chosen) or not chosen:
        raise ConfigError("problem.parameters", chosen, "distinct names, at least one")
    return chosen


def _boxes(params: dict[str, Variable], chosen: list[str], bounds: Mapping[str, Any]
           ) -> tuple[list[float], list[float], list[str]]:
    for name in bounds:
        if name not in chosen:
            raise ConfigError(f"problem.bounds.{name}", bounds[name], "a box of an identified "
                              "parameter: one of " + ", ".join(chosen))
    lower, upper, sources = [], [], []
    for name in chosen:
        v = params[name]
        if name in bounds:
            lo, hi = _box_of(name, bounds[name])
            src = "set by you (problem.bounds)"
        elif v.lower is not None and v.upper is not None and v.lower < v.upper:
            lo, hi, src = v.lower, v.upper, "the FMU's min and max"
        else:
            raise ConfigError(f"problem.bounds.{name}", None, "[lower, upper]: the FMU gives "
                              f"parameter {name} no min and max")
        lower.append(lo)
        upper.append(hi)
        sources.append(src)
    return lower, upper, sources


def _stated(params: dict[str, Variable], chosen: list[str], known: Mapping[str, Any]
            ) -> list[tuple[Variable, float, str]]:
    stated = []
    for name, value in known.items():
        if name in chosen:
            raise ConfigError(f"problem.known.{name}", value, "a quantity not identified "
                              f"({name} is in problem.parameters)")
        if name not in params:
            raise ConfigError(f"problem.known.{name}", value, "a real parameter of the FMU: "
                              + ", ".join(n for n in params if n not in chosen)[:400])
        number = _num(value) if not isinstance(value, bool) else None
        if number is None:
            raise ConfigError(f"problem.known.{name}", value, "a finite number")
        stated.append((params[name], number, SET_BY_YOU))
    for name, v in params.items():
        if name not in chosen and name not in known and v.start is not None:
            stated.append((v, v.start, FMU_START))
    return stated


def plan(description: Any, parameters: Sequence[str] | None, bounds: Mapping[str, Any],
         known: Mapping[str, Any]) -> Plan:
    """The plan of an FMU's description under the config keys, or a :class:`ConfigError`."""
    variables = [v for v in description.modelVariables if v.type in REAL]
    params = {v.name: _variable(v) for v in variables if v.causality == "parameter"
              and v.variability in ("fixed", "tunable")}
    inputs = tuple(_variable(v) for v in variables if v.causality == "input")
    outputs = tuple(_variable(v) for v in variables if v.causality == "output")
    others = [v.name for v in description.modelVariables if v.causality == "input"
              and v.type not in REAL]
    if others:
        raise ConfigError("problem.fmu", others[0], "an FMU whose inputs are real numbers "
                          f"(input {others[0]} is not)")
    if not outputs:
        raise ConfigError("problem.fmu", description.modelName, "an FMU with real outputs")
    chosen = _chosen(params, parameters, bounds)
    lower, upper, sources = _boxes(params, chosen, bounds)
    stated = _stated(params, chosen, known)
    return Plan(tuple(params[n] for n in chosen), np.array(lower), np.array(upper),
                tuple(sources), tuple(stated), inputs, outputs)
