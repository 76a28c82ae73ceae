"""Registers the vehicle problems and their report sections; imports neither numba,
scipy.linalg, pandas nor matplotlib (each comes when first needed)."""

from __future__ import annotations

from vpid_bench import hookimpl

from .model_error_report import model_error_sections
from .problem import VehicleProblem
from .report import vehicle_sections
from .ride.bayesrace import BayesraceProblem
from .ride.full import RideFullProblem
from .ride.half import RideHalfProblem
from .ride.lateral import LateralProblem
from .ride.magic import LateralMFProblem
from .ride.quarter import RideQuarterProblem
from .ride.racecar import RacecarProblem
from .ride.suites import MEMBERS
from .structure_report import structure_sections


@hookimpl
def vpid_bench_register_problems(register):
    register("vehicle", VehicleProblem)
    register("ride_quarter", RideQuarterProblem)
    register("ride_half", RideHalfProblem)
    register("ride_full", RideFullProblem)
    register("lateral", LateralProblem)
    register("lateral_mf", LateralMFProblem)
    register("bayesrace", BayesraceProblem)
    register("racecar", RacecarProblem)
    for member in MEMBERS:
        register(member.name, member)


@hookimpl
def vpid_bench_register_report_sections(register):
    register("vehicle", vehicle_sections)
    for problem in (RideQuarterProblem, RideHalfProblem, RideFullProblem, *MEMBERS):
        if issubclass(problem, (RideQuarterProblem, RideHalfProblem, RideFullProblem)):
            register(problem.name, structure_sections)
    for member in MEMBERS:  # the section itself says nothing where a member has no entry
        if getattr(member.Config(), "record_model", "linear") != "linear":
            register(member.name, model_error_sections)
