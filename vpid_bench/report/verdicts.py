"""The report's verdicts as data, no words (:mod:`.first_screen` writes them): per context,
whether an optimizer can be recommended, which one, and why. The rules, each in
docs/report.md ("Verdicts") with a test in tests/report/test_verdicts.py:

1. nothing compared (untested runs, one optimizer): a description, not a recommendation;
2. no recommendation where the Cramér–Rao bound exceeds :data:`BOUND_LIMIT` or no optimizer
   beats every reference that ran (random search, the box centre; never recommended);
3. whom to use: the best group by the metric among those that beat every reference, a tie
   broken by search quality, then by cost (ERT to the optimum, then seconds);
4. floor over bound per instance (:func:`floor_over_bound`): above :data:`ESTIMATOR_GAP` the
   estimator (or model error, where a richer model made the record) limits the accuracy;
   below :data:`BELOW_BOUND` the record's optimum is biased;
5. under model error, a record's optimum farther from the truth than a reference ends means
   the fitted model cannot identify the system (:func:`cannot_identify`)."""

from __future__ import annotations

import dataclasses
import math
import statistics
from collections.abc import Mapping, Sequence
from typing import Any

from .optima import REACHED
from .rankings import TIE_RTOL
from .ties import cheapest, same

#: A bound (norm of the Cramér–Rao bounds, %) above this: no estimator determines the
#: parameters from such a record (one standard deviation is larger than the values).
BOUND_LIMIT = 100.0
#: A floor this many times the bound (median per instance): the estimator limits accuracy.
ESTIMATOR_GAP = 2.0
#: A floor below this many times the bound (median per instance) is called biased: an
#: efficient unbiased estimator's median error norm lies at 0.67 to 0.96 of the bound, and a
#: median over 30 instances scatters by some 0.15 around that.
BELOW_BOUND = 0.5
#: A leader whose median metric is within this factor of the floor has searched enough.
AT_FLOOR = 1.1
#: Methods the tests do not separate whose medians differ by more than this (relative) are
#: not called equivalent: the verdict says more runs would tell.
EQUIVALENCE_MARGIN = 0.10
#: The optimizers a recommended method must beat, when they were run (built-in baselines).
REFERENCES: tuple[str, ...] = ("random", "centre")
#: Their names in words.
REFERENCE_WORDS = {"random": "random search", "centre": "the box centre"}

#: Kinds of verdict.
USE, NONE, DESCRIBE, EMPTY = "use", "none", "describe", "empty"
#: How the recommended optimizer was chosen (``Verdict.basis``).
ALONE, SEARCH, COST, ORDER, SEARCH_ONLY = "alone", "search", "cost", "order", "search_only"
#: What limits the accuracy of the leader (``Verdict.limit``).
LIMIT_SEARCH, LIMIT_BELOW, LIMIT_ESTIMATOR, LIMIT_MODEL, LIMIT_RECORDS, LIMIT_TRUTH = (
    "search", "below_floor", "estimator", "model", "records", "truth")


@dataclasses.dataclass(frozen=True)
class Search:
    """One optimizer's search quality on a context, with its cost to the optimum (ERT in
    evaluations and seconds; ``inf``: no run reached it)."""

    reached: int
    runs: int
    rel_gap_median: float
    group: str = ""
    evaluations: float = math.inf
    seconds: float = math.nan

    @property
    def at_optimum(self) -> bool:
        """Most runs reach the optimum, or the median gap is at the reach threshold."""
        return self.reached >= self.runs / 2 or self.rel_gap_median <= REACHED


@dataclasses.dataclass(frozen=True)
class Method:
    """One optimizer of a context (``group`` ``""``: untested; ``search`` ``None``: no optima)."""

    name: str
    runs: int
    median: float
    group: str = ""
    search: Search | None = None


