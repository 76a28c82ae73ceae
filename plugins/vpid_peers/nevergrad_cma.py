"""nevergrad's CMA without the check it repeats at every candidate, and without the wrapper
that passes each candidate on: the same search, more than half of nevergrad's own time saved
(where :mod:`.nevergrad_replica` does not apply).

nevergrad's CMA (1.0.x, ``nevergrad.optimization.optimizerlib._CMA``, the strategy behind the
registry's ``CMA``) reads its ``es``
property once per ``tell`` (to learn the population size) and once per generation in ``ask``.
Each read builds a ``Normalizer`` of the parametrization (a copy of the parameter tree and a
round trip through its bound transforms, about 0.4 ms) to decide whether the parametrization
is fully bounded, an answer that cannot change during a run and that the property uses only
when it creates the cma strategy (at the start and after a restart). Measured on
``vpid1_q_golden_hump`` (8 runs of 4,000 evaluations, under cProfile): 34 % of the runs' time;
``benchmarks/bench_nevergrad_cma.py`` prints nevergrad's time per candidate with and without.

:func:`skip_repeated_bounds_check` gives one optimizer a subclass whose ``es`` returns the
strategy it already has while that strategy has not stopped (or is fcmaes, which nevergrad
never restarts), and otherwise asks nevergrad's own property, which then creates a new one
exactly as before. What nevergrad asks and tells is unchanged:
``tests/peers/test_nevergrad_cma.py`` checks that the candidates are bit-identical with and
without it, over a restart.

The registry's ``CMA`` is a ``MetaCMA``: a wrapper whose ``ask`` and ``tell`` pass each
candidate on to the optimizer it selected (its public ``optim``), after the wrapper's own
checks and book-keeping (constraints, its archive of every candidate, its best points), which
draw no random numbers and which the selected optimizer repeats. :func:`driven` returns that
selected optimizer, to be asked and told directly: every candidate then goes once through
nevergrad's ``ask`` and ``tell`` instead of twice. The same test checks the candidates against
the wrapper's.

**Why a private API** (the brief's rule: a private one needs a test and a reason): nevergrad
offers no public option for this, and nevergrad's per-evaluation time was the largest
share of the vpid1 archive's build (29 %). The function touches ``_CMA``, ``_es`` and
``_config`` (and the public ``optim`` of ``MetaCMA``); when one of them is missing (another
nevergrad version) it leaves the optimizer as it is, and the test above fails, so that the
next upgrade is looked at.
"""

from __future__ import annotations

import functools
from typing import Any


def cma_class() -> type | None:
    """nevergrad's CMA optimizer class (private), or ``None`` when this nevergrad has none."""
    try:
        from nevergrad.optimization import optimizerlib
    except ImportError:  # pragma: no cover - the plugin registers only when it is found
        return None
    cls = getattr(optimizerlib, "_CMA", None)
    return cls if isinstance(cls, type) and isinstance(getattr(cls, "es", None), property) \
        else None


@functools.cache
def _reusing(base: type) -> type:
    """A subclass of ``base`` (nevergrad's CMA) whose ``es`` reuses a running strategy."""
    original = base.es.fget

    class ReusingCMA(base):  # type: ignore[misc, valid-type]
        @property
        def es(self) -> Any:
            strategy = self._es
            if strategy is not None and (self._config.fcmaes or not strategy.stop()):
                return strategy
            return original(self)  # creates the strategy (first call, or after a stop)

    ReusingCMA.__name__ = base.__name__
    ReusingCMA.__qualname__ = base.__qualname__
    return ReusingCMA


def skip_repeated_bounds_check(optimizer: Any) -> Any:
    """``optimizer`` itself, its cma strategy reused while it runs (see the module docstring)
    when it is nevergrad's CMA: the class ``_CMA``, or the registry's ``CMA``/``MetaCMA``,
    which pick one at their first candidate (``CMAbounded`` in the unit box) and delegate to
    it (their ``optim``, built here instead, from the same construction-time facts). Any
    other optimizer is returned unchanged."""
    base = cma_class()
    if base is None:
        return optimizer
    import nevergrad as ng

    inner = optimizer.optim if isinstance(optimizer, ng.optimizers.registry["MetaCMA"]) \
        else optimizer
    if type(inner) is base and all(hasattr(inner, a) for a in ("_es", "_config")):
        inner.__class__ = _reusing(base)
    return optimizer


def driven(optimizer: Any) -> Any:
    """The optimizer to ask and tell: a ``MetaCMA``'s (the registry's ``CMA``) selected
    optimizer, its public ``optim``, which the wrapper's own ``ask`` and ``tell`` only pass
    each candidate on to (see the module docstring); any other optimizer itself."""
    import nevergrad as ng

    meta = ng.optimizers.registry.get("MetaCMA")
    if isinstance(meta, type) and isinstance(optimizer, meta):
        return optimizer.optim
    return optimizer
