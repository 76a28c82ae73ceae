"""The third-party records (GPL-3.0, a separate data distribution): checksums, a user's folder
in their place, and the constants our code states against the shipped YAML files."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
import yaml
from vpid_vehicle.ride import bayesrace, racecar, third_party

from vpid_bench import ConfigError, file_sha256

#: A folder holding upstream copies (``bayesrace/`` and ``racecar/``), when one is named.
UPSTREAM = Path(os.environ.get("VPID_MEASURED_DATA", "/nonexistent"))


@pytest.fixture(scope="module")
def installed() -> Path:
    folder = third_party.installed_folder()
    assert folder is not None, "make install installs records-gpl/ (vpid-records-gpl)"
    return folder


def test_the_installed_records_have_their_published_checksums(installed):
    for name, expected in third_party.SHA256.items():
        path = third_party.verified(name, None)
        assert path.parent == installed and file_sha256(path) == expected
    assert (installed / "LICENSE").read_text().lstrip().startswith("GNU GENERAL PUBLIC LICENSE")


def test_a_users_folder_with_the_same_files_is_read(tmp_path, installed):
    name = "DYN-PP-ETHZ.npz"
    shutil.copy(installed / name, tmp_path)
    assert third_party.verified(name, str(tmp_path)) == tmp_path / name


def test_an_altered_file_is_one_error_naming_it_and_the_checksum(tmp_path, installed):
    name = "LVMS_23_01_04_B.csv"
    data = bytearray((installed / name).read_bytes())
    data[100] ^= 1
    (tmp_path / name).write_bytes(bytes(data))
    with pytest.raises(ConfigError) as err:
        third_party.verified(name, str(tmp_path))
    text = str(err.value)
    assert text.startswith("problem.data_dir=") and "\n" not in text
    assert name in text and third_party.SHA256[name] in text


def test_a_folder_without_the_file_says_which_and_its_checksum(tmp_path):
    with pytest.raises(ConfigError, match="Putnam_park2023_run4_2.csv.*" +
                       third_party.SHA256["Putnam_park2023_run4_2.csv"]):
        third_party.verified("Putnam_park2023_run4_2.csv", str(tmp_path))


def test_a_missing_data_folder_refuses_the_config_at_the_preflight(tmp_path):
    with pytest.raises(ConfigError, match="problem.data_dir"):
        bayesrace.BayesraceConfig(data_dir=str(tmp_path))
    with pytest.raises(ConfigError, match="problem.data_dir"):
        racecar.RacecarConfig(data_dir=str(tmp_path))


@pytest.mark.skipif(not (UPSTREAM / "bayesrace").is_dir(), reason="no folder of upstream "
                    "copies named (set VPID_MEASURED_DATA to a folder holding bayesrace/ and "
                    "racecar/ with the published files)")
def test_the_upstream_copies_verify_as_a_users_folder():
    for sub, names in (("bayesrace", bayesrace.TRACKS.values()),
                       ("racecar", racecar.LOGS.values())):
        for name in names:
            assert third_party.verified(name, str(UPSTREAM / sub)).is_file()


def _specs(doc: dict) -> dict[str, float]:
    """VEHICLE_SPECS with ``mass`` named ``m`` as our models name it."""
    return {("m" if k == "mass" else k): float(v) for k, v in doc["VEHICLE_SPECS"].items()}


def test_the_simulators_coefficients_are_those_of_the_shipped_yaml(installed):
    doc = yaml.safe_load((installed / "deep_dynamics.yaml").read_text())
    params = {k: v for p in doc["PARAMETERS"] for k, v in p.items() if k not in ("Min", "Max")}
    ranges = {next(iter(p)): (p["Min"], p["Max"]) for p in doc["PARAMETERS"]}
    assert set(params) == set(bayesrace.SIMULATOR)
    for k, (value, low, high) in bayesrace.SIMULATOR.items():
        assert (float(params[k]), *map(float, ranges[k])) == (value, low, high), k
    assert _specs(doc) == bayesrace.VEHICLE


def test_the_racecars_constants_and_ranges_are_those_of_the_shipped_yaml(installed):
    doc = yaml.safe_load((installed / "deep_dynamics_iac.yaml").read_text())
    assert _specs(doc) == racecar.VEHICLE
    ranges = {next(iter(p)): (float(p["Min"]), float(p["Max"])) for p in doc["PARAMETERS"]}
    names, _, lower, upper = racecar.TYRES["magic_formula"]
    for k, lo, hi in zip(names, lower, upper, strict=True):
        assert ranges[k] == (lo, hi), k
