"""Registers ``problem=vehicle``. Light on purpose: importing this module pulls in neither
numba nor scipy.linalg (the compiled kernel is imported on the first evaluation)."""

from __future__ import annotations

from vpid_bench import hookimpl

from .problem import VehicleProblem


@hookimpl
def vpid_bench_register_problems(register):
    register("vehicle", VehicleProblem)
