"""The ``vpid-bench`` console command's first module, outside the package on purpose.

Importing ``vpid_bench`` takes about 0.15 s (numpy); a Ctrl-C in that time was Python's own
``KeyboardInterrupt`` traceback. From this module's first line a Ctrl-C is only noted, handed
to :mod:`vpid_bench.interrupts` once it is imported, and raised by the command when its
start-up is over: one ``interrupted:`` line and status 130, whenever it comes. SIGTERM and
SIGHUP likewise (status 143 and 129).
"""

from __future__ import annotations

import signal


def main() -> None:
    """The console entry point ``vpid-bench``."""
    noted: list[int] = []
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), lambda signum, frame: noted.append(signum))
    from vpid_bench import interrupts
    from vpid_bench.shell.main import main as command

    interrupts.defer()  # from here on the command's own noting handler
    if noted:
        interrupts.note(noted[0])
    command()
