"""How fast ``vpid-bench`` answers: ``--help``, ``--version`` and one-line refusals (issue 46).

Each command's median wall and CPU time (s) over ``--repeat`` fresh processes, beside
``python -c pass`` and a minimal ``@hydra.main`` app's ``--help`` (the goal: ``--help`` and a
refusal within 1.5x the latter; README.md, a command that answers at once).

    .venv/bin/python benchmarks/bench_latency.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

from _shared import run_timed

MINIMAL_APP = '''import hydra


@hydra.main(version_base="1.3", config_path=None)
def app(cfg):
    pass


if __name__ == "__main__":
    app()
'''


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    bench = str(Path(sys.executable).with_name("vpid-bench"))
    with tempfile.TemporaryDirectory() as tmp:
        app = Path(tmp, "minimal_hydra_app.py")
        app.write_text(MINIMAL_APP)
        commands = {
            "python -c pass": [sys.executable, "-c", "pass"],
            "minimal @hydra.main app --help": [sys.executable, str(app), "--help"],
            "vpid-bench --help": [bench, "--help"],
            "vpid-bench --version": [bench, "--version"],
            "vpid-bench optimizer=de44 (refused)": [bench, "optimizer=de44"],
            "vpid-bench runz=3 (refused)": [bench, "runz=3"],
        }
        rows = {}
        for name, cmd in commands.items():
            times = [run_timed(cmd, check=False) for _ in range(args.repeat)]  # refusals exit 2
            rows[name] = (statistics.median(t[0] for t in times),
                          statistics.median(t[1] for t in times))
    hydra_wall, hydra_cpu = rows["minimal @hydra.main app --help"]
    print(f"median of {args.repeat} runs each; ratio: to the minimal Hydra app's --help")
    print(f"{'command':40s} {'wall s':>7s} {'cpu s':>7s} {'wall x':>7s} {'cpu x':>7s}")
    for name, (wall, cpu) in rows.items():
        print(f"{name:40s} {wall:7.2f} {cpu:7.2f} {wall / hydra_wall:7.2f} "
              f"{cpu / hydra_cpu:7.2f}")


if __name__ == "__main__":
    main()
