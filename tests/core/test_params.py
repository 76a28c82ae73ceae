"""Typed hyper-parameters: unknown keys and bad values fail when the object is built."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import pytest

from vpid_bench.api import ConfigError
from vpid_bench.params import build_dataclass, dataclass_defaults, hydra_node


@dataclass(frozen=True)
class Inner:
    level: float = 0.05
    model: Literal["mult", "add"] = "mult"
    seed: int | None = None


@dataclass(frozen=True)
class Outer:
    F: float = 0.6
    n: int = 3
    flag: bool = False
    inner: Inner = field(default_factory=Inner)


def test_defaults_round_trip():
    assert build_dataclass(Outer, dataclass_defaults(Outer)) == Outer()


def test_values_are_coerced_and_nested():
    got = build_dataclass(Outer, {"F": 1, "n": 4.0, "inner": {"level": 0.1, "seed": 3}})
    assert got == Outer(F=1.0, n=4, inner=Inner(level=0.1, seed=3))
    assert isinstance(got.F, float) and isinstance(got.n, int)


@pytest.mark.parametrize(
    "mapping, key, fragment",
    [
        ({"FF": 0.8}, "optimizer.FF", "known keys are F, flag, inner, n"),
        ({"F": "abc"}, "optimizer.F", "a real number"),
        ({"F": float("nan")}, "optimizer.F", "not NaN"),
        ({"n": 2.5}, "optimizer.n", "an integer"),
        ({"n": True}, "optimizer.n", "an integer"),
        ({"flag": "yes"}, "optimizer.flag", "true or false"),
        ({"inner": {"model": "mul"}}, "optimizer.inner.model", "one of 'mult', 'add'"),
        ({"inner": {"colour": 1}}, "optimizer.inner.colour", "known keys are level, model, seed"),
        ({"inner": 3}, "optimizer.inner", "mapping"),
    ],
)
def test_bad_values_name_the_key_and_what_is_allowed(mapping, key, fragment):
    with pytest.raises(ConfigError) as info:
        build_dataclass(Outer, mapping, prefix="optimizer")
    assert info.value.key == key
    assert fragment in str(info.value)
    assert str(info.value).startswith(f"{key}=")


def test_name_and_private_keys_are_metadata():
    assert build_dataclass(Outer, {"name": "x", "_target_": "y"}) == Outer()


def test_hydra_node_leaves_out_the_protocol_keys():
    @dataclass(frozen=True)
    class P:
        ps: int = 20
        F: float = 0.5

    assert hydra_node(P, "mine", exclude=("ps", "iterations")) == {"name": "mine", "F": 0.5}
    assert hydra_node(P, "mine") == {"name": "mine", "ps": 20, "F": 0.5}


def test_a_setting_added_later_is_left_out_at_its_default():
    """added_setting: at its default a key added to a config after runs were recorded is
    not in the job's settings (records, run ids, optimum keys and archives made before it
    stay valid); any other value is recorded."""
    import dataclasses

    from vpid_bench import ProblemConfig, added_setting
    from vpid_bench.params import settings_of, to_plain

    @dataclasses.dataclass(frozen=True)
    class Inner:
        file: str | None = None

    @dataclasses.dataclass(frozen=True)
    class Old(ProblemConfig):
        level: float = 0.05

    @dataclasses.dataclass(frozen=True)
    class New(Old):
        model: str = added_setting("linear")
        reference: Inner = added_setting(default_factory=Inner)

    assert settings_of(New()) == to_plain(Old())
    assert settings_of(New(model="bilinear"))["model"] == "bilinear"
    assert settings_of(New(reference=Inner("r.csv")))["reference"] == {"file": "r.csv"}
    assert "model" in to_plain(New())  # the full config is still all there
