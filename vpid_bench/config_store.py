"""Hydra config nodes for every registered plugin, built from their dataclasses.

Called once at start-up (never at import): each optimizer becomes a choice of the
``optimizer`` group and each problem of the ``problem`` group, so ``optimizer=<name>`` works
for a third-party optimizer that ships no YAML. An optimizer's ``ps`` and ``iterations``
default to ``${problem.ps}`` and ``${problem.iterations}``: the problem carries the protocol.
"""

from __future__ import annotations

from .params import hydra_node
from .plugins import Registry

OPTIMIZER_INTERPOLATIONS = {"ps": "${problem.ps}", "iterations": "${problem.iterations}"}


def register_configs(registry: Registry) -> None:
    """Store a node per registered optimizer and problem in Hydra's ConfigStore."""
    from hydra.core.config_store import ConfigStore

    cs = ConfigStore.instance()
    for name, cls in sorted(registry.optimizers.items()):
        cs.store(group="optimizer", name=name,
                 node=hydra_node(cls.Params, name, OPTIMIZER_INTERPOLATIONS),
                 provider=registry.owner("optimizer", name))
    for name, cls in sorted(registry.problems.items()):
        cs.store(group="problem", name=name, node=hydra_node(cls.Config, name),
                 provider=registry.owner("problem", name))