@dataclasses.dataclass(frozen=True)
class Evidence:
    """What a context's verdict rests on. ``methods``: best first by the metric; ``pairs``:
    the metric's pairwise tests; ``floors``, ``bounds``: per instance, its optimum's metric
    and its Cramér–Rao bound norm; ``references``/``missing``: the references run or not."""

    context: str
    metric: str
    unit: str
    methods: tuple[Method, ...]
    tested: bool
    pairs: tuple[Mapping[str, Any], ...] = ()
    floors: Mapping[Any, float] = dataclasses.field(default_factory=dict)
    bounds: Mapping[Any, float] = dataclasses.field(default_factory=dict)
    estimator: str | None = None
    estimator_floors: Mapping[str, Any] | None = None
    references: tuple[str, ...] = ()
    missing: tuple[str, ...] = ()
    centred: bool = False
    truth: bool = True  # False: the problem knows no truth (the metric is held out)
    #: what biases the record's optimum: the richer model that made it (``""``: none) and
    #: (instances whose optimum lies on a box edge, instances with a known optimum)
    model_error: str = ""
    on_edge: tuple[int, int] = (0, 0)


@dataclasses.dataclass(frozen=True)
class Cost:
    """What reaching the optimum cost one optimizer: ERT in evaluations and in seconds."""

    name: str
    evaluations: float
    seconds: float


@dataclasses.dataclass(frozen=True)
class EstimatorAdvice:
    """The estimator as the bottleneck: its floor is ``ratio`` times the bound; ``better``:
    the objective whose optimum lies closest to the truth on the first ``instances``
    instances (``None``: none closer, or unknown)."""

    chosen: str | None
    ratio: float
    better: str | None = None
    better_floor: float = math.nan
    chosen_floor: float = math.nan
    instances: int = 0


@dataclasses.dataclass(frozen=True)
class Verdict:
    """The verdict of one context, with its reasons. ``kind``: :data:`USE` (``pick``),
    :data:`NONE` (``over_bound``, ``not_beaten``), :data:`DESCRIBE` (``pick`` described;
    ``single``: one optimizer ran) or :data:`EMPTY`. ``tied``: those the tests do not
    separate from the pick, ``spread`` their largest relative difference of medians;
    ``costs``: the pick's first. ``floor``, ``bound``: medians over the instances, ``ratio``
    the median of their per-instance ratio; ``limit``: what limits the leader, ``gain`` its
    median over the floor."""

    context: str
    metric: str
    unit: str
    kind: str
    pick: str | None = None
    runs: int = 0
    median: float = math.nan
    basis: str = ""
    tied: tuple[str, ...] = ()
    spread: float = 0.0
    leaders: tuple[str, ...] = ()  # the metric's best group, when the pick is not among them
    costs: tuple[Cost, ...] = ()
    next_pair: Mapping[str, Any] | None = None
    next_name: str | None = None
    single: bool = False
    over_bound: bool = False
    not_beaten: tuple[str, ...] = ()
    references: tuple[str, ...] = ()
    missing: tuple[str, ...] = ()
    floor: float = math.nan
    bound: float = math.nan
    ratio: float = math.nan
    limit: str = ""
    gain: float = math.nan
    centred: bool = False
    estimator: str | None = None
    advice: EstimatorAdvice | None = None
    truth: bool = True
    search: Search | None = None  # the search quality of ``pick``
    bound_range: tuple[float, float] = (math.nan, math.nan)  # the instances' least, largest
    below_bound: bool = False  # the record's optimum is biased (by model_error, on_edge)
    model_error: str = ""
    on_edge: tuple[int, int] = (0, 0)
    #: rule 5: the references (name, median) ending nearer the truth than the optimum
    cannot_identify: tuple[tuple[str, float], ...] = ()


def _median(values: Sequence[float]) -> float:
    v = [float(x) for x in values if math.isfinite(float(x))]
    return statistics.median(v) if v else math.nan


def floor_over_bound(floors: Mapping[Any, float], bounds: Mapping[Any, float]) -> float:
    """The median over the instances of ``floor_i / bound_i`` (``nan``: none has both):
    instances' bounds differ by factors, so a median floor is not set against one bound."""
    ratios = [floors[k] / bounds[k] for k in floors
              if k in bounds and math.isfinite(floors[k]) and math.isfinite(bounds[k])
              and bounds[k] > 0]
    return statistics.median(ratios) if ratios else math.nan


def tied(a: float, b: float) -> bool:
    """Whether two medians are equal within :data:`~.rankings.TIE_RTOL` (relative)."""
    return same(a, b, TIE_RTOL)


