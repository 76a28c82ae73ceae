"""The problem contract, grouped into capabilities, and the check that refuses half of one.

A :class:`~vpid_bench.api.Problem` is a core plus capabilities it may offer
(:data:`CAPABILITIES`; the table and why each is all or nothing: docs/architecture.md, the
problem contract). :func:`check_problem_class` (called by the job spec's parse, so the
pre-flight) refuses in one line a member without its capability's anchor, ``instance``
without ``instance_id``, and a method of :class:`~vpid_bench.api.Problem` replaced by a
non-callable (``instance_id = "a"``).
"""

from __future__ import annotations

import dataclasses
import inspect

from .errors import ConfigError
from .problem import Problem

DOCS = "docs/architecture.md#the-problem-contract"


@dataclasses.dataclass(frozen=True)
class Capability:
    """A group of :class:`~vpid_bench.api.Problem` members offered together."""

    name: str
    members: tuple[str, ...]
    anchor: str | None  # the member whose override offers the capability (None: no anchor)
    needs: tuple[str, ...] = ()  # members that must be overridden with the anchor
    what: str = ""


CAPABILITIES: tuple[Capability, ...] = (
    Capability("core", ("Config", "name", "bounds", "evaluate", "x_true", "metrics",
                        "describe", "rows_independent", "suites", "family", "comparisons",
                        "fits_a_record"),
               None, what="the box, the objective, and optionally the truth, accuracy "
                          "metrics and fixed comparison rows"),
    Capability("residuals", ("residuals", "residual_groups", "evaluate_with_residuals",
                             "fisher_residuals", "fisher_groups", "residual_sigma"),
               "residuals",
               what="residual vectors, for least-squares optimizers and the identifiability "
                    "analysis"),
    Capability("instances", ("instance", "instance_id", "evaluate_instances"), "instance",
               needs=("instance_id",),
               what="a different record per run index, named so that runs pair by instance"),
    Capability("signals", ("signals", "signal_units"), "signals",
               what="measured and fitted channels, for the measured-vs-fitted figure"),
    Capability("plumbing", ("write_artifacts", "content_digest", "set_threads"), None,
               what="files kept beside the records, a digest of data files, threads"),
)


def overrides(cls: type, member: str) -> bool:
    """Whether ``cls`` defines ``member`` differently from :class:`~vpid_bench.api.Problem`."""
    return getattr(cls, member, None) is not getattr(Problem, member, None)


def offered(cls: type[Problem]) -> list[str]:
    """The capabilities ``cls`` offers (``core`` always)."""
    return [c.name for c in CAPABILITIES if c.anchor is None and c.name == "core"
            or c.anchor is not None and overrides(cls, c.anchor)]


def check_problem_class(cls: type, name: str | None = None) -> None:
    """Refuse (:class:`~vpid_bench.api.ConfigError`, key ``problem``) a problem class that
    implements part of a capability or replaced a method by a non-callable."""
    label = name or getattr(cls, "name", None) or cls.__name__
    if not (isinstance(cls, type) and issubclass(cls, Problem)):
        raise ConfigError("problem", label, "a subclass of vpid_bench.Problem")
    for cap in CAPABILITIES:
        for member in cap.members:
            _check_callable(cls, member, label)
        if cap.anchor is None:
            continue
        done = [m for m in cap.members if overrides(cls, m)]
        if not done:
            continue
        missing = [m for m in (cap.anchor, *cap.needs) if m not in done]
        if missing:
            lack = " and ".join(f"{m}()" for m in missing)
            raise ConfigError("problem", label, f"a problem that offers the {cap.name!r} "
                              f"capability whole ({cap.what}): it implements "
                              f"{', '.join(f'{m}()' for m in done)} but not {lack}; implement "
                              f"{lack} too, or none of {', '.join(cap.members)} (see {DOCS})")


def _check_callable(cls: type, member: str, label: str) -> None:
    base = inspect.getattr_static(Problem, member, None)
    if not callable(base) or isinstance(base, (property, type)):
        return
    mine = inspect.getattr_static(cls, member, None)
    if isinstance(mine, (staticmethod, classmethod)) or callable(mine):
        return
    raise ConfigError("problem", label, f"{member} must be a method, like "
                      f"Problem.{member}(), not a {type(mine).__name__} (see {DOCS})")
