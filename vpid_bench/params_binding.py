"""The trap of an optimizer plugin that forgets ``Params = MyParams`` (issue 46).

Such a class inherits :class:`~vpid_bench.optimizer.OptimizerParams` as its ``Params``: the
job builds the base parameters, and every run failed with an ``AttributeError`` on the
first parameter of its own the code read. :func:`check_params_bound` reads the class's own
source (its syntax tree, nothing is run) for ``self.params.<name>`` and ``params.<name>``
and refuses, before any run, a class whose ``Params`` is the base class while it reads
names the base does not have.
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import inspect
import textwrap

from .errors import ConfigError
from .optimizer import OptimizerParams


@functools.lru_cache(maxsize=256)
def params_read(cls: type) -> frozenset[str]:
    """The attribute names the code of ``cls`` and of its bases outside vpid-bench (what a
    plugin author wrote) reads from ``self.params`` or ``params`` (once per class)."""
    names: set[str] = set()
    for klass in cls.__mro__:
        if klass.__module__ in ("builtins", "abc", "vpid_bench.optimizer"):
            continue
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
        except (OSError, TypeError, SyntaxError):  # no readable source: nothing to read
            continue
        for node in ast.walk(tree):
            if not isinstance(node, ast.Attribute) or not isinstance(node.ctx, ast.Load):
                continue
            owner = node.value
            plain = isinstance(owner, ast.Name) and owner.id == "params"
            on_self = (isinstance(owner, ast.Attribute) and owner.attr == "params"
                       and isinstance(owner.value, ast.Name) and owner.value.id == "self")
            if plain or on_self:
                names.add(node.attr)
    return frozenset(names)


def check_params_bound(cls: type, name: str) -> None:
    """Refuse optimizer ``name`` whose ``Params`` is still the base
    :class:`~vpid_bench.optimizer.OptimizerParams` (``Params = MyParams`` not bound) while
    its code reads parameters of its own, naming them. A class that binds a ``Params`` of its
    own is not judged (a subclass may override every method that reads a base's field)."""
    params = getattr(cls, "Params", None)
    if params is not OptimizerParams:
        return
    fields = {f.name for f in dataclasses.fields(params)}
    missing = sorted(params_read(cls) - fields - set(dir(params)))
    if missing:
        raise ConfigError(f"optimizer={name}", params.__name__,
                          f"a Params dataclass with the parameters its code reads ("
                          f"{', '.join(missing)} missing from {params.__name__}): bind "
                          f"Params = <your dataclass> in the class body (docs/plugins.md)")
