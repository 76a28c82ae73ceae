"""vpid-bench's default Hydra sweeper: Hydra's basic sweeper without its second check.

Hydra's basic sweeper composes every job's config twice: once to validate the whole batch
before launching it, and again when the launcher starts the job. vpid-bench's pre-flight
(:mod:`vpid_bench.shell.preflight`) has already composed and checked every point of the
command, with more checks than Hydra's validation (the plugins' own ranges, the job spec,
the reference data), and stopped the command with one line on any fault before Hydra
started. So this sweeper launches the batches as the basic sweeper does (same expansion,
same order, same job numbers and folders) and leaves out the repeated validation: on the
paper experiment (18 jobs) that is 18 compositions of about 0.1 s each.

It lives in the ``hydra_plugins`` namespace because Hydra instantiates sweepers only from
there. ``conf/config.yaml`` selects it (``override hydra/sweeper: vpid_bench``); any other
sweeper (``hydra/sweeper=optuna``, say) still works, with its own validation.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from hydra.plugins.sweeper import Sweeper


class PreflightSweeper(Sweeper):
    """Hydra's :class:`BasicSweeper` for points that vpid-bench's pre-flight has checked.

    It wraps a basic sweeper rather than subclassing it: Hydra's plugin scan re-executes the
    module that defines ``BasicSweeper``, and a subclass made before the scan would then fail
    the basic sweeper's own ``super(BasicSweeper, self)`` call."""

    def __init__(self, max_batch_size: int | None = None, params: Any = None) -> None:
        from hydra._internal.core_plugins.basic_sweeper import BasicSweeper

        super().__init__()
        self.basic = BasicSweeper(max_batch_size=max_batch_size, params=params)
        self.basic.validate_batch_is_legal = self._checked_by_preflight  # type: ignore[method-assign]

    @staticmethod
    def _checked_by_preflight(batch: Sequence[Sequence[str]]) -> None:
        """Nothing to do: the pre-flight composed and checked every point of the batch."""
        return None

    def setup(self, *, hydra_context: Any, task_function: Any, config: Any) -> None:
        self.basic.setup(hydra_context=hydra_context, task_function=task_function,
                         config=config)

    def sweep(self, arguments: list[str]) -> Any:
        return self.basic.sweep(arguments)