def _pair(pairs: Sequence[Mapping[str, Any]], a: str, b: str) -> Mapping[str, Any] | None:
    return next((r for r in pairs if {r["a"], r["b"]} == {a, b}), None)


def beats(pairs: Sequence[Mapping[str, Any]], a: str, b: str) -> bool:
    """Whether the Holm-corrected test finds ``a`` significantly lower than ``b``."""
    row = _pair(pairs, a, b)
    return bool(row is not None and row.get("significant") and row.get("better") == a)


def _lead(items: Sequence[Method], group: Any) -> list[Method]:
    """Those of ``items`` (best first) sharing the first one's first rank-group letter."""
    if not items:
        return []
    letters = group(items[0])
    if not letters:
        return [items[0]]
    return [m for m in items if letters[0] in group(m)]


def _choose(eligible: list[Method]) -> tuple[Method, str, list[Method], list[Method]]:
    """Rule 3: (pick, basis, the metric's best group, those tied with the pick by search too)."""
    mlead = _lead(eligible, lambda m: m.group)
    if not all(m.search for m in eligible):
        return mlead[0], ALONE if len(mlead) == 1 else ORDER, mlead, []
    by_search = sorted(eligible, key=lambda m: (-m.search.reached / max(m.search.runs, 1),
                                                m.search.rel_gap_median))
    slead = _lead(by_search, lambda m: m.search.group)
    names = {m.name for m in slead}
    both = [m for m in sorted(mlead, key=by_search.index) if m.name in names]
    pool = both or sorted(slead, key=by_search.index)
    pick, decided = (cheapest(pool, lambda m: (m.search.evaluations, m.search.seconds))
                     if len(pool) > 1 else (pool[0], ""))
    if not both:
        return pick, SEARCH_ONLY, mlead, pool
    basis = (ALONE if len(mlead) == 1 else SEARCH if len(both) == 1
             else COST if decided else ORDER)
    if basis == ORDER:  # tied on everything: the first by the metric's median
        pick = next(m for m in mlead if m in both)
    return pick, basis, mlead, pool


def _limit(pick: Method, floor: float, ratio: float, model_error: str = "") -> tuple[str, float]:
    """What limits the leader, and its median over the floor."""
    if not math.isfinite(floor) or floor < 0:
        return "", math.nan
    m = pick.median
    at_opt = pick.search is not None and pick.search.at_optimum
    if floor == 0:  # noise-free records: the optimum is the truth, no ratio to it
        return (LIMIT_RECORDS if at_opt or m <= 0 else LIMIT_TRUTH), math.nan
    if m < floor and not tied(m, floor) and not at_opt:
        return LIMIT_BELOW, m / floor
    if at_opt or m <= AT_FLOOR * floor:
        if math.isfinite(ratio) and ratio > ESTIMATOR_GAP:
            return (LIMIT_MODEL if model_error else LIMIT_ESTIMATOR), m / floor
        return LIMIT_RECORDS, m / floor
    return LIMIT_SEARCH, m / floor


def estimator_advice(chosen: str | None, ratio: float,
                     floors: Mapping[str, Any] | None) -> EstimatorAdvice | None:
    """Rule 4's advice (``None`` within :data:`ESTIMATOR_GAP`); ``floors``: ``estimators.json``."""
    if not (math.isfinite(ratio) and ratio > ESTIMATOR_GAP):
        return None
    if not floors:
        return EstimatorAdvice(chosen, ratio)
    per = floors["floors"]
    mine = float(per[chosen]["median"]) if chosen in per else math.nan
    others = [(o, float(v["median"])) for o, v in per.items() if o != chosen]
    best = min(others, key=lambda item: item[1], default=None)
    if best is None or not (best[1] < mine or not math.isfinite(mine)):
        best = (None, math.nan)
    return EstimatorAdvice(chosen, ratio, *best, mine, int(floors["instances"]))


def cannot_identify(ev: Evidence, floor: float) -> tuple[tuple[str, float], ...]:
    """Rule 5: the references (name, median) ending nearer the truth than ``floor``."""
    if not ev.model_error or not math.isfinite(floor):
        return ()
    return tuple((m.name, m.median) for m in ev.methods
                 if m.name in ev.references and math.isfinite(m.median) and m.median < floor)


