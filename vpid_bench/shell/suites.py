"""``suite=<name>``: ``-m suite=smoke`` becomes ``-m problem=<each problem of smoke>`` (a
suite is what its problems declare, ``Problem.suites``) before the pre-flight and Hydra see it.
"""

from __future__ import annotations

import dataclasses

from ..errors import ConfigError
from ..plugins import Registry
from .argv import CommandLine


def expand_suites(cmd: CommandLine, registry: Registry) -> CommandLine:
    """``cmd`` with ``suite=a[,b]`` replaced by ``problem=<members>``; an unknown suite, one
    without ``-m`` or with ``problem=`` refused in one line."""
    given = [o for o in cmd.overrides if o.startswith("suite=")]
    if not given:
        return cmd
    known = registry.suites()
    value = given[-1].split("=", 1)[1]
    names = [v.strip() for v in value.split(",") if v.strip()]
    for name in names or [value]:
        if name not in known:
            raise ConfigError("suite", value, "one of " + (", ".join(sorted(known)) or
                                                            "(no installed problem declares one)"))
    if not cmd.multirun:
        raise ConfigError("suite", value, "a sweep of its problems: add -m")
    if any(o.split("=", 1)[0].lstrip("+~") == "problem" for o in cmd.overrides):
        raise ConfigError("suite", value, "either suite= or problem=, not both")
    members = sorted({p for name in names for p in known[name]})
    override = "problem=" + ",".join(members)

    def swap(args: list[str]) -> list[str]:
        return [override if a.startswith("suite=") else a for a in args
                if not (a.startswith("suite=") and a != given[-1])]

    return dataclasses.replace(cmd, overrides=swap(cmd.overrides), hydra_args=swap(cmd.hydra_args))
