"""Provenance: which versions of what produced a record.

Two kinds of facts, both looked up once per process (reading package metadata costs
milliseconds and a record is written per run):

* :func:`package_versions`: Python and the numerical stack that can change any result;
* :func:`distribution_provenance`: for a plugin, the distribution that ships it, its version
  and the installed versions of what it declares it requires. The plugin registry records this
  when it loads each entry point, so a record can name the exact plugin release, and a resumed
  job can tell runs made by another release (see :mod:`vpid_bench.experiment`).
"""

from __future__ import annotations

import functools
import importlib.metadata
import platform
import re
from typing import Any

#: Packages whose version can change a result, recorded in every record.
CORE_PACKAGES = ("vpid-bench", "numpy", "scipy", "numba", "hydra-core", "pluggy")


@functools.lru_cache(maxsize=8)
def package_versions(extra: tuple[str, ...] = ()) -> dict[str, str]:
    """Versions of Python and of :data:`CORE_PACKAGES` (plus ``extra``) that are installed."""
    out = {"python": platform.python_version()}
    for dist in (*CORE_PACKAGES, *extra):
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            continue
    return out


_REQUIREMENT_NAME = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)")


def _requirement_names(dist: importlib.metadata.Distribution) -> list[str]:
    """Names of the distribution's unconditional requirements (extras and markers skipped)."""
    names = []
    for req in dist.requires or []:
        if ";" in req and "extra" in req.split(";", 1)[1]:
            continue
        match = _REQUIREMENT_NAME.match(req)
        if match:
            names.append(match.group(1))
    return names


@functools.lru_cache(maxsize=64)
def _provenance_of(dist_name: str) -> tuple[str, str, tuple[tuple[str, str], ...]]:
    dist = importlib.metadata.distribution(dist_name)
    requires = []
    for name in _requirement_names(dist):
        try:
            requires.append((name, importlib.metadata.version(name)))
        except importlib.metadata.PackageNotFoundError:
            requires.append((name, "not installed"))
    return dist.metadata["Name"], dist.version, tuple(sorted(requires))


def distribution_provenance(dist: importlib.metadata.Distribution | None) -> dict[str, Any]:
    """``{"distribution", "version", "requires": {name: installed version}}`` of a plugin's
    distribution; ``{}`` for a plugin that no installed distribution ships (tests, scripts)."""
    if dist is None:
        return {}
    try:
        name, version, requires = _provenance_of(dist.metadata["Name"])
    except (importlib.metadata.PackageNotFoundError, KeyError, TypeError):
        return {"distribution": str(dist.metadata["Name"]), "version": str(dist.version),
                "requires": {}}
    return {"distribution": name, "version": version, "requires": dict(requires)}
