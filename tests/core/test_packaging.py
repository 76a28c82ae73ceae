"""Every package folder ships: the wheel's package list in pyproject.toml names each folder
with an ``__init__.py`` under vpid_bench/, plugins/ and conf/ (a forgotten one would install
in editable mode and be missing from a wheel)."""

from __future__ import annotations

from pathlib import Path

import tomllib

ROOT = Path(__file__).parents[2]


def _declared() -> tuple[set[str], dict[str, str]]:
    tool = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    return set(tool["packages"]), tool.get("package-dir", {})


def _package_name(folder: Path, package_dir: dict[str, str]) -> str:
    rel = folder.relative_to(ROOT).as_posix()
    for name, path in sorted(package_dir.items(), key=lambda kv: -len(kv[1])):
        if rel == path or rel.startswith(path + "/"):
            return name + rel[len(path):].replace("/", ".")
    return rel.replace("/", ".")


def test_every_package_folder_is_declared():
    packages, package_dir = _declared()
    found = {_package_name(init.parent, package_dir)
             for base in ("vpid_bench", "plugins", "conf", "archive")
             for init in (ROOT / base).rglob("__init__.py") if "__pycache__" not in init.parts}
    # Folders of YAML presets under conf/ ship as data packages too.
    found |= {_package_name(y.parent, package_dir) for y in (ROOT / "conf").rglob("*.yaml")}
    assert found - packages == set(), "add these to [tool.setuptools] packages"
    assert packages - found == set(), "declared but missing"


def test_every_first_party_plugin_has_an_entry_point():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    targets = {v.split(".")[0] for v in meta["entry-points"]["vpid_bench"].values()}
    plugins = {p.name for p in (ROOT / "plugins").iterdir() if (p / "__init__.py").is_file()}
    assert plugins == targets
