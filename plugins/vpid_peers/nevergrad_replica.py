"""nevergrad's CMA in the unit box, its ask and tell replicated on the ``cma`` library: the same
candidates, without nevergrad's parameter machinery around each one.

In a bounded box the registry's ``CMA`` (``MetaCMA``) selects ``CMAbounded``: an elitist,
diagonal cma strategy in nevergrad's *standardized* space. Each candidate then goes through
nevergrad's parameter layer: a copy of the parameter tree (``spawn_child``), its bound layer,
constraint checks, freezing, and an archive of every candidate. For one candidate per ask (the
plugin's default), that layer costs several times what cma itself does (and more than the
vehicle's objective): ``benchmarks/bench_nevergrad_cma.py`` prints the time per candidate with
and without it. On the vpid1 archive's build it was most of ``optimizer=nevergrad``'s time.

:func:`replicated` returns an optimizer that asks and tells exactly what nevergrad's would,
computed as nevergrad 1.0.12 computes it:

* **the strategy**: ``cma.CMAEvolutionStrategy`` at the origin of the standardized space, step
  ``scale x 0.3`` (``x 0.15`` from 18 parameters on), nevergrad's population size, its
  options (``CMA_diagonal``, ``CMA_elitist``, ``verbose=-9``, ``seed=nan``) and its random
  numbers (``randn`` of the parametrization's ``random_state``); a new strategy, the same
  way, whenever nevergrad's would read that the running one has stopped (at every ask of a
  new generation and at every tell);
* **a candidate's value** from the standardized point ``z``: ``sigma x (z + x0 / sigma)``, the
  parameter's ``sigma`` and initial value ``x0``, bounced once off the unit box's walls and
  clipped (nevergrad's ``Clipping(0, 1, bounce=True)``);
* **what is told**: that value back in the standardized space, ``(value - x0) / sigma``, and
  the loss clipped at ``5e20`` (``inf`` and ``nan`` included), a generation at a time; an
  error of cma's ``tell`` is ignored, as nevergrad ignores it.

It is used only where it is known to be exact: nevergrad's selected optimizer is the class
``_CMA`` without ``fcmaes``, a random start or extra cma options, for two or more parameters
(``CMAbounded``, and the registry's other CMA variants, whose settings are read from it: the
test checks ``CMA``, ``OldCMA``, ``SDiagonalCMA`` and ``CMApara``), on the plugin's own
parametrization (an ``ng.p.Array`` in ``[0, 1]``), with a nevergrad version this module was
checked against (:data:`CHECKED_VERSIONS`); anywhere else nevergrad itself runs. ``tests/peers/
test_nevergrad_cma.py`` checks the candidates bit-identical to nevergrad's own, restarts,
infinite losses and batches of a population included, and fails when nevergrad's version moves
past the checked ones, so that the next one is checked too.

**Why private facts** (the brief's rule: a private API needs a test and a reason): the
settings are read from nevergrad's objects (``_popsize``, ``_config``) rather than repeated
here, and what is computed mirrors nevergrad's private classes; there is no public way to ask
nevergrad for less work per candidate, and it was the largest cost of the archive's build
that was not the vehicle itself.
"""

from __future__ import annotations

import contextlib
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

#: nevergrad versions whose CMA this module was checked against, candidate by candidate.
CHECKED_VERSIONS = frozenset({"1.0.12"})
#: nevergrad clips a loss at this value (``inf`` and ``nan`` too) before its optimizer sees it.
LOSS_CLIP = 5.0e20


@dataclass(frozen=True)
class Candidate:
    """One asked point: ``value`` in the unit box, ``told`` its standardized coordinates."""

    value: np.ndarray
    told: np.ndarray


