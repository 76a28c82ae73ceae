"""The named suites (docs/suite.md): each member a problem of its own (a ride or lateral
problem with its defaults, which the command line may still change) registered under a stable
name with its suites (``vpid-bench -m suite=smoke optimizer=...`` sweeps them): ``smoke``
(every family once, short), ``structures`` (richer structures on the records they made),
``vpid1`` (the suite proper, at the archive's protocol: 1,000·D evaluations by default).
"""

from __future__ import annotations

import dataclasses
import typing
from typing import Any

from .full import RideFullProblem
from .half import RideHalfProblem
from .lateral import LateralProblem
from .magic import LateralMFProblem
from .quarter import RideQuarterProblem

#: The ``smoke`` protocol: 2 s records, 10 generations.
SMOKE = dict(iterations=10, duration_s=2.0)
#: Evaluations per parameter of a ``vpid1`` member's default budget (the archive's budget).
VPID1_BUDGET_PER_DIM = 1000


def protocol(base: type, suites: tuple[str, ...]) -> dict[str, Any]:
    """The protocol defaults a suite gives each member (its own come after)."""
    if "smoke" in suites:
        return dict(SMOKE)
    if "vpid1" in suites:
        ps = typing.cast(int, base.Config().ps)
        dim = len(base.model.names)
        return {"iterations": VPID1_BUDGET_PER_DIM * dim // ps - 1}
    return {}


def member(base: type, name: str, suites: tuple[str, ...], **defaults: Any) -> type:
    """A subclass of ``base`` named ``name`` in ``suites``, with its suites' and own defaults."""
    defaults = {**protocol(base, suites), **defaults}
    hints = typing.get_type_hints(base.Config)
    unknown = set(defaults) - set(hints)
    if unknown:
        raise TypeError(f"suite member {name}: {base.name} has no key {sorted(unknown)}")
    config = dataclasses.make_dataclass(
        f"{name}_Config", [(k, hints[k], dataclasses.field(default=v))
                           for k, v in defaults.items()],
        bases=(base.Config,), frozen=True)
    config.__doc__ = (f"Suite member {name}: {base.name} with "
                      + ", ".join(f"{k}={v}" for k, v in defaults.items())
                      + f". Other keys: {base.name}'s.")
    cls = type(name, (base,), {"Config": config, "name": name, "suites": suites,
                               "__doc__": config.__doc__, "__module__": __name__})
    # Importable by name from this module, so pickle can send a member (and a config of
    # one) to a worker process; classes made by type() otherwise claim a module they are
    # not in, and the job falls back to running in the command's own process.
    config.__module__ = __name__
    config.__qualname__ = config.__name__
    globals()[name] = cls
    globals()[config.__name__] = config
    return cls


MEMBERS: tuple[type, ...] = (
    member(RideQuarterProblem, "smoke_quarter", ("smoke",)),
    member(RideHalfProblem, "smoke_half", ("smoke",)),
    member(RideFullProblem, "smoke_full", ("smoke",)),
    member(LateralProblem, "smoke_lateral", ("smoke",)),
    member(LateralMFProblem, "smoke_lateral_mf", ("smoke",)),
    member(RideQuarterProblem, "vpid1_q_golden_hump", ("vpid1",)),
    member(RideQuarterProblem, "vpid1_q_golden_iso_c", ("vpid1",), road="iso8608",
           speed_kmh=80.0, sensors="body"),
    member(RideQuarterProblem, "vpid1_q_bus_step", ("vpid1",), parameter_set="quarter_bus",
           road="step", sensors="body_wheel_stroke"),
    member(RideQuarterProblem, "vpid1_q_golden_bilinear", ("vpid1",),
           record_model="bilinear_damper"),
    member(RideHalfProblem, "vpid1_h_gokdag_bump", ("vpid1",), road="bump", speed_kmh=20.0),
    member(RideHalfProblem, "vpid1_h_gokdag_iso_b", ("vpid1",), road="iso8608",
           road_class="B", speed_kmh=60.0, sensors="body_pitch_rate"),
    member(RideHalfProblem, "vpid1_h_jazar_hump", ("vpid1",), parameter_set="jazar_half",
           sensors="body_wheel"),
    member(RideHalfProblem, "vpid1_h_gokdag_seat_iso_c", ("vpid1",), record_model="seat",
           road="iso8608", speed_kmh=60.0),
    member(RideFullProblem, "vpid1_f_jazar_hump", ("vpid1",)),
    member(RideFullProblem, "vpid1_f_jazar_iso_c", ("vpid1",), road="iso8608",
           speed_kmh=60.0, sensors="body_rates"),
    member(RideFullProblem, "vpid1_f_sym_iso_d", ("vpid1",), parameter_set="jazar_symmetric",
           road="iso8608", road_class="D", sensors="body_wheel"),
    member(RideFullProblem, "vpid1_f_bmw_iso_c", ("vpid1",), parameter_set="bmw320i",
           road="iso8608", speed_kmh=60.0),
    member(LateralProblem, "vpid1_l_civic_sine", ("vpid1",)),
    member(LateralProblem, "vpid1_l_smart_step", ("vpid1",), parameter_set="smart",
           manoeuvre="step", sensors="yaw"),
    member(LateralProblem, "vpid1_l_civic_step_beta", ("vpid1",), manoeuvre="step",
           sensors="yaw_ay_beta"),
    member(LateralProblem, "vpid1_l_civic_model_error", ("vpid1",), record_model="magic_formula",
           steer_deg=4.0),
    member(LateralMFProblem, "vpid1_mf_civic_sine", ("vpid1",)),
    # the richer structures (issue 43) on the records they made, which the linear model misfits
    member(RideQuarterProblem, "structures_q_golden_bilinear", ("structures",),
           damper="bilinear"),
    member(RideHalfProblem, "structures_h_gokdag_bilinear", ("structures",),
           damper="bilinear", sensors="body_wheel"),
    member(RideFullProblem, "structures_f_jazar_bilinear", ("structures",),
           damper="bilinear", sensors="body_wheel"),
)
