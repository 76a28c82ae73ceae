"""Plugins that start processes, close their pipe, or crash in problem code the sweep once ran
in its own process (issue 35, failures 1-5 and 18), for ``test_worker_processes.py``. Module
level, so worker processes import them by name; registered by :func:`register` through the
``vpid_bench`` entry point the tests plant (a third party's plugin, as installed).

Every process these plugins start writes a file ``<kind>-<pid>`` holding its start time
(``time.time()``) into the folder named by the environment variable :data:`PIDS_ENV`, so a
test can check that none outlives the sweep and that the sweep did not wait for them."""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from vpid_bench import Bounds, Optimizer, OptimizerParams, Problem, ProblemConfig, hookimpl

PIDS_ENV = "VPID_TEST_PIDS"
#: How long a child these plugins leave behind lives (s).
CHILD_S = 40.0


def note(kind: str) -> None:
    """Say that this process started (see module)."""
    folder = os.environ.get(PIDS_ENV)
    if folder:
        tmp = Path(folder, f".{kind}-{os.getpid()}")
        tmp.write_text(repr(time.time()))
        tmp.replace(Path(folder, f"{kind}-{os.getpid()}"))


def fork_noted(kind: str, child: Callable[[], None] | None = None) -> bool:
    """Fork; the child notes itself (the parent waits for that, so a test finds every child)
    and then runs ``child`` if given (which should not return). True in the child."""
    read, write = os.pipe()
    if os.fork() == 0:
        os.close(read)
        note(kind)
        os.write(write, b"x")
        os.close(write)
        if child is not None:
            child()
        return True
    os.close(write)
    os.read(read, 1)
    os.close(read)
    return False


def linger() -> None:
    """In a child: keep what it inherited (the worker's pipe, its streams) for
    :data:`CHILD_S` seconds, then end."""
    time.sleep(CHILD_S)
    os._exit(0)


def daemon(kind: str) -> None:
    """Start a daemon as the textbook does (fork, a session of its own, fork again), which
    keeps the standard output and error it inherited."""
    def middle() -> None:
        os.setsid()
        fork_noted(kind, linger)
        os._exit(0)

    pid = os.fork()
    if pid == 0:
        middle()
    os.waitpid(pid, 0)


def no_core_file() -> None:
    import resource

    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def segfault() -> None:
    import ctypes

    no_core_file()
    ctypes.string_at(0)  # reads address 0: SIGSEGV


_done: set[str] = set()


def once(what: str) -> bool:
    """True the first time in this process (and its forked copies) that ``what`` is asked."""
    if what in _done:
        return False
    _done.add(what)
    return True


class Base(Optimizer):
    Params = OptimizerParams

    def ask(self) -> np.ndarray:
        return self.bounds.sample(self.rng, self.params.ps)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        pass


class ForkExit(Base):
    """Failure 1: forks in ask(); the child lives on with the worker's pipe, the worker exits."""

    def ask(self) -> np.ndarray:
        fork_noted("forkexit", linger)
        os._exit(3)


class Orphan(Base):
    """Failure 2: leaves a daemon holding the command's stdout and stderr (once a worker)."""

    def ask(self) -> np.ndarray:
        if once("orphan"):
            daemon("orphan")
        return super().ask()


class ForkBoth(Base):
    """Failure 3: forks once in ask() and both copies go on with the run."""

    def ask(self) -> np.ndarray:
        if once("forkboth"):
            fork_noted("forkboth")
        return super().ask()


class ClosePipe(Base):
    """Failure 4: closes every file descriptor above the standard ones (its pipe to the sweep
    among them), as code that daemonises itself does."""

    def ask(self) -> np.ndarray:
        os.closerange(3, 65536)
        return super().ask()


class SlowBuild(Base):
    """Failure 18: a constructor slower than any run may be, so every run times out."""

    def __init__(self, *args, **kwargs) -> None:
        time.sleep(30)
        super().__init__(*args, **kwargs)


class Crashy(Problem):
    """Failure 5: sum(x^2) over [-1, 1]^3 with residuals x and a known truth; segfaults in the
    problem method named by ``fault_at`` (``metrics``, ``describe``, ``polish``: its residual
    groups, asked by the optimum polish after the runs; ``signals``), as C code does."""

    @dataclasses.dataclass(frozen=True)
    class Config(ProblemConfig):
        fault_at: str = "none"

    rows_independent = True

    def _maybe(self, place: str) -> None:
        if self.config.fault_at == place:
            segfault()

    @property
    def bounds(self) -> Bounds:
        return Bounds(-np.ones(3), np.ones(3), ("a", "b", "c"))

    @property
    def x_true(self) -> np.ndarray:
        return np.full(3, 0.5)

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        return np.sum(np.asarray(X, dtype=float) ** 2, axis=1)

    def residuals(self, X: np.ndarray) -> np.ndarray:
        return np.asarray(X, dtype=float)

    def residual_groups(self) -> np.ndarray:
        self._maybe("polish")
        return np.zeros(3, dtype=int)

    def metrics(self, x: np.ndarray) -> dict[str, float]:
        self._maybe("metrics")
        return {"error": float(np.linalg.norm(np.asarray(x) - self.x_true))}

    def describe(self) -> dict[str, object]:
        self._maybe("describe")
        return {"f_at_true": 0.75}

    def signals(self, x: np.ndarray) -> dict[str, np.ndarray]:
        self._maybe("signals")
        t = np.linspace(0.0, 1.0, 5)
        return {"t": t, "y:measured": t, "y:fitted": t * float(np.sum(x))}


OPTIMIZERS = (ForkExit, Orphan, ForkBoth, ClosePipe, SlowBuild)


def left_running(folder: Path, grace: float = 5.0) -> list[int]:
    """For a test: the processes noted in ``folder`` (see module) still running ``grace``
    seconds from now at the latest; each is then killed, so a failing test leaves none."""
    import contextlib

    import psutil

    def alive(pid: int) -> bool:
        try:
            return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
        except psutil.Error:
            return False

    noted = [int(p.name.rsplit("-", 1)[1]) for p in folder.glob("*-*")]
    end = time.monotonic() + grace
    while any(alive(pid) for pid in noted) and time.monotonic() < end:
        time.sleep(0.2)
    left = [pid for pid in noted if alive(pid)]
    for pid in left:
        with contextlib.suppress(psutil.Error):
            psutil.Process(pid).kill()
    return left


@hookimpl
def vpid_bench_register_optimizers(register):
    for cls in OPTIMIZERS:
        register(cls.__name__.lower(), cls)


@hookimpl
def vpid_bench_register_problems(register):
    register("crashy", Crashy)
