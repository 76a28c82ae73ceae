"""``vpid-bench --help`` answered without Hydra's help machinery (it deep-copies the config
store once per config group: 4-9 s before a word, issue 46): the header and footer of
``hydra_settings.yaml``, the registry's choices and one composition of the selected config.
A custom config or a sweep's comma list still goes to Hydra.
"""

from __future__ import annotations

from typing import Any

from omegaconf import OmegaConf

from .argv import CommandLine
from .compose import SHIPPED, _compose, initialize
from .config_store import hydra_settings
from .preflight import _group_names


def choices(registry: Any) -> list[str]:
    """One ``group: name, name, ...`` line per group (plugins and presets)."""
    return [f"{group}: " + ", ".join(_group_names(group, registry))
            for group in ("optimizer", "problem")]


def help_text(cmd: CommandLine, registry: Any) -> str | None:
    """The help page for ``cmd``, or ``None`` when only Hydra can build it."""
    if cmd.custom_config or any("," in o for o in cmd.overrides):
        return None
    with initialize(SHIPPED):
        cfg = _compose(list(cmd.overrides), hydra=False)
    text = hydra_settings()["help"]
    return (f"{text['header']}\n== Choices (group=option) ==\n" + "\n".join(choices(registry))
            + "\n\n\n== Config of this selection (override any key: key=value) ==\n"
            + OmegaConf.to_yaml(cfg) + "\n" + text["footer"])
