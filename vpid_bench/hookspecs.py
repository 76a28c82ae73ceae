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
