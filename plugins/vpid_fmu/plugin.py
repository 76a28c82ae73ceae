"""Registers ``problem=fmu``. Light on purpose: importing this module neither imports fmpy nor
opens an FMU (both happen when the problem's config or the problem is built)."""

from __future__ import annotations

from vpid_bench import hookimpl

from .problem import FmuProblem


@hookimpl
def vpid_bench_register_problems(register):
    register("fmu", FmuProblem)
