"""Every one-line ``vpid-bench`` command in the README and docs/ passes the pre-flight: its
keys, values, problems, optimizers and suites exist (nothing runs). A renamed key or a removed
option shows up here instead of in a newcomer's terminal."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
COMMAND = re.compile(r"^(?:\.venv/bin/)?vpid-bench ([^#\\]*?)\s*(?:#.*)?$")
#: Commands shown on purpose as refused, or needing what a test run has not (a user's file,
#: the example third-party plugin installed on its own), or only printing help.
NOT_CHECKED = ("--help", "--resume", "my_record.csv", "my.csv", "model.fmu",
               "problem.noise=-1", "quarter_car", "one_plus_one")


def _commands() -> list[tuple[str, str]]:
    out = []
    for page in PAGES:
        for line in page.read_text(encoding="utf-8").splitlines():
            m = COMMAND.match(line.strip())
            if m is None or line.rstrip().endswith("\\") or " is a " in line:
                continue
            if any(word in line for word in NOT_CHECKED):
                continue
            out.append((page.name, m.group(1).strip()))
    first = {args: page for page, args in sorted(set(out), reverse=True)}  # one page each
    return sorted((page, args) for args, page in first.items())


@pytest.mark.parametrize("page, args", _commands())
def test_a_documented_command_passes_the_preflight(page, args, registry, tmp_path):
    from vpid_bench.shell.argv import parse_command_line
    from vpid_bench.shell.callbacks import ensure_job_dir_resolver
    from vpid_bench.shell.config_store import register_configs
    from vpid_bench.shell.preflight import plan
    from vpid_bench.shell.suites import expand_suites

    register_configs(registry)
    ensure_job_dir_resolver()
    argv = shlex.split(args)
    key = "hydra.sweep.dir" if "-m" in argv else "hydra.run.dir"
    argv = [a for a in argv if not a.startswith(key + "=")] + [f"{key}={tmp_path / 'out'}"]
    cmd = expand_suites(parse_command_line(argv), registry)
    assert plan(cmd, registry).jobs  # raises one ConfigError line if anything is off


def test_the_commands_are_found():
    found = [args for _, args in _commands()]
    assert len(found) >= 25
    assert any(a.startswith("-m suite=smoke") for a in found)
    assert any("problem.objective=ml" in a for a in found)


DESIGN = re.compile(r"^(?:\.venv/bin/)?vpid-bench-design ([^#\\]*?)\s*(?:#.*)?$")


def _design_commands() -> list[str]:
    return sorted({m.group(1).strip() for page in PAGES
                   for line in page.read_text(encoding="utf-8").splitlines()
                   if (m := DESIGN.match(line.strip())) is not None
                   and "<" not in line})


@pytest.mark.parametrize("args", _design_commands())
def test_a_documented_design_command_runs(args, capsys):
    from vpid_bench.design import main

    assert main(shlex.split(args)) == 0, capsys.readouterr().err
    assert "| design |" in capsys.readouterr().out
