"""problem=quarter_car: identify a quarter-car's sprung mass, spring and damper from the
body's vertical acceleration as it drives over a bump.

Two degrees of freedom (SI units): the sprung mass ``ms`` (body, height zs) rides on the
suspension spring ``ks`` and damper ``cs`` above the unsprung mass ``mu`` (wheel, height zu),
which rides on the tyre spring ``kt``; the road height y(t) acts through the tyre:

    ms zs'' = -ks (zs - zu) - cs (zs' - zu')
    mu zu'' =  ks (zs - zu) + cs (zs' - zu') - kt (zu - y)

The car meets a rectangular bump (``bump_height``, ``bump_length``) at t = 0 at ``speed``
km/h. The record is zs'' sampled every ``dt`` s for ``duration`` s, the true car's response
times (1 + noise n) with n ~ N(0, 1) drawn from ``noise_seed``. Unknowns: ms, ks, cs, in
[0.5, 1.5] x their true values; mu and kt are known. Objective: ||measured - computed|| /
||measured|| (Euclidean norms over the samples).
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vpid_bench import Bounds, ConfigError, Problem, ProblemConfig, hookimpl

NAMES, UNITS = ("ms", "ks", "cs"), ("kg", "N/m", "N s/m")


@dataclass(frozen=True)
class QuarterCarConfig(ProblemConfig):  # inherits ps = 20, iterations = 50 (the protocol)
    ms: float = 250.0  # sprung mass, kg (true value, identified)
    ks: float = 16000.0  # suspension stiffness, N/m (true value, identified)
    cs: float = 1000.0  # suspension damping, N s/m (true value, identified)
    mu: float = 35.0  # unsprung mass, kg (known)
    kt: float = 160000.0  # tyre stiffness, N/m (known)
    speed: float = 20.0  # km/h
    bump_height: float = 0.04  # m
    bump_length: float = 0.10  # m
    duration: float = 1.5  # record length, s
    dt: float = 0.002  # sample interval, s
    noise: float = 0.05  # relative noise level (0.05 = 5 %)
    noise_seed: int = 0

    def __post_init__(self) -> None:
        units = dict(ms="kg", ks="N/m", cs="N s/m", mu="kg", kt="N/m", speed="km/h",
                     bump_length="m", duration="s", dt="s")
        for key, unit in units.items():
            if not 0 < getattr(self, key) < np.inf:
                raise ConfigError(f"problem.{key}", getattr(self, key), f"a number > 0 ({unit})")
        if not abs(self.bump_height) < np.inf:
            raise ConfigError("problem.bump_height", self.bump_height, "a finite height (m)")
        if not self.dt < self.duration:
            raise ConfigError("problem.dt", self.dt, f"a step below duration = {self.duration} s")
        if not 0 <= self.noise <= 1:
            raise ConfigError("problem.noise", self.noise, "a level in [0, 1] (0.05 = 5 %)")
        if self.noise_seed < 0:
            raise ConfigError("problem.noise_seed", self.noise_seed, "an integer >= 0")


class QuarterCar(Problem):
    """The measured record is made once, here; evaluate() fits it for a batch of candidates."""

    Config = QuarterCarConfig

    def __init__(self, config: QuarterCarConfig) -> None:
        super().__init__(config)
        c = config
        self._x_true = np.array([c.ms, c.ks, c.cs])
        self._bounds = Bounds(0.5 * self._x_true, 1.5 * self._x_true, NAMES, UNITS)
        self.t = np.arange(int(round(c.duration / c.dt))) * c.dt
        self.t_off = c.bump_length / (c.speed / 3.6)  # s: when the tyre leaves the bump
        clean = self.responses(self._x_true)[0]
        rng = np.random.default_rng(c.noise_seed)
        self.measured = clean * (1 + c.noise * rng.standard_normal(clean.size))

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    @property
    def x_true(self) -> np.ndarray:
        return self._x_true.copy()

    def responses(self, X: np.ndarray) -> np.ndarray:
        """zs'' (m/s^2) of each row [ms, ks, cs] of X, shape (n, samples): the exact response
        to the bump as a sum of the car's four modes. With state s = [zs, zu, zs', zu'],
        s' = A s + b y and a road step y = h from t0 on, zs'' = h e2 expm(A (t - t0)) b;
        the bump is a step up at 0 and down at t_off."""
        ms, ks, cs = np.atleast_2d(X).T
        mu, kt, n = self.config.mu, self.config.kt, ms.size
        A = np.zeros((n, 4, 4))
        A[:, 0, 2] = A[:, 1, 3] = 1.0
        A[:, 2] = np.stack([-ks, ks, -cs, cs], axis=1) / ms[:, None]
        A[:, 3] = np.stack([ks, -ks - kt, cs, -cs], axis=1) / mu
        lam, V = np.linalg.eig(A)  # modes: A = V diag(lam) V^-1
        b = np.linalg.solve(V, np.broadcast_to([0, 0, 0, kt / mu], (n, 4))[..., None])[..., 0]
        weight = self.config.bump_height * V[:, 2, :] * b  # each mode's share of zs''

        def step(t0: float) -> np.ndarray:  # modes excited by a road step at t0, (n, 4, T)
            since = self.t - t0
            return np.where(since >= 0, np.exp(lam[..., None] * np.maximum(since, 0)), 0)

        return np.einsum("nj,njk->nk", weight, step(0.0) - step(self.t_off)).real

    def residuals(self, X: np.ndarray) -> np.ndarray:
        return self.measured - self.responses(X)

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        f = np.linalg.norm(self.residuals(X), axis=1) / np.linalg.norm(self.measured)
        return np.where(np.isfinite(f), f, np.inf)

    def signals(self, x: np.ndarray) -> dict[str, np.ndarray]:
        return {"t": self.t, "zs'':measured": self.measured,
                "zs'':fitted": self.responses(x)[0]}

    def metrics(self, x: np.ndarray) -> dict[str, float]:
        errors = 100 * (np.asarray(x) / self._x_true - 1)  # percent, per parameter
        return {"NoRE": float(np.linalg.norm(errors)),
                "max_error_percent": float(np.abs(errors).max())}

    def describe(self) -> dict:
        return {"samples": int(self.t.size), "f_at_true": float(self.evaluate(self._x_true)[0])}

    def write_artifacts(self, directory: Path) -> list[Path]:
        path = Path(directory) / "reference.csv"
        np.savetxt(path, np.column_stack([self.t, self.measured]), delimiter=",",
                   header="t_s,zs_dd_m_s2", comments="")
        return [path]


@hookimpl
def vpid_bench_register_problems(register):
    register("quarter_car", QuarterCar)
