"""Hydra config nodes built from dataclasses: the job spec and every registered plugin.

Called once at start-up (never at import). The job spec's defaults become the primary
config's top-level keys (``conf/config.yaml`` lists ``vpid_bench_spec`` in its defaults), so
the keys are declared once, in :class:`vpid_bench.spec.JobSpec`. Each optimizer becomes a choice
of the ``optimizer`` group and each problem of the ``problem`` group, so ``optimizer=<name>``
works for a third-party optimizer that ships no YAML. An optimizer's node leaves out the
protocol keys (``ps``, ``iterations``): the job copies them from the problem.
"""

from __future__ import annotations

from ..params import dataclass_defaults, hydra_node
from ..plugins import Registry
from ..problem import FILLED_PARAMS
from ..spec import JobSpec

SPEC_NODE = "vpid_bench_spec"
#: Hydra's default job logging without its file handler: Hydra configures logging before our
#: task runs, so a job folder it cannot write would stop the whole sweep; the task opens the
#: job's log file itself (``vpid_bench.log``, see :mod:`.main`), inside its error handling.
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
    cs.store(name=SPEC_NODE, node=dataclass_defaults(JobSpec), provider="vpid-bench")
    for name, cls in sorted(registry.optimizers.items()):
        cs.store(group="optimizer", name=name,
                 node=hydra_node(cls.Params, name, exclude=FILLED_PARAMS),
                 provider=registry.owner("optimizer", name))
    for name, cls in sorted(registry.problems.items()):
        cs.store(group="problem", name=name, node=hydra_node(cls.Config, name),
                 provider=registry.owner("problem", name))
