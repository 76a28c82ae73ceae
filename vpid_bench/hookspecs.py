"""The hooks a vpid-bench plugin may implement.

A plugin is a module (or object) named by an entry point of group ``vpid_bench`` in its
distribution's metadata. It implements one or both hooks below with the
:data:`vpid_bench.hookimpl` marker. Each hook receives a ``register`` callback; calling it
adds a problem or an optimizer under a name. The built-in plugins use exactly this path.
"""

from __future__ import annotations

import pluggy

PROJECT_NAME = "vpid_bench"

hookspec = pluggy.HookspecMarker(PROJECT_NAME)
hookimpl = pluggy.HookimplMarker(PROJECT_NAME)


@hookspec
def vpid_bench_register_optimizers(register):  # type: ignore[no-untyped-def]
    """Register optimizers: call ``register(name, optimizer_class)`` once per optimizer.

    ``optimizer_class`` subclasses :class:`vpid_bench.api.Optimizer` and has a ``Params``
    frozen dataclass; ``name`` becomes ``optimizer=<name>`` on the command line.
    """


@hookspec
def vpid_bench_register_problems(register):  # type: ignore[no-untyped-def]
    """Register problems: call ``register(name, problem_class)`` once per problem.

    ``problem_class`` subclasses :class:`vpid_bench.api.Problem` and has a ``Config``
    frozen dataclass deriving from :class:`vpid_bench.api.ProblemConfig`.
    """


@hookspec
def vpid_bench_register_report_sections(register):  # type: ignore[no-untyped-def]
    """Register report sections: call ``register(problem_name, section_function)``.

    ``section_function(ctx)`` receives a read-only :class:`~vpid_bench.ReportContext` (that
    problem's runs and records, helpers that write tables and figures safely, ``short``,
    ``alpha``) and returns a :class:`~vpid_bench.Contribution` or ``None``; called only when
    the records hold runs of ``problem_name``: what only the plugin knows (a paper's tables,
    figures of its signals, a protocol's checks).
    """
