"""``optimizer=centre``: the do-nothing answer, ``(lower + upper) / 2``, one evaluation: what
an answer that never looked at the data scores (NoRE 0 where the truth is the box's centre,
as in the paper, which is why the suite's truths are random)."""

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
