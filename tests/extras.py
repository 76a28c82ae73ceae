"""Which optional extras are installed, for skip marks that name the missing extra.

``importlib.util.find_spec("hydra_plugins.x")`` raises ``ModuleNotFoundError`` when no Hydra
plugin at all is installed (the ``hydra_plugins`` namespace itself is missing, as with only the
``[test]`` extra), so a module-level skip mark built on it fails collection instead of skipping.
"""

from __future__ import annotations

import importlib.util

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
