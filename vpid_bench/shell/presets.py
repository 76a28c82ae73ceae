"""YAML presets shipped in ``conf/<group>/``: each extends a registered plugin."""

from __future__ import annotations

import importlib.resources

from omegaconf import OmegaConf


def yaml_presets(group: str) -> dict[str, str]:
    """Presets shipped as ``conf/<group>/<name>.yaml``, each mapped to the registered plugin
    name it extends (the first entry of its defaults list, followed through other presets)."""
    folder = importlib.resources.files("vpid_bench.conf").joinpath(group)
    if not folder.is_dir():
        return {}
    parent: dict[str, str | None] = {}
    for entry in folder.iterdir():
        if entry.name.endswith(".yaml"):
            node = OmegaConf.create(entry.read_text())
            bases = [d for d in node.get("defaults", []) if isinstance(d, str) and d != "_self_"]
            parent[entry.name[: -len(".yaml")]] = bases[0] if bases else None
    out: dict[str, str] = {}
    for name in parent:
        current, seen = name, set()
        while current in parent and current not in seen and parent[current] is not None:
            seen.add(current)
            current = parent[current]
        if current is not None and current not in parent:
            out[name] = current
    return out

