"""Registers ``problem=emps`` and its report section. Light on purpose: importing this module
reads no data and pulls in neither numba nor scipy.io (the records are read when the problem is
built)."""

from __future__ import annotations

from vpid_bench import hookimpl

from .problem import EmpsProblem
from .report import emps_sections


@hookimpl
def vpid_bench_register_problems(register):
    register("emps", EmpsProblem)


@hookimpl
def vpid_bench_register_report_sections(register):
    register("emps", emps_sections)
