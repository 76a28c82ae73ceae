"""The errors this package raises on purpose; the CLI shows each as one line."""

from __future__ import annotations

from typing import Any


class VpidBenchError(Exception):
    """Base class of the errors this package raises on purpose (shown as one line by the CLI)."""


class ConfigError(VpidBenchError, ValueError):
    """A configuration value not allowed: its message names the key, the value and what is."""

    def __init__(self, key: str, value: Any, allowed: str) -> None:
        self.key, self.value, self.allowed = key, value, allowed
        super().__init__(f"{key}={value!r} is not allowed: {allowed}")


class PluginError(VpidBenchError):
    """A plugin could not be loaded or registered (name collision, bad registration)."""


class OptimizerContractError(VpidBenchError):
    """An optimizer broke the ask/tell contract (wrong shape, NaN, outside the box, ...)."""