class ReplicatedCMA:
    """nevergrad's ``_CMA`` (``CMAbounded`` or another of its CMA variants, its settings read
    from it), asked and told as nevergrad does (see the module docstring); built from that
    nevergrad optimizer before its first ask."""

    def __init__(self, inner: Any) -> None:
        parametrization = inner.parametrization
        self._config = inner._config
        self._popsize = int(inner._popsize)
        self._randn = parametrization.random_state.randn
        self._dim = int(inner.dimension)
        self._sigma = float(parametrization.sigma.value)
        self._x0 = np.array(parametrization.value, dtype=float)
        self._reduced_x0 = (self._x0 / self._sigma).ravel()
        self._es: Any = None
        self._to_ask: deque[np.ndarray] = deque()
        self._to_tell: list[tuple[np.ndarray, float]] = []

    def _strategy(self) -> Any:
        """The running cma strategy, a new one when there is none or it has stopped (what
        reading nevergrad's ``es`` does, each time it is read)."""
        if self._es is None or self._es.stop():
            import cma

            scale = 0.3 if self._dim < 18 else 0.15  # nevergrad's, in a fully bounded box
            self._es = cma.CMAEvolutionStrategy(
                x0=np.zeros(self._dim, dtype=np.float64),
                sigma0=self._config.scale * scale,
                inopts=dict(popsize=self._popsize, randn=self._randn,
                            CMA_diagonal=self._config.diagonal, verbose=-9, seed=np.nan,
                            CMA_elitist=self._config.elitist))
        return self._es

    def ask(self) -> Candidate:
        """The next candidate of the current generation (a new generation asked when none is
        left)."""
        if not self._to_ask:
            self._to_ask.extend(self._strategy().ask())
        z = self._to_ask.popleft()
        reduced = self._sigma * (z + self._reduced_x0).reshape(self._x0.shape)
        value = _bounce_into_unit_box(reduced)
        return Candidate(value, ((value - self._x0) / self._sigma).ravel())

    def tell(self, candidate: Candidate, loss: float) -> None:
        """``loss`` of ``candidate``; the generation is told to cma once it is complete."""
        loss = float(loss)
        if not loss < LOSS_CLIP:
            loss = LOSS_CLIP
        self._to_tell.append((candidate.told, loss))
        # nevergrad reads its strategy here and again to tell it: each read asks cma whether
        # it stopped (and starts a new one if so), so both reads are kept
        if len(self._to_tell) >= self._strategy().popsize:
            xs = [told for told, _ in self._to_tell]
            ys = [f for _, f in self._to_tell]
            with contextlib.suppress(RuntimeError, AssertionError):  # as nevergrad does
                self._strategy().tell(xs, ys)
            self._to_tell = []


def _bounce_into_unit_box(x: np.ndarray) -> np.ndarray:
    """nevergrad's ``Clipping(0, 1, bounce=True)``: ``x`` itself inside the box, else clipped,
    bounced once off the wall it crossed and clipped again."""
    if not (np.any(x < 0.0) or np.any(x > 1.0)):
        return x
    out = np.clip(x, 0.0, 1.0)
    return np.clip(2 * out - x, 0.0, 1.0)


def replicated(optimizer: Any) -> Any:
    """A :class:`ReplicatedCMA` of ``optimizer`` (nevergrad's selected optimizer, not yet asked)
    where it is known to be exact (see the module docstring); otherwise ``optimizer``."""
    return ReplicatedCMA(optimizer) if why_not(optimizer) is None else optimizer


def why_not(optimizer: Any) -> str | None:
    """Why ``optimizer`` is run by nevergrad itself rather than replicated (``None``: it is
    replicated)."""
    import nevergrad as ng

    from .nevergrad_cma import cma_class

    if ng.__version__ not in CHECKED_VERSIONS:
        return f"nevergrad {ng.__version__} is not one this replica was checked against"
    base = cma_class()
    if base is None or not isinstance(optimizer, base):
        return "not nevergrad's CMA"
    config = getattr(optimizer, "_config", None)
    settings = ("fcmaes", "random_init", "inopts", "scale", "diagonal", "elitist")
    if config is None or not all(hasattr(config, s) for s in settings):
        return "its settings are not where they were"
    if config.fcmaes or config.random_init or config.inopts is not None:
        return "settings other than CMAbounded's"
    if getattr(optimizer, "_es", None) is not None or optimizer.num_ask:
        return "already asked"
    if optimizer.dimension < 2:
        return "one parameter (nevergrad then uses fcmaes)"
    return _why_not_the_box(optimizer.parametrization)


def _why_not_the_box(parametrization: Any) -> str | None:
    """``None`` when ``parametrization`` is the plugin's: one array in ``[0, 1]`` with
    nevergrad's bouncing bounds; else why not."""
    import nevergrad as ng

    if type(parametrization) is not ng.p.Array:
        return "not a plain ng.p.Array"
    bounds = parametrization.bounds
    if bounds[0] is None or bounds[1] is None or not (np.all(bounds[0] == 0.0)
                                                      and np.all(bounds[1] == 1.0)):
        return "not the unit box"
    layers = [type(layer).__name__ for layer in getattr(parametrization, "_layers", [])]
    if layers != ["Array", "Bound", "ArrayCasting"]:
        return f"other parameter layers ({layers})"
    if getattr(parametrization._layers[1], "_method", None) != "bouncing":
        return "bounds other than bouncing"
    return None
