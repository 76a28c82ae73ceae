"""Every script the docs name (``benchmarks/<name>.py``, ``tools/<name>.py``) exists and has
each ``--option`` its documented command passes, and every script in those folders is named
somewhere in the docs: a renamed, folded or deleted script, or one nobody documents, shows up
here instead of in a reader's terminal (issue 45: one documented command for each table)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", ROOT / "Makefile", ROOT / "tools" / "README.md",
         ROOT / "benchmarks" / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SCRIPT = re.compile(r"\b((?:benchmarks|tools)/[A-Za-z_0-9]+\.(?:py|c))\b")
OPTION = re.compile(r"(?<![\w-])(--[a-z][a-z0-9-]*)")


def _commands() -> list[tuple[str, str, str]]:
    """``(page, script, the rest of its line)`` for every line of the docs naming a script,
    with a command's continuation lines (ending in ``\\``) joined."""
    out = []
    for page in PAGES:
        text = re.sub(r"\\\n\s*", " ", page.read_text(encoding="utf-8"))
        for line in text.splitlines():
            for m in SCRIPT.finditer(line):
                rest = line[m.end():].split("`")[0].split("|")[0].split("#")[0]
                out.append((page.name, m.group(1), rest))
    return out


@pytest.mark.parametrize("page, script, rest", _commands(),
                         ids=lambda v: v if isinstance(v, str) and "/" in v else None)
def test_a_named_script_exists_with_its_options(page, script, rest):
    path = ROOT / script
    assert path.is_file(), f"{page} names {script}, which does not exist"
    if " -- " in f" {rest} ":  # what follows -- goes to vpid-bench, not to the script
        rest = f" {rest} ".split(" -- ")[0]
    source = path.read_text(encoding="utf-8")
    for module in re.findall(r"^from (\w+) import", source, re.M):  # a sibling's options
        if (path.parent / f"{module}.py").is_file():
            source += (path.parent / f"{module}.py").read_text(encoding="utf-8")
    missing = [o for o in OPTION.findall(rest) if o != "--help" and f'"{o}"' not in source]
    assert not missing, f"{page}: {script} has no option {', '.join(missing)}"


def test_every_script_is_documented():
    named = {script for _, script, _ in _commands()}
    scripts = {f"{p.parent.name}/{p.name}" for folder in ("benchmarks", "tools")
               for p in (ROOT / folder).glob("*.py") if not p.name.startswith("_")}
    assert scripts - named == set()
    assert len(named) >= 20  # the pattern finds the commands at all
