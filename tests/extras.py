"""Which optional extras are installed, for skip marks that name the missing extra.

``importlib.util.find_spec("hydra_plugins.x")`` raises ``ModuleNotFoundError`` when no Hydra
plugin at all is installed (the ``hydra_plugins`` namespace itself is missing, as with only the
``[test]`` extra), so a module-level skip mark built on it fails collection instead of skipping.
"""

from __future__ import annotations

import contextlib
import importlib.util
from collections.abc import Iterator

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


#: The shipped archives' runs (archive-runs/, installed by ``make install``): tests that read
#: them are skipped without it, with the reason.
needs_archive_runs = needs("vpid_archive_runs", "make install: pip install -e ./archive-runs")


@contextlib.contextmanager
def every_core() -> Iterator[None]:
    """This process on every core the machine lets it use, for the block (tests/conftest.py
    pins each xdist test process to one): for a test of work spread over processes."""
    import os

    if not hasattr(os, "sched_setaffinity"):
        yield
        return
    mine = os.sched_getaffinity(0)
    with contextlib.suppress(OSError):  # cores it may not use (a cpuset): it stays as it was
        os.sched_setaffinity(0, range(os.cpu_count() or 1))
    try:
        yield
    finally:
        os.sched_setaffinity(0, mine)
