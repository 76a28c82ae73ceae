"""``vpid-bench-design``: rank candidate record designs of a problem by what they determine.

    vpid-bench-design ride_half --vary sensors=body,body_wheel --vary speed_kmh=20,40
    vpid-bench-design ride_quarter sensors=body --vary speed_kmh=30,60 --floor 10 --profile

A design is the problem with one choice of settings (``key=value`` for all, each ``--vary``
a factor), measured on instance 0 (what each column means: docs/estimators.md, record
design). Prints Markdown.
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import sys
from typing import Any

import numpy as np
from omegaconf import OmegaConf

from .analysis.estimator_floors import truth_optima_metric
from .analysis.identifiability import cramer_rao
from .analysis.profile import STRUCTURAL_RATIO, profile_intervals
from .errors import ConfigError, VpidBenchError
from .params import build_dataclass
from .plugins import Registry

UNDETERMINED_PERCENT = 10.0


def _settings(items: list[str], flag: str) -> list[tuple[str, str]]:
    out = []
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip().removeprefix("problem.")
        if not sep or not key:
            raise ConfigError(flag, item, "key=value (e.g. record.extra=0.5)")
        out.append((key, value))
    return out


def designs(fixed: list[tuple[str, str]], vary: list[tuple[str, str]]
            ) -> list[list[tuple[str, str]]]:
    """Every combination of the ``--vary`` values, each with the fixed settings first."""
    axes = [[(k, v.strip()) for v in values.split(",")] for k, values in vary]
    return [fixed + list(combo) for combo in itertools.product(*axes)] if axes else [fixed]


def build(registry: Any, name: str, settings: list[tuple[str, str]]) -> Any:
    """The problem ``name`` with ``settings`` (dotted keys, YAML values), checked as the CLI."""
    try:
        cls = registry.problem(name)
    except KeyError:
        raise ConfigError("problem", name,
                          "one of " + ", ".join(sorted(registry.problems))) from None
    try:
        mapping = OmegaConf.to_container(OmegaConf.from_dotlist([f"{k}={v}" for k, v in settings]))
    except Exception as exc:  # noqa: BLE001 - OmegaConf or YAML refuses the text: one line
        raise ConfigError("settings", " ".join(f"{k}={v}" for k, v in settings),
                          f"key=value pairs with YAML values ({type(exc).__name__})") from None
    return cls(build_dataclass(cls.Config, mapping, prefix="problem"))


def measure(problem: Any, floor: int, profile: bool) -> dict[str, Any]:
    """The design's numbers (see the module)."""
    crb = cramer_rao(problem)
    if crb is None:
        raise ConfigError("problem", problem.name, "a problem with residuals, its truth and a "
                          "noise level (no Cramér–Rao bound without them)")
    rel = np.asarray(crb["crb_percent"]) / 100.0
    s = np.asarray(crb["singular_values"])
    d = rel.size
    out: dict[str, Any] = {
        "crb_norm": crb["crb_norm_percent"], "condition": crb["condition_number"],
        "d_opt": float(np.exp(2.0 * np.sum(np.log(np.maximum(s, 1e-300))) / d)),
        "a_opt": float(np.sum(rel**2)),
        "undetermined": [f"{n} ({100 * r:.3g} %)" for n, r in zip(crb["names"], rel,
                                                                   strict=True)
                         if 100 * r > UNDETERMINED_PERCENT],
        # the condition number is of the same whitened, scaled Jacobian: no second one
        "structural": (crb["condition_number"] is None
                       or crb["condition_number"] >= 1.0 / STRUCTURAL_RATIO),
        "floor": None, "profile": None,
    }
    if floor:
        measured = truth_optima_metric(problem, floor)
        out["floor"] = statistics.median(measured[1]) if measured else None
    if profile:
        out["profile"] = profile_intervals(problem, crb)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="vpid-bench-design",
                                 description=__doc__.split("\n\n")[0],
                                 epilog="Docs: docs/estimators.md (record design).")
    ap.add_argument("problem", help="a registered problem (vpid-bench --help lists them)")
    ap.add_argument("settings", nargs="*", help="key=value for every design")
    ap.add_argument("--vary", action="append", default=[], metavar="KEY=A,B",
                    help="a factor: one design per value (repeat for more factors)")
    ap.add_argument("--floor", type=int, default=0, metavar="N",
                    help="measure the floor of the problem's objective on N instances")
    ap.add_argument("--profile", action="store_true",
                    help="profile-likelihood 95 %% intervals of instance 0")
    args = ap.parse_args(argv)
    try:
        if not 0 <= args.floor <= 1000:
            raise ConfigError("--floor", args.floor, "an integer in [0, 1000]")
        registry = Registry()
        candidates = designs(_settings(args.settings, "settings"), _settings(args.vary, "--vary"))
        if len(candidates) > 200:
            raise ConfigError("--vary", len(candidates), "at most 200 designs")
        results = []
        for k, settings in enumerate(candidates, 1):
            label = " ".join(f"{key}={v}" for key, v in settings) or "(defaults)"
            print(f"design {k}/{len(candidates)}: {label}", file=sys.stderr, flush=True)
            results.append((label, measure(build(registry, args.problem, settings),
                                           args.floor, args.profile)))
    except VpidBenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    results.sort(key=lambda item: item[1]["crb_norm"])
    floor = f"floor (median over {args.floor})" if args.floor else "floor"
    print(f"Designs of `{args.problem}`, best first by the Cramér–Rao norm (instance 0):\n")
    print(f"| design | CRB norm (%) | {floor} | condition | D-opt | A-opt | "
          f"undetermined (> {UNDETERMINED_PERCENT:g} %) | structural symmetry |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for label, m in results:
        cell = "" if m["floor"] is None else f"{m['floor']:.3g}"
        print(f"| {label} | {m['crb_norm']:.3g} | {cell} | {m['condition']:.3g} | "
              f"{m['d_opt']:.3g} | {m['a_opt']:.3g} | {', '.join(m['undetermined']) or 'none'} | "
              f"{'yes' if m['structural'] else 'no'} |")
    for label, m in results:
        if m["profile"] is None:
            continue
        p = m["profile"]
        print(f"\nProfile-likelihood 95 % intervals, {label} (instance 0):\n")
        print("| parameter | estimate | lower | upper | classification |")
        print("| --- | --- | --- | --- | --- |")
        for j, n in enumerate(p["names"]):
            lo, up = p["lower"][j], p["upper"][j]
            print(f"| {n} | {p['estimate'][j]:.5g} | {'open' if lo is None else f'{lo:.5g}'} "
                  f"| {'open' if up is None else f'{up:.5g}'} | {p['classification'][j]} |")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
