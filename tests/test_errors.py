"""Wrong types raise a moli error that is also a TypeError; wrong values do not."""

import pickle

import numpy as np
import pytest

import moli
from moli.errors import DataError, OptionError, wrong_type

Y, U = np.zeros((20, 1)), np.ones((20, 1))


@pytest.mark.parametrize("make, error", [
    (lambda: moli.IdentifyOptions(nmax="8"), OptionError),
    (lambda: moli.IdentifyOptions(order_tolerance=[1.0]), OptionError),
    (lambda: moli.IdentifyOptions(center="yes"), OptionError),
    (lambda: moli.IOData(Y, U, Ts="0.5"), DataError),
    (lambda: moli.IOData(Y, U, Ts=None), DataError),
    (lambda: moli.IOData("y", U), DataError),
    (lambda: moli.IOData(Y, U, output_names=5), DataError),
], ids=["nmax text", "tolerance list", "flag text", "Ts text", "Ts None", "y text", "names int"])
def test_a_wrong_type_is_both_the_moli_error_and_a_type_error(make, error):
    with pytest.raises(error) as caught:
        make()
    assert isinstance(caught.value, TypeError) and isinstance(caught.value, ValueError)


@pytest.mark.parametrize("make, error", [
    (lambda: moli.IdentifyOptions(nmax=0), OptionError),
    (lambda: moli.IdentifyOptions(order_tolerance=-1.0), OptionError),
    (lambda: moli.IOData(Y, U, Ts=-0.5), DataError),
    (lambda: moli.IOData(Y, U, Ts=float("nan")), DataError),
    (lambda: moli.IOData(Y, U, output_names=["a", "b"]), DataError),
], ids=["nmax 0", "tolerance negative", "Ts negative", "Ts NaN", "two names for one channel"])
def test_a_wrong_value_is_not_a_type_error(make, error):
    with pytest.raises(error) as caught:
        make()
    assert not isinstance(caught.value, TypeError)


def test_type_variants_pickle_as_themselves():
    # errors cross process boundaries in fleet runs: the class must be found by name
    error = wrong_type(DataError)("Ts must be a positive finite number, got '1'")
    again = pickle.loads(pickle.dumps(error))
    assert type(again) is type(error) and str(again) == str(error)
    assert wrong_type(wrong_type(DataError)) is wrong_type(DataError)
