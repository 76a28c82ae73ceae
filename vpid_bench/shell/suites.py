"""``suite=<name>`` on the command line: the sweep of every problem of a named suite.

A suite is what its problems declare (``Problem.suites``); ``-m suite=smoke`` becomes
``-m problem=<each problem of smoke>`` before the pre-flight and Hydra see the command line,
so every member runs with its own defaults and everything else (optimizers, keys, resume)
works as for any problem sweep.
"""

from __future__ import annotations

import dataclasses

from ..errors import ConfigError
from ..plugins import Registry
from .argv import CommandLine


def expand_suites(cmd: CommandLine, registry: Registry) -> CommandLine:
    """``cmd`` with a ``suite=a[,b]`` override replaced by ``problem=<members>``. Refused in
    one line: an unknown suite (naming the known ones), a suite without ``-m``, a suite
    together with ``problem=``."""
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

    return dataclasses.replace(cmd, overrides=swap(cmd.overrides),
                               hydra_args=swap(cmd.hydra_args))
