"""Bad arguments to the data layer: a moli error naming the argument, before any work.

NaN in a record's ``y``/``u`` is not covered here: it marks missing samples. inf is
never a measurement.
"""

from __future__ import annotations

import numpy as np
import pytest

import moli
from moli import DataError

RNG = np.random.default_rng(0)
Y, U = RNG.standard_normal((50, 2)), RNG.standard_normal((50, 1))


@pytest.mark.parametrize("y, u, message", [
    (np.zeros((0, 2)), np.zeros((0, 1)), "no samples"),
    (np.zeros((50, 0)), U, "at least one channel"),
    (Y, np.zeros((50, 0)), "at least one channel"),
    (Y * 1j, U, "y must be real"),
    (Y, U.astype(complex), "u must be real"),
    (Y, [[1.0], [2.0, 3.0]], "u must be a rectangular array"),
    ("abc", U, "y must be an array of real"),
    (None, U, "y must be an array of real"),
    (np.where(np.arange(50)[:, None] == 7, np.inf, Y), U, "inf"),
])
def test_a_bad_record_is_refused(y, u, message):
    with pytest.raises(DataError, match=message):
        moli.IOData(y, u)


@pytest.mark.parametrize("Ts", ["1", None, -1.0, 0.0, float("nan"), float("inf"), True, [1.0], 1j])
def test_a_bad_sampling_period_is_refused(Ts):
    with pytest.raises(DataError, match="Ts must be a positive finite number"):
        moli.IOData(Y, U, Ts)


@pytest.mark.parametrize("names, message", [
    ("ab", "output_names must be a list of 2 names"),  # a string is not split into letters
    (5, "output_names must be a list of 2 names"),
    (["a"], "output_names has 1 names for 2 channels"),
    (["a", "a"], "output_names must be distinct"),
])
def test_bad_channel_names_are_refused(names, message):
    with pytest.raises(DataError, match=message):
        moli.IOData(Y, U, 1.0, names)


def test_one_sample_is_a_record_but_not_enough_to_identify():
    one = moli.IOData(Y[:1], U[:1])
    assert one.N == 1
    with pytest.raises(DataError):
        moli.identify(one, nmax=2)


@pytest.mark.parametrize("call, message", [
    (lambda d: d.split("half"), "split point must be"),
    (lambda d: d.split(float("nan")), "split point must be"),
    (lambda d: d[3], "indexed by a slice"),
    (lambda d: d.remove_means(np.ones(3)), r"y_offset must have shape \(2,\)"),
    (lambda d: d.remove_means(np.full(2, np.nan)), "y_offset must be finite"),
    (lambda d: d.remove_means("a"), "y_offset must be an array of real"),
    (lambda d: moli.check_data(d, "3"), "nmax must be an integer"),
    (lambda d: moli.check_data(d, 0), "nmax must be an integer of at least 1"),
    (lambda d: moli.check_data(d, float("nan")), "nmax must be an integer"),
    (lambda d: moli.check_data(d.y), "data must be an IOData"),
    (lambda d: moli.to_dataframe(d.y), "data must be an IOData"),
    (lambda d: moli.read_data(5), "path must be a str or Path"),
    (lambda d: moli.from_dataframe(d.y, ["u1"], ["y1"]), "frame must be a pandas DataFrame"),
])
def test_bad_arguments_of_record_functions(call, message):
    with pytest.raises(DataError, match=message):
        call(moli.IOData(Y, U))


def test_nothing_the_caller_passed_is_changed():
    y, u = Y.copy(), U.copy()
    data = moli.IOData(y, u)
    data.remove_means()
    moli.check_data(data, 3)
    assert np.array_equal(y, Y) and np.array_equal(u, U)


@pytest.mark.parametrize("Ts", [0.5, np.float32(0.5), np.array(0.5), 1])
def test_a_number_of_any_numeric_type_is_a_sampling_period(Ts):
    assert moli.IOData(Y, U, Ts).Ts == float(Ts)