def decide(ev: Evidence) -> Verdict:
    """The verdict of one context (the rules of the module)."""
    base = _base(ev)
    if not ev.methods:
        return Verdict(kind=EMPTY, **base)
    candidates = [m for m in ev.methods if m.name not in ev.references]
    if not ev.tested or len(ev.methods) < 2 or not candidates:  # rule 1: a description
        return _verdict(DESCRIBE, (candidates or list(ev.methods))[0], ev, base,
                        single=len(ev.methods) < 2)
    eligible = [m for m in candidates
                if all(beats(ev.pairs, m.name, r) for r in ev.references)]
    over = math.isfinite(base["bound"]) and base["bound"] > BOUND_LIMIT
    if over or not eligible or base["cannot_identify"]:  # rules 2 and 5: none recommended
        not_beaten = tuple(r for r in ev.references
                           if not any(beats(ev.pairs, m.name, r) for m in candidates))
        return _verdict(NONE, candidates[0], ev, base, over_bound=over, not_beaten=not_beaten)
    return _use(ev, eligible, base)


def _base(ev: Evidence) -> dict[str, Any]:
    """What every verdict of ``ev`` carries: its names and rule 4's levels."""
    base: dict[str, Any] = {
        "context": ev.context, "metric": ev.metric, "unit": ev.unit, "references": ev.references,
        "missing": ev.missing, "centred": ev.centred, "estimator": ev.estimator, "truth": ev.truth}
    if not ev.methods:
        return base
    ratio = floor_over_bound(ev.floors, ev.bounds)
    finite = [b for b in ev.bounds.values() if math.isfinite(b)]
    return base | {
        "floor": _median(list(ev.floors.values())), "bound": _median(list(ev.bounds.values())),
        "ratio": ratio,
        "bound_range": (min(finite), max(finite)) if finite else (math.nan, math.nan),
        # far above the bound from a richer model's record: model error, not the estimator
        "advice": None if ev.model_error else estimator_advice(
            ev.estimator, ratio, ev.estimator_floors),
        "below_bound": math.isfinite(ratio) and ratio < BELOW_BOUND,
        "model_error": ev.model_error, "on_edge": ev.on_edge,
        "cannot_identify": cannot_identify(ev, _median(list(ev.floors.values())))}


def _verdict(kind: str, lead: Method, ev: Evidence, base: dict[str, Any], **kw: Any) -> Verdict:
    """A verdict naming ``lead``, with what limits it (rule 4)."""
    limit, gain = _limit(lead, base["floor"], base["ratio"], ev.model_error)
    return Verdict(kind=kind, pick=lead.name, runs=lead.runs, median=lead.median, limit=limit,
                   gain=gain, search=lead.search, **kw, **base)


def _use(ev: Evidence, eligible: list[Method], base: dict[str, Any]) -> Verdict:
    """Rule 3: whom to use among the eligible (:func:`_choose`)."""
    pick, basis, mlead, pool = _choose(eligible)
    # those the metric's tests do not separate from the pick: its rank group, or, where the
    # pick is not in the metric's best group, each eligible method without a significant pair
    tied_with = ([m for m in mlead if m.name != pick.name] if basis != SEARCH_ONLY else
                 [m for m in eligible if m.name != pick.name
                  and not beats(ev.pairs, m.name, pick.name)
                  and not beats(ev.pairs, pick.name, m.name)])
    spread = max((abs(m.median - pick.median) / abs(pick.median) for m in tied_with
                  if math.isfinite(m.median) and math.isfinite(pick.median)
                  and pick.median != 0), default=0.0)
    costs = tuple(Cost(m.name, m.search.evaluations, m.search.seconds)
                  for m in [pick] + [m for m in pool if m.name != pick.name] if m.search)
    nxt = next((m.name for m in ev.methods if m.name != pick.name), None)
    return _verdict(USE, pick, ev, base, basis=basis, tied=tuple(m.name for m in tied_with),
                    spread=spread, costs=costs,
                    leaders=tuple(m.name for m in mlead) if basis == SEARCH_ONLY else (),
                    next_pair=None if nxt is None else _pair(ev.pairs, pick.name, nxt),
                    next_name=nxt)
