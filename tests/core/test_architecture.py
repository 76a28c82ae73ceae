"""The rooms of the house and what each may import (docs/architecture.md), checked on the
source: the core knows no problem, the shell is the only room that knows Hydra, the report
knows nothing of the shell, plugins use the public API only."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]
CORE = ROOT / "vpid_bench"
PLUGINS = ROOT / "plugins"
#: What a plugin may import from vpid-bench: the API and the report-section helpers.
PLUGIN_API = ("vpid_bench", "vpid_bench.api", "vpid_bench.hookspecs", "vpid_bench.report.sections",
              "vpid_bench.artifacts")


def _imports(path: Path) -> set[str]:
    """Every module a file imports (absolute, relative imports resolved)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = ".".join(path.relative_to(path.parents[len(path.relative_to(ROOT).parts) - 1])
                       .with_suffix("").parts[:-1])
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module or ""
            out.add(module)
    return out


def _files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*.py") if "__pycache__" not in p.parts)


def test_the_core_names_no_problem_outside_the_hook_docs():
    """No word 'vehicle', 'paper' or 'NoRE' in vpid_bench/ but in the report hook's docstring
    (whole words: 'ignore' and 'NoRecordsError' are not meant)."""
    word = re.compile(r"\b(vehicles?|paper|nore)\b", re.IGNORECASE)
    hits = [f"{p.relative_to(ROOT)}:{i}" for p in CORE.rglob("*") if p.is_file()
            and p.suffix in (".py", ".yaml", ".csv") and "__pycache__" not in p.parts
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
            if word.search(line)]
    assert hits == ["vpid_bench/hookspecs.py:48"], hits


def test_the_import_reader_sees_relative_and_absolute_imports():
    """A control: the checks below would see a forbidden import."""
    seen = _imports(CORE / "shell" / "callbacks.py")
    assert "vpid_bench.report.build" in seen and "hydra.experimental.callback" in seen


def test_only_the_shell_imports_hydra():
    bad = [str(p.relative_to(ROOT)) for p in _files(CORE)
           if "shell" not in p.relative_to(CORE).parts
           and any(m == "hydra" or m.startswith("hydra.") for m in _imports(p))]
    assert bad == []


def test_the_report_imports_nothing_from_the_shell():
    bad = [str(p.relative_to(ROOT)) for p in _files(CORE / "report")
           if any(m.startswith("vpid_bench.shell") for m in _imports(p))]
    assert bad == []


@pytest.mark.parametrize("plugin", sorted(p.name for p in PLUGINS.iterdir() if p.is_dir()
                                          and not p.name.startswith((".", "_"))))
def test_plugins_use_only_the_public_api(plugin):
    bad = {m for p in _files(PLUGINS / plugin) for m in _imports(p)
           if m.startswith("vpid_bench") and m not in PLUGIN_API}
    assert bad == set()
