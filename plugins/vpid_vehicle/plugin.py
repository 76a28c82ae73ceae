"""Registers ``problem=vehicle`` and its report sections. Light on purpose: importing this
module pulls in neither numba nor scipy.linalg (the compiled kernel is imported on the first
evaluation), nor pandas or matplotlib (imported when a report section is built)."""

from __future__ import annotations

from vpid_bench import hookimpl

from .problem import VehicleProblem
from .report import vehicle_sections


@hookimpl
def vpid_bench_register_problems(register):
    register("vehicle", VehicleProblem)


@hookimpl
def vpid_bench_register_report_sections(register):
    register("vehicle", vehicle_sections)
