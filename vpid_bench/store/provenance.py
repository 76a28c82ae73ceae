"""Provenance: which versions of what produced a record, each looked up once per process: the
numerical stack, each plugin's distribution and requirements (a resumed job tells runs made by
another release) and a digest of its installed source (:func:`code_digest`: it enters each
run's id, so a plugin changed under the same version, which once served its old records, runs
again).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.metadata
import platform
import re
import sys
from pathlib import Path
from typing import Any

#: Packages whose version can change a result, recorded in every record.
CORE_PACKAGES = ("vpid-bench", "numpy", "scipy", "numba", "hydra-core", "pluggy")


@functools.lru_cache(maxsize=8)
def package_versions(extra: tuple[str, ...] = ()) -> dict[str, str]:
    """Versions of Python and of :data:`CORE_PACKAGES` (plus ``extra``) that are installed."""
    out = {"python": platform.python_version()}
    for dist in (*CORE_PACKAGES, *extra):
        with contextlib.suppress(importlib.metadata.PackageNotFoundError):
            out[dist] = importlib.metadata.version(dist)
    return out


_REQUIREMENT_NAME = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)")


@functools.lru_cache(maxsize=64)
def _provenance_of(dist_name: str) -> tuple[str, str, tuple[tuple[str, str], ...]]:
    """Name, version and the installed versions of its requirements (those of extras left out)."""
    dist = importlib.metadata.distribution(dist_name)
    requires = []
    for req in dist.requires or []:
        match = _REQUIREMENT_NAME.match(req)
        if match is None or ";" in req and "extra" in req.split(";", 1)[1]:
            continue
        try:
            requires.append((match.group(1), importlib.metadata.version(match.group(1))))
        except importlib.metadata.PackageNotFoundError:
            requires.append((match.group(1), "not installed"))
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


def library_provenance(dist: str) -> dict[str, str]:
    """``{"name", "version"}`` of the library distribution ``dist`` an optimizer runs
    (``Optimizer.library``); the version ``"not installed"`` when no such distribution is."""
    try:
        version = importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        version = "not installed"
    return {"name": dist, "version": version}


#: Source bytes read for a plugin's code digest; past it, files count by path, size and
#: modification time (a class defined inside a large library should not read all of it).
MAX_CODE_BYTES = 32 * 1024 * 1024


@functools.lru_cache(maxsize=64)
def _tree_digest(root: str) -> str:
    """SHA-256 (16 hex digits) of every ``.py`` file below ``root`` (or the file), in order."""
    base = Path(root)
    files = [base] if base.is_file() else sorted(
        p for p in base.rglob("*.py") if "__pycache__" not in p.parts and p.is_file())
    h = hashlib.sha256()
    budget = MAX_CODE_BYTES
    for path in files:
        rel = path.name if path == base else str(path.relative_to(base))
        info = path.stat()
        h.update(f"{rel}\0{info.st_size}\0".encode())
        if info.st_size <= budget:
            budget -= info.st_size
            h.update(path.read_bytes())
        else:
            h.update(str(info.st_mtime_ns).encode())
    return h.hexdigest()[:16]


def code_digest(cls: type) -> str | None:
    """A digest of the installed code of the top-level package (or module) defining ``cls``;
    ``None`` without a source file (defined interactively, or in a zip)."""
    top = cls.__module__.split(".")[0]
    for name in (top, cls.__module__):
        file = getattr(sys.modules.get(name), "__file__", None)
        if file:
            path = Path(file)
            root = path.parent if path.name == "__init__.py" else path
            try:
                return _tree_digest(str(root.resolve()))
            except OSError:
                return None
    return None
