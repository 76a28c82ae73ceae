"""Random search: candidates drawn uniformly in the box, ``ps`` per batch.

The null baseline of every report: an optimizer that does not beat it at the same budget
has learned nothing from the objective. Also the example of a third-party plugin: this
package lives outside vpid-bench and is found through its ``vpid_bench`` entry point.
"""

from dataclasses import dataclass

import numpy as np

from vpid_bench import Optimizer, OptimizerParams, hookimpl


@dataclass(frozen=True)
class RandomSearchParams(OptimizerParams):
    """No parameters beyond the batch size ``ps`` (candidates per ask)."""


class RandomSearch(Optimizer):
    """Uniform sampling in the bounds; keeps nothing (the run loop tracks the best)."""

    Params = RandomSearchParams

    def ask(self) -> np.ndarray:
        return self.bounds.sample(self.rng, self.params.ps)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        pass


@hookimpl
def vpid_bench_register_optimizers(register):
    register("random", RandomSearch)
