"""Helpers shared by the vehicle tests."""

from __future__ import annotations

from vpid_vehicle.config import VehicleConfig
from vpid_vehicle.problem import VehicleProblem

from vpid_bench.params import build_dataclass


def make(**overrides) -> VehicleProblem:
    """A problem from dotted overrides, e.g. make(**{"noise.level": 0.0})."""
    tree: dict = {}
    for key, value in overrides.items():
        node = tree
        *parents, leaf = key.split(".")
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = value
    return VehicleProblem(build_dataclass(VehicleConfig, tree, prefix="problem"))
