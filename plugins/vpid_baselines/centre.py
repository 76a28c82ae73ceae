"""``optimizer=centre``: the do-nothing answer, the centre of the box, one evaluation.

It proposes ``(lower + upper) / 2`` once and is done. Every report that includes it shows what
an answer that never looked at the data scores: on a problem whose truth sits at the centre of
its box (the paper's), it scores a NoRE of 0, which is why the suite's problems place the truth
at a random place in the box.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vpid_bench import Optimizer, OptimizerParams


@dataclass(frozen=True)
class CentreParams(OptimizerParams):
    """No parameters: one candidate, the box centre."""


class Centre(Optimizer):
    """Asks for the box centre once, then is done (the run uses one evaluation)."""

    Params = CentreParams

    def ask(self) -> np.ndarray:
        return ((self.bounds.lower + self.bounds.upper) / 2.0)[None, :]

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        self.done = True
