"""Fixtures of the peers tests: the paper's vehicle, built once per session."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def vehicle():
    from vpid_vehicle.config import VehicleConfig
    from vpid_vehicle.problem import VehicleProblem

    return VehicleProblem(VehicleConfig())
