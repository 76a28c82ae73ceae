"""``vpid-bench-compile``: the installed plugins' numba loops compiled once into numba's
on-disk cache, so that no run pays the compile (5-45 s per model on a cold cache; ``make
install`` runs it, docs/usage.md).

Every registered problem is built with its defaults and evaluates a small population through
each path a job takes (values, residuals and their Fisher rows when offered, the signals);
every registered optimizer runs two generations on ``problem=functions``. Only the plugin
API is used, so a third party's plugins are compiled too; a problem that needs the user's
own settings (``problem=fmu``) is skipped with its reason.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor

import numpy as np

#: Candidates per evaluated population (rows): the batch path a run takes.
POPULATION = 4
#: Generations each optimizer runs on ``problem=functions``.
GENERATIONS = 2


def _problem(name: str) -> str:
    """Build problem ``name`` with its defaults and evaluate through each of its paths; the
    line to print."""
    from vpid_bench.errors import VpidBenchError
    from vpid_bench.plugins import Registry
    from vpid_bench.problem import offers_residuals

    started = time.perf_counter()
    cls = Registry().problem(name)
    try:
        problem = cls(cls.Config())
    except VpidBenchError as exc:  # needs the user's own settings
        return f"problem={name}: skipped ({str(exc).splitlines()[0]})"
    X = problem.bounds.sample(np.random.default_rng(0), POPULATION)
    problem.evaluate(X)
    if offers_residuals(problem):
        problem.evaluate_with_residuals(X)
        problem.fisher_residuals(X[:1])
    problem.signals(X[0])
    return f"problem={name}: {time.perf_counter() - started:.1f} s"


def _optimizer(name: str) -> str:
    """Run optimizer ``name`` for :data:`GENERATIONS` generations on ``problem=functions``;
    the line to print."""
    from vpid_bench.optimizer import check_compatible
    from vpid_bench.plugins import Registry
    from vpid_bench.runner import run

    started = time.perf_counter()
    registry = Registry()
    if "functions" not in registry.problems:
        return f"optimizer={name}: skipped (problem=functions is not installed)"
    problem_cls = registry.problem("functions")
    problem = problem_cls(problem_cls.Config())
    cls = registry.optimizer(name)
    ps = problem.config.ps
    params = cls.Params(ps=ps, iterations=GENERATIONS, budget=ps * (GENERATIONS + 1))
    try:
        optimizer = cls(params, problem.bounds, np.random.default_rng(0))
        check_compatible(problem, optimizer)
    except Exception as exc:  # noqa: BLE001 - a plugin's refusal is its own; say it, go on
        return f"optimizer={name}: skipped ({str(exc).splitlines()[0] if str(exc) else exc!r})"
    run(problem, optimizer, params.budget)
    return f"optimizer={name}: {time.perf_counter() - started:.1f} s"


def _task(kind_name: tuple[str, str]) -> str:
    kind, name = kind_name
    try:
        return (_problem if kind == "problem" else _optimizer)(name)
    except Exception as exc:  # noqa: BLE001 - one plugin's failure is said, the rest compile
        return f"{kind}={name}: failed ({type(exc).__name__}: {str(exc).splitlines()[0]})"


def main(argv: Sequence[str] | None = None) -> int:
    """Compile every installed problem's and optimizer's loops; exit 1 if one failed."""
    import os

    parser = argparse.ArgumentParser(prog="vpid-bench-compile", description=__doc__.split("\n")[0])
    parser.add_argument("names", nargs="*", metavar="NAME",
                        help="only these problems and optimizers (default: every installed one)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="processes compiling at once (default: the machine's cores)")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error(f"--jobs: {args.jobs} is not a positive count of processes")
    from vpid_bench.plugins import Registry

    registry = Registry()
    unknown = sorted(set(args.names) - set(registry.problems) - set(registry.optimizers))
    if unknown:
        parser.error(f"{', '.join(unknown)}: not an installed problem or optimizer (see "
                     "vpid-bench --help)")
    chosen = set(args.names) or set(registry.problems) | set(registry.optimizers)
    tasks = [("problem", n) for n in sorted(registry.problems) if n in chosen]
    tasks += [("optimizer", n) for n in sorted(registry.optimizers) if n in chosen]
    started = time.perf_counter()
    print(f"vpid-bench-compile: {len(tasks)} problems and optimizers on {args.jobs} "
          "process(es), into numba's cache", file=sys.stderr, flush=True)
    failed = 0
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        for line in pool.map(_task, tasks):
            failed += ": failed (" in line
            print(f"  {line}", file=sys.stderr, flush=True)
    print(f"vpid-bench-compile: done in {time.perf_counter() - started:.0f} s"
          + (f", {failed} failed" if failed else ""), file=sys.stderr)
    return 1 if failed else 0
