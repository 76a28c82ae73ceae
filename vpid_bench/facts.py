"""What a job needs to know of its problem, read where the problem was built.

With worker processes the sweep's own process never builds a problem nor calls its code (a
segfault in ``describe()`` once ended the sweep): a worker reads these facts
(:func:`problem_facts`) and the job works from them: the dimension, whether runs may go in
lockstep, the data's digest (in every run id) and what each run's record holds.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from .bounds import Bounds
from .errors import PluginError
from .problem import Problem, kept_instance


@dataclasses.dataclass(frozen=True)
class InstanceFacts:
    """One instance as a run record holds it: id, box, truth (``None``: unknown), ``describe()``."""

    id: str | None
    bounds: Bounds
    x_true: np.ndarray | None
    info: dict[str, Any]


@dataclasses.dataclass(frozen=True)
class ProblemFacts:
    """A problem's dimension, ``rows_independent``, ``content_digest()``, runs' instances."""

    dim: int
    rows_independent: bool
    content_digest: str | None
    instances: tuple[InstanceFacts, ...]

    def instance(self, index: int) -> InstanceFacts:
        """The facts of run ``index``'s instance."""
        return self.instances[index]


def problem_facts(problem: Problem, runs: int) -> ProblemFacts:
    """The facts of ``problem`` and of runs ``0 .. runs-1``'s instances; a method that
    raises is named in a :class:`~vpid_bench.errors.PluginError`."""
    name = getattr(problem, "name", "?")

    def read(what: str, call: Any) -> Any:
        try:
            return call()
        except Exception as exc:  # noqa: BLE001 - named, with the plugin's own message
            raise PluginError(f"problem {name!r}: {what} raised {type(exc).__name__}: "
                              f"{exc}") from exc

    instances = []
    for i in range(runs):
        inst = read(f"instance({i})", lambda i=i: kept_instance(problem, i))
        info = read(f"describe() of instance {i}", inst.describe)
        if not isinstance(info, dict):
            raise PluginError(f"problem {name!r}: describe() of instance {i} returned "
                              f"{type(info).__name__}, not a dict")
        if getattr(inst, "fits_a_record", True) is False:
            info = {**info, "fits_a_record": False}
        x_true = read(f"x_true of instance {i}", lambda inst=inst: inst.x_true)
        instances.append(InstanceFacts(
            id=read(f"instance_id() of instance {i}", inst.instance_id),
            bounds=read(f"bounds of instance {i}", lambda inst=inst: inst.bounds),
            x_true=None if x_true is None else np.asarray(x_true, dtype=float),
            info=info))
    bounds = read("bounds", lambda: problem.bounds)
    return ProblemFacts(dim=int(bounds.dim),
                        rows_independent=bool(getattr(problem, "rows_independent", False)),
                        content_digest=read("content_digest()", problem.content_digest),
                        instances=tuple(instances))
