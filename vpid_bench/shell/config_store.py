"""Hydra config nodes built from dataclasses: the job spec and every registered plugin.

Called once at start-up. The spec node (``vpid_bench_spec``, first in a config's defaults)
declares the top-level keys once, from :class:`vpid_bench.spec.JobSpec`, with Hydra's settings
for vpid-bench (``hydra_settings.yaml``), so a user's own config behaves like the shipped one.
Each plugin becomes a choice of its group (a third-party optimizer needs no YAML); an
optimizer's node leaves out what the job fills in.
"""

from __future__ import annotations

import importlib.resources
from typing import Any

from ..params import dataclass_defaults, hydra_node, open_key_paths
from ..plugins import Registry
from ..problem import FILLED_PARAMS
from ..spec import JobSpec

SPEC_NODE = "vpid_bench_spec"
#: Hydra's settings (a YAML file of this package), merged into the spec node.
HYDRA_SETTINGS = "hydra_settings.yaml"
#: Hydra's job logging without its file handler (opened outside our task, a folder it cannot
#: write would stop the sweep): the task opens ``vpid_bench.log`` itself (:mod:`.main`).
JOB_LOGGING = {
    "version": 1,
    "formatters": {"simple": {"format": "[%(asctime)s][%(name)s][%(levelname)s] - %(message)s"}},
    "handlers": {"console": {"class": "logging.StreamHandler", "formatter": "simple",
                             "stream": "ext://sys.stdout"}},
    "root": {"level": "INFO", "handlers": ["console"]},
    "disable_existing_loggers": False,
}


def register_configs(registry: Registry) -> None:
    """Store the spec node and a node per registered optimizer and problem in Hydra's
    ConfigStore."""
    from hydra.core.config_store import ConfigStore

    cs = ConfigStore.instance()
    cs.store(group="hydra/job_logging", name="vpid_bench", node=JOB_LOGGING,
             provider="vpid-bench")
    cs.store(name=SPEC_NODE, node=spec_node(), provider="vpid-bench")
    for name, cls in sorted(registry.optimizers.items()):
        cs.store(group="optimizer", name=name,
                 node=hydra_node(cls.Params, name, exclude=FILLED_PARAMS),
                 provider=registry.owner("optimizer", name))
    for name, cls in sorted(registry.problems.items()):
        cs.store(group="problem", name=name, node=problem_node(cls.Config, name),
                 provider=registry.owner("problem", name))


def problem_node(config: type, name: str) -> Any:
    """A problem's node, its ``added_setting(open_keys=True)`` mappings left open to new
    keys (the problem checks those names itself)."""
    node = hydra_node(config, name)
    paths = open_key_paths(config)
    if not paths:
        return node
    from omegaconf import OmegaConf

    out = OmegaConf.create(node)
    for path in paths:
        OmegaConf.set_struct(OmegaConf.select(out, path), False)
    return out


def hydra_settings() -> dict[str, Any]:
    """The ``hydra`` node of :data:`HYDRA_SETTINGS` (interpolations unresolved)."""
    from omegaconf import OmegaConf

    text = importlib.resources.files(__package__).joinpath(HYDRA_SETTINGS).read_text()
    return OmegaConf.to_container(OmegaConf.create(text), resolve=False)["hydra"]


def spec_node() -> dict[str, Any]:
    """The ``vpid_bench_spec`` node: every top-level key at its default, Hydra's settings for
    vpid-bench and the job logging without a file handler (see :data:`JOB_LOGGING`)."""
    return {"defaults": [{"override hydra/job_logging": "vpid_bench"}, "_self_"],
            **dataclass_defaults(JobSpec), "hydra": hydra_settings()}
