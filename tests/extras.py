"""Which optional extras are installed, for skip marks that name the missing extra.

``importlib.util.find_spec("hydra_plugins.x")`` raises ``ModuleNotFoundError`` when no Hydra
plugin at all is installed (the ``hydra_plugins`` namespace itself is missing, as with only the
``[test]`` extra), so a module-level skip mark built on it fails collection instead of skipping.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable

import pytest


def installed(module: str) -> bool:
    """True when ``module`` (dotted) can be imported; False when it or a parent is missing."""
    try:
        return importlib.util.find_spec(module) is not None
    except ModuleNotFoundError:
        return False


def needs(module: str, extra: str) -> pytest.MarkDecorator:
    """A skip mark for a test that needs ``module``, naming the extra that installs it."""
    return pytest.mark.skipif(not installed(module),
                              reason=f"{module} not installed (extra {extra!r})")


def limit(seconds: float) -> float:
    """A subprocess time limit of ``seconds`` on a quiet machine, scaled for this one: by
    ``VPID_TEST_TIME_FACTOR`` when set, else by the load per core (the 1-minute load average
    over the cores, at least 1, at most 8). The limits catch a hang, not slowness: on a
    2-core machine that other work loads to 9, a 120 s limit becomes 540 s, so a test fails
    only when something is wrong."""
    import os

    factor = os.environ.get("VPID_TEST_TIME_FACTOR")
    if factor:
        return seconds * max(1.0, float(factor))
    try:
        load = os.getloadavg()[0] / (os.cpu_count() or 1)
    except OSError:  # no load average on this platform
        load = 1.0
    return seconds * min(8.0, max(1.0, load))


def one_core() -> Callable[[], None] | None:
    """A ``preexec_fn`` that pins a CLI subprocess to one core of this test process's, the
    xdist worker's own (``gw0`` the first, ``gw1`` the second, ...): the command then sees one
    core, as on a one-core allocation, and starts one worker process per job, not one per
    core (each costs 1.2 s of CPU to start), and two test processes' commands do not share a
    core. ``None`` where the platform cannot pin (not Linux)."""
    import os

    if not hasattr(os, "sched_setaffinity"):
        return None
    cores = sorted(os.sched_getaffinity(0))
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw")
    core = cores[int(worker) % len(cores)] if worker.isdigit() else cores[0]
    return lambda: os.sched_setaffinity(0, {core})


#: The shipped archives' runs (archive-runs/, installed by ``make install``): tests that read
#: them are skipped without it, with the reason.
needs_archive_runs = needs("vpid_archive_runs", "make install: pip install -e ./archive-runs")
