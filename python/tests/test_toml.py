"""The manifest TOML writer reads back as the dict it was given."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from rwg import _toml

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib


def test_manifest_shapes_round_trip():
    doc = {
        "seed": 2**62,
        "samples": 300,
        "bias": [False, True],
        "note": 'quotes " and \\ and \n newline, tab\t, bell \x07, é',
        "weights": {"distribution": "normal", "scale": 0.1},
        "architectures": [{"name": "0HL", "hidden": []}, {"name": "2 HL", "hidden": [4, 4]}],
        "envs": [
            {"id": "gymnasium:LunarLander-v3", "kwargs": {"continuous": True, "gravity": -9.5}},
            {"id": "classic_control/CartPole-v1", "solved": 475.0, "config": {"a": {"b": [1, 2]}}},
        ],
        "x.y": {"deep": [{"k": 1}, {"k": 2, "t": {"u": "v"}}]},
        "floats": [0.1, 1e300, -0.0, 5e-324],
        "mixed": [{"inline": 1}, 2],
    }
    assert tomllib.loads(_toml.dumps(doc)) == doc


def test_special_values_and_numpy_and_paths():
    text = _toml.dumps({"a": float("inf"), "b": -math.inf, "c": np.int64(3), "d": np.float64(0.5),
                        "e": np.array([1, 2]), "f": Path("x/y.so"), "g": True})
    back = tomllib.loads(text)
    assert back["a"] == math.inf and back["b"] == -math.inf
    assert back["c"] == 3 and back["d"] == 0.5 and back["e"] == [1, 2]
    assert back["f"] == "x/y.so" and back["g"] is True
    assert math.isnan(tomllib.loads(_toml.dumps({"n": float("nan")}))["n"])


def test_what_toml_cannot_hold_is_refused_naming_its_key():
    with pytest.raises(TypeError, match=r"manifest key envs.solved: cannot write a NoneType"):
        _toml.dumps({"envs": [{"id": "x", "solved": None}]})
    with pytest.raises(TypeError, match="keys must be strings"):
        _toml.dumps({1: 2})
    with pytest.raises(TypeError, match="must be a dict"):
        _toml.dumps([1])
