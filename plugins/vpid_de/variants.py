"""DE1-DE8 of Gökdağ (2014), Table I: each a :class:`~vpid_de.base.DifferentialEvolution`
with its ``Params`` (defaults: Table I's values; ``optimizer=de1 optimizer.K=0.4`` is an
unknown key), a mutation kernel and, where the scale factor varies, :meth:`factors`."""

from __future__ import annotations

import dataclasses
from typing import Any, Literal

from vpid_bench import ConfigError

from .base import DEParams, DifferentialEvolution, Draw

#: the choices of DE8's ``eq15`` key
Eq15Form = Literal["das", "printed"]


@dataclasses.dataclass(frozen=True)
class FixedFParams(DEParams):
    """DE1-DE5: a constant scale factor, Table I's F = 0.6, CR = 0.9 (the paper's range 0:2)."""

    F: float = 0.6

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 0.0 < self.F <= 2.0:
            raise ConfigError("optimizer.F", self.F, "a number in (0, 2]")


@dataclasses.dataclass(frozen=True)
class DE6Params(DEParams):
    """DE6, Eq. 13 (Karaboğa and Ökdem): K = 0.5, CR = 0.8, F ~ U(F_min, F_max) = U(-2, 2)
    drawn per ``draw``: ``generation`` (the paper) or ``vector`` (per target vector)."""

    CR: float = 0.8
    K: float = 0.5
    F_min: float = -2.0
    F_max: float = 2.0
    draw: Draw = "generation"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.F_min <= self.F_max:
            raise ConfigError("optimizer.F_max", self.F_max, f"a number >= F_min={self.F_min}")


@dataclasses.dataclass(frozen=True)
class DE7Params(DEParams):
    """DE7, Eq. 14 (Das et al., random scale factor): CR = 0.9, R ~ U(R_min, R_max) =
    U(0.5, 1) drawn per ``draw``: ``generation`` (the paper) or ``vector`` (Das et al.'s)."""

    R_min: float = 0.5
    R_max: float = 1.0
    draw: Draw = "generation"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.R_min <= self.R_max:
            raise ConfigError("optimizer.R_max", self.R_max, f"a number >= R_min={self.R_min}")


@dataclasses.dataclass(frozen=True)
class DE8Params(DEParams):
    """DE8, Eq. 14 with Eq. 15 (Das et al., time-varying scale factor): CR = 0.9, R_max =
    1.2, R_min = 0.4; ``eq15``: :func:`eq15`'s form."""

    R_max: float = 1.2
    R_min: float = 0.4
    eq15: Eq15Form = "das"


def eq15(k: int, k_max: int, r_max: float, r_min: float, form: Eq15Form = "das") -> float:
    """Eq. 15's scale factor after ``k`` generations of ``k_max`` (``iterations``): ``das``
    ``(r_max - r_min)(k_max - k)/k_max + r_min`` (Das et al. 2005), ``printed`` without the
    ``+ r_min`` (as the paper prints it: 0.8 towards 0)."""
    r = (r_max - r_min) * (k_max - k) / k_max
    return r + r_min if form == "das" else r


def _fixed_f(label: str, mutation: str, doc: str) -> type[DifferentialEvolution]:
    """A variant with a constant scale factor (DE1-DE5), named by its label."""
    return type(label.upper(), (DifferentialEvolution,), {
        "__doc__": doc, "__module__": __name__, "Params": FixedFParams, "mutation": mutation,
        "label": label})


DE1 = _fixed_f("de1", "rand1", "Eq. 7, rand/1: ``v_i = x_r1 + F (x_r2 - x_r3)``.")
DE2 = _fixed_f("de2", "best2", "Eq. 9, best/2: ``v_i = x_best + F (x_r1 + x_r2 - x_r3 - x_r4)``.")
DE3 = _fixed_f("de3", "best1", "Eq. 10, best/1: ``v_i = x_best + F (x_r1 - x_r2)``.")
DE4 = _fixed_f("de4", "current_to_best1", "Eq. 11, current-to-best/1: ``v_i = x_i + F (x_best "
               "- x_i) + F (x_r1 - x_r2)``.")
DE5 = _fixed_f("de5", "rand2", "Eq. 12, rand/2: ``v_i = x_r1 + F (x_r2 - x_r3) + F (x_r4 - "
               "x_r5)``.")


class DE6(DifferentialEvolution):
    """Eq. 13: ``v_i = x_i + K (x_r1 - x_i) + F (x_r2 - x_r3)``, F ~ U(-2, 2)."""

    Params, mutation, label = DE6Params, "current_to_rand1", "de6"

    def factors(self) -> dict[str, Any]:
        p = self.params
        return {"F": self.draw_factor(p.F_min, p.F_max, p.draw), "K": p.K}


class DE7(DifferentialEvolution):
    """Eq. 14: ``v_i = x_r1 + R (x_r2 - x_r3)``, R ~ U(0.5, 1)."""

    Params, mutation, label = DE7Params, "rand1", "de7"

    def factors(self) -> dict[str, Any]:
        p = self.params
        return {"F": self.draw_factor(p.R_min, p.R_max, p.draw)}


class DE8(DifferentialEvolution):
    """Eq. 14 with Eq. 15: ``v_i = x_r1 + R_k (x_r2 - x_r3)``, R_k decreasing linearly."""

    Params, mutation, label = DE8Params, "rand1", "de8"

    def factors(self) -> dict[str, Any]:
        p = self.params
        return {"F": eq15(self.generation, p.iterations, p.R_max, p.R_min, p.eq15)}


#: command-line name -> optimizer class
STRATEGIES: dict[str, type[DifferentialEvolution]] = {
    cls.label: cls for cls in (DE1, DE2, DE3, DE4, DE5, DE6, DE7, DE8)
}
