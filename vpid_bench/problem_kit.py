"""What problem plugins share beyond :class:`~vpid_bench.problem.Problem`, written once:
:class:`ChannelFit`, the weighted-residual path of a problem that fits measured channels, and
:class:`FrozenMap` with :func:`freeze_fields`, a config's open-key mapping made read-only and
hashable (a problem is cached by its config)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from . import estimators
from .errors import ConfigError


class ChannelFit:
    """A problem mixin for a problem that fits ``measured`` channels ``(p, N)`` sampled at
    ``t`` (s), named with units by ``channels`` (``((name, unit), ...)``), with the objective
    ``config.objective`` (:mod:`vpid_bench.estimators`) and its fixed ``weights``; the problem
    gives :meth:`computed` ``(n, p, N)`` (NaN rows where a row is not simulated). Residuals:
    channels one after another, inf rows where a simulation fails."""

    measured: np.ndarray
    weights: np.ndarray
    t: np.ndarray
    channels: tuple[tuple[str, str], ...]

    def computed(self, X: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def evaluate_with_residuals(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        weighted = (self.measured[None] - self.computed(X)) * self.weights
        return estimators.residuals_and_value(self.config.objective, weighted)

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        return self.evaluate_with_residuals(X)[0]

    def residuals(self, X: np.ndarray) -> np.ndarray:
        """What a least-squares optimizer minimises (:func:`estimators.residuals_and_value`)."""
        return self.evaluate_with_residuals(X)[1]

    def fisher_residuals(self, X: np.ndarray) -> np.ndarray:
        """``(measured_c - computed_c) / ||measured_c||`` whatever the objective."""
        scale = np.linalg.norm(self.measured, axis=1)[None, :, None]
        R = (self.measured[None] - self.computed(X)) / scale
        R[~np.all(np.isfinite(R), axis=(1, 2))] = np.inf
        return R.reshape(R.shape[0], -1)

    def fisher_groups(self) -> np.ndarray:
        """The channel of each entry of :meth:`fisher_residuals`."""
        return np.repeat(np.arange(self.measured.shape[0]), self.measured.shape[1])

    def residual_groups(self) -> np.ndarray:
        """One group per channel for ``eq3`` (a norm each), one for the sums of squares."""
        return estimators.groups(self.config.objective, *self.measured.shape)

    def signal_units(self) -> dict[str, str]:
        return dict(self.channels)

    def signals(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Each channel measured and fitted at the record's times ``t``."""
        fitted = self.computed(np.asarray(x, dtype=float).reshape(1, -1))[0]
        out = {"t": self.t.copy()}
        for c, (name, _) in enumerate(self.channels):
            out[f"{name}:measured"], out[f"{name}:fitted"] = self.measured[c].copy(), fitted[c]
        return out


def _freeze(value: Any) -> Any:
    if isinstance(value, Mapping):
        return FrozenMap(value)
    if isinstance(value, (list, tuple)) or (hasattr(value, "__iter__")
                                            and not isinstance(value, (str, bytes))):
        return tuple(_freeze(v) for v in value)
    return value


class FrozenMap(dict):
    """A read-only mapping that hashes, its keys strings, its values frozen (mappings become
    FrozenMaps, sequences tuples)."""

    def __init__(self, items: Any = ()) -> None:
        super().__init__({str(k): _freeze(v) for k, v in dict(items).items()})

    def __hash__(self) -> int:  # type: ignore[override]
        return hash(tuple(sorted(self.items())))

    def __reduce__(self) -> Any:
        return (FrozenMap, (dict(self),))

    def _read_only(self, *args: Any, **kwargs: Any) -> Any:
        raise TypeError("a config mapping is read-only")

    __setitem__ = __delitem__ = update = pop = popitem = clear = setdefault = _read_only  # type: ignore[assignment]


def freeze_fields(config: Any, *names: str, prefix: str = "problem.") -> None:
    """Make the mapping fields ``names`` of a frozen config :class:`FrozenMap` (``None``: an
    empty one), or raise a :class:`ConfigError` naming ``<prefix><name>``."""
    for name in names:
        value = getattr(config, name)
        if value is None:
            value = {}
        if not isinstance(value, Mapping):
            raise ConfigError(f"{prefix}{name}", value, "a mapping of names, e.g. "
                              f"{prefix}{name}.<name>=...")
        object.__setattr__(config, name, FrozenMap(value))
