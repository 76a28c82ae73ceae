"""Small problems and optimizers for the peers tests."""

from __future__ import annotations

import numpy as np

from vpid_bench.api import Bounds, Problem


class LinearLSQ(Problem):
    """Residuals ``r = b - A x`` (one group, or split into ``groups``) over a box; ``f`` is the
    sum of the group norms. Counts every row it evaluates."""

    name = "linear_lsq"

    def __init__(self, A: np.ndarray, b: np.ndarray, lower, upper, groups=None) -> None:
        super().__init__(None)
        self.A, self.b = np.asarray(A, float), np.asarray(b, float)
        d = self.A.shape[1]
        self._bounds = Bounds(np.broadcast_to(lower, d), np.broadcast_to(upper, d),
                              tuple(f"x{i}" for i in range(d)))
        self.groups = np.zeros(self.b.size, int) if groups is None else np.asarray(groups)
        self.evaluated = 0

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    def residuals(self, X):
        return self.b[None] - np.atleast_2d(X) @ self.A.T

    def residual_groups(self):
        return self.groups.copy()

    def evaluate(self, X):
        self.evaluated += len(X)
        R = self.residuals(X)
        return sum(np.linalg.norm(R[:, self.groups == g], axis=1)
                   for g in range(self.groups.max() + 1))


class NoResiduals(Problem):
    """The sphere on [-1, 1]^3, without residuals; counts evaluated rows."""

    name = "plain_sphere"

    def __init__(self) -> None:
        super().__init__(None)
        self._bounds = Bounds(-np.ones(3), np.ones(3), ("a", "b", "c"))
        self.evaluated = 0

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    def evaluate(self, X):
        self.evaluated += len(X)
        return np.sum(np.atleast_2d(X) ** 2, axis=1)


def loop_threads() -> list:
    """Bridge worker threads still alive."""
    import threading

    return [t for t in threading.enumerate() if t.name.startswith("vpid-bench loop")]


def run_optimizer(registry, name: str, problem, seed: int, budget: int | None = None,
                  **overrides):
    """Run optimizer ``name`` on ``problem`` (its protocol's budget unless ``budget``);
    returns the run result and the optimizer."""
    from vpid_bench.build import optimizer_params
    from vpid_bench.runner import run

    cfg = problem.config
    cls, params = optimizer_params(
        registry, {"name": name, "ps": cfg.ps, "iterations": cfg.iterations, **overrides}
    )
    optimizer = cls(params, problem.bounds, np.random.default_rng(seed))
    return run(problem, optimizer, budget or cfg.ps * (cfg.iterations + 1)), optimizer
