"""Progress lines of long commands, one home: a duration in words (:func:`duration`) and the
stages of a long build with counts, time spent and the time left (:class:`Stages`). A sweep's
own line (jobs and runs) is the shell's :class:`~vpid_bench.shell.progress.SweepProgress`,
built on :func:`duration`; the report over an archive uses :class:`Stages`.

Lines go to standard error, so the first screen on standard output stays the answer."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import TextIO


def duration(seconds: float) -> str:
    """``"45 s"``, ``"3 min 05 s"``, ``"1 h 02 min"``."""
    s = max(0, round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


class Stages:
    """One line as each stage of ``what`` starts (``report: figures (87), 21 s elapsed``),
    and within a counted stage a line at most every ``every_s`` seconds with the count and
    the time left at the stage's pace so far (``report: figures 40/87, 33 s elapsed, about
    14 s left``)."""

    def __init__(self, what: str, stream: TextIO | None = None,
                 clock: Callable[[], float] = time.monotonic, every_s: float = 5.0) -> None:
        self.what, self.stream, self.clock, self.every_s = what, stream, clock, every_s
        self.start = clock()
        self.name, self.total = "", 0
        self.stage_start = self.last = self.start

    def _say(self, text: str) -> str:
        line = f"{self.what}: {text}, {duration(self.clock() - self.start)} elapsed"
        print(line, file=self.stream or sys.stderr, flush=True)
        return line

    def stage(self, name: str, total: int = 0) -> str:
        """Start the stage ``name`` (``total``: how many steps it counts, 0: none)."""
        self.name, self.total = name, total
        self.stage_start = self.last = self.clock()
        return self._say(f"{name} ({total})" if total else name)

    def left_s(self, done: int) -> float:
        """Seconds left in the counted stage at its pace so far (NaN before a step)."""
        if done <= 0 or not self.total:
            return math.nan
        return (self.clock() - self.stage_start) / done * max(0, self.total - done)

    def step(self, done: int) -> str | None:
        """``done`` steps of the stage are over: a line when ``every_s`` has passed since the
        last one (or at the last step), else ``None``."""
        now = self.clock()
        if done < self.total and now - self.last < self.every_s:
            return None
        self.last = now
        left = self.left_s(done)
        early = done < max(3, self.total // 10)  # a pace from one step says little
        eta = "" if math.isnan(left) or early or done >= self.total else \
            f", about {duration(left)} left"
        return self._say(f"{self.name} {done}/{self.total}{eta}")
