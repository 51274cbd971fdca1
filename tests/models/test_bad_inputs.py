"""Bad matrices, arguments and model files: a moli error naming what is wrong."""

from __future__ import annotations

import copy
import json
import re

import numpy as np
import pytest

import moli
from moli import DataError, ModelFileError

A, B, C = np.array([[0.5]]), np.array([[1.0]]), np.array([[1.0]])


@pytest.mark.parametrize("kwargs, message", [
    ({"A": [["a"]]}, "A must be an array of real"),
    ({"A": [[0.5, 0.1], [0.2]]}, "A must be a rectangular array"),
    ({"A": [[np.nan]]}, "A must be a finite 2-D matrix"),
    ({"A": [[0.5j]]}, "A must be real"),
    ({"A": None}, "A must be an array of real"),
    ({"B": np.ones((2, 1))}, "B needs 1 rows"),
    ({"Ts": "1"}, "Ts must be a positive finite number"),
    ({"Ts": None}, "Ts must be a positive finite number"),
    ({"Ts": -1.0}, "Ts must be a positive finite number"),
    ({"Ts": float("nan")}, "Ts must be a positive finite number"),
    ({"output_names": 5}, "output_names must be a list of 1 names"),
    ({"output_names": "y"}, "output_names must be a list of 1 names"),
    ({"y_offset": [1.0, 2.0]}, "y_offset must have 1 entries"),
    ({"u_offset": [np.nan]}, "u_offset must be finite"),
    ({"indices": "a"}, "indices must be a list of positive integers"),
    ({"indices": [1.5]}, "indices must be an integer"),
    ({"alpha": [1.0, np.nan]}, "alpha must be finite"),
    ({"info": [1]}, "info must be a dict"),
])
def test_a_bad_model_argument_is_refused(kwargs, message):
    given = {"A": A, "B": B, "C": C, **kwargs}
    with pytest.raises(DataError, match=message):
        moli.StateSpaceModel(**given)


@pytest.mark.parametrize("call, message", [
    (lambda m: m.simulate(np.ones((10, 2))), r"u must be 1-D .* shape \(N, 1\)"),
    (lambda m: m.simulate(np.ones(10) * 1j), "u must be real"),
    (lambda m: m.simulate(np.ones(10), [np.nan]), "x0 must be finite"),
    (lambda m: m.simulate(np.ones(10), [1.0, 2.0]), "x0 must have 1 entries"),
    (lambda m: m.simulate(np.ones(10), "abc"), "x0 must be an array of real"),
    (lambda m: m.markov("a"), "count must be an integer"),
    (lambda m: m.markov(0), "count must be an integer of at least 1"),
    (lambda m: m.save(3), "path must be a str or Path"),
])
def test_bad_arguments_of_model_methods(call, message):
    with pytest.raises(DataError, match=message):
        call(moli.StateSpaceModel(A, B, C))


def test_an_empty_input_simulates_to_an_empty_output():
    assert moli.StateSpaceModel(A, B, C).simulate(np.zeros((0, 1))).shape == (0, 1)


def test_simulate_leaves_its_arguments_alone():
    u, x0 = np.arange(10.0), np.array([2.0])
    moli.StateSpaceModel(A, B, C).simulate(u, x0)
    assert np.array_equal(u, np.arange(10.0)) and np.array_equal(x0, [2.0])


@pytest.fixture(scope="module")
def saved() -> dict:
    return moli.example_plant().to_dict()


def _set(content: dict, key: str, value: object) -> dict:
    changed = copy.deepcopy(content)
    changed[key] = value
    return changed


def _drop(content: dict, key: str) -> dict:
    changed = copy.deepcopy(content)
    del changed[key]
    return changed


# each case: how to spoil the saved model -> what the error must say
FILES = {
    "string matrix": (lambda c: _set(c, "A", [["a"] * 6] * 6), "A must be an array of real"),
    "ragged matrix": (lambda c: _set(c, "A", [[0.1] * 6] * 5 + [[0.1] * 5]), "A must be a rectangular"),
    "null matrix": (lambda c: _set(c, "B", None), "B must be an array of real"),
    "offset of the wrong length": (lambda c: _set(c, "y_offset", [0.0, 1.0]), "y_offset must have 3 entries"),
    "names as a string": (lambda c: _set(c, "output_names", "y1y2y3"), "output_names must be a list of 3"),
    "names as a number": (lambda c: _set(c, "input_names", 3), "input_names must be a list of 3"),
    "Ts as text": (lambda c: _set(c, "Ts", "1"), "Ts must be a positive finite number"),
    "negative Ts": (lambda c: _set(c, "Ts", -1.0), "Ts must be a positive finite number"),
    "indices as text": (lambda c: _set(c, "indices", "ab"), "indices must be a list"),
    "info as a list": (lambda c: _set(c, "info", [1]), "info must be a dict"),
    "no A": (lambda c: _drop(c, "A"), "lacks the field 'A'"),
    "no Ts": (lambda c: _drop(c, "Ts"), "lacks the field 'Ts'"),
    "no output names": (lambda c: _drop(c, "output_names"), "lacks the field 'output_names'"),
    "no format": (lambda c: _drop(c, "format"), "not a moli model file"),
    "a list": (lambda c: [1, 2], "holds a JSON list"),
}


@pytest.mark.parametrize("case", sorted(FILES))
def test_a_spoiled_model_file_is_a_model_file_error(case, saved, tmp_path):
    spoil, message = FILES[case]
    path = tmp_path / "model.json"
    path.write_text(json.dumps(spoil(saved)))
    with pytest.raises(ModelFileError, match=message):
        moli.load_model(path)


@pytest.fixture(scope="module")
def saved_continuous() -> dict:
    return moli.example_plant().to_continuous().to_dict()


# spoiled fields that both kinds of model file hold -> what the error must name
SHARED = {
    "offset of the wrong length": ("y_offset", [0.0], "y_offset must have 3 entries"),
    "NaN offset": ("u_offset", [0.0, float("nan"), 0.0], "u_offset must be finite"),
    "infinite offset": ("y_offset", [float("inf"), 0.0, 0.0], "y_offset must be finite"),
    "names as one string": ("output_names", "abc", "output_names must be a list of 3 names (distinct strings)"),
    "duplicate names": ("input_names", ["u1", "u1", "u2"], "input_names must be distinct"),
    "numbers as names": ("output_names", [1, 2, 3], "output_names must be a list of 3 names (distinct strings)"),
    "names in a dict": ("input_names", {"u1": 1, "u2": 2, "u3": 3}, "input_names must be a list of 3"),
}
DELAYS = {
    "infinite delay": ([0.0, float("inf"), 0.0], "input_delays must be finite and non-negative"),
    "NaN delay": ([float("nan"), 0.0, 0.0], "input_delays must be finite and non-negative"),
    "negative delay": ([0.0, 0.0, -0.5], "input_delays must be finite and non-negative"),
    "delays of the wrong length": ([0.0, 1.0], "input_delays must have 3 entries"),
    "delays as text": ("0.5", "input_delays must be an array of real"),
}


@pytest.mark.parametrize("kind", ["discrete", "continuous"])
@pytest.mark.parametrize("case", sorted(SHARED))
def test_either_kind_of_model_file_names_the_spoiled_field_and_the_file(case, kind, saved, saved_continuous,
                                                                        tmp_path):
    key, value, message = SHARED[case]
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_set(saved if kind == "discrete" else saved_continuous, key, value)))
    with pytest.raises(ModelFileError, match=re.escape(f"{path}: ") + ".*" + re.escape(message)):
        moli.load_model(path)


@pytest.mark.parametrize("case", sorted(DELAYS))
def test_a_continuous_model_file_refuses_delays_that_are_no_dead_times(case, saved_continuous, tmp_path):
    value, message = DELAYS[case]
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_set(saved_continuous, "input_delays", value)))
    with pytest.raises(ModelFileError, match=re.escape(f"{path}: ") + ".*" + re.escape(message)):
        moli.load_model(path)


def test_a_discrete_model_file_refuses_delays_that_are_not_whole_samples(saved, tmp_path):
    for value in ([0, 1.5, 0], [0, -1, 0], [0, float("inf"), 0]):
        path = tmp_path / "model.json"
        path.write_text(json.dumps(_set(saved, "input_delays", value)))
        with pytest.raises(ModelFileError, match="input_delays must be"):
            moli.load_model(path)


def test_the_checked_continuous_model_file_reads_back_what_was_saved(saved_continuous, tmp_path):
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_set(saved_continuous, "input_delays", [0.0, 0.25, 2.0])))
    model = moli.load_model(path)
    assert model.input_delays == (0.0, 0.25, 2.0) and model.output_names == ("y1", "y2", "y3")
    np.testing.assert_array_equal(model.y_offset, saved_continuous["y_offset"])


@pytest.mark.parametrize("text, message", [
    (lambda t: t[: len(t) // 2], "is not a JSON model file"),
    (lambda t: "", "is not a JSON model file"),
    (lambda t: t.replace('"Ts": 1.0', '"Ts": NaN'), "Ts must be a positive finite number"),
])
def test_truncated_or_odd_json_is_a_model_file_error(text, message, saved, tmp_path):
    path = tmp_path / "model.json"
    path.write_text(text(json.dumps(saved)))
    with pytest.raises(ModelFileError, match=message):
        moli.load_model(path)


def test_a_folder_or_a_number_is_not_a_model_file(tmp_path):
    with pytest.raises(ModelFileError, match="cannot read the model file"):
        moli.load_model(tmp_path)
    with pytest.raises(ModelFileError, match="path must be a str or Path"):
        moli.load_model(3)  # type: ignore[arg-type]
