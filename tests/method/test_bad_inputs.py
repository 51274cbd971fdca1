"""Bad arguments to the method's public functions: a moli error before any work.

Options are covered field by field in test_options.py.
"""

from __future__ import annotations

import numpy as np
import pytest

import moli
from moli import DataError, FilterError, OptionError

RNG = np.random.default_rng(2)
DATA = moli.IOData(RNG.standard_normal((120, 2)), RNG.standard_normal((120, 1)))


@pytest.mark.parametrize("call, error, message", [
    (lambda: moli.identify(DATA.y, nmax=3), DataError, "data must be an IOData"),
    (lambda: moli.identify(DATA, "val", nmax=3), DataError, "validation must be an IOData"),
    (lambda: moli.identify(DATA, moli.IOData(np.ones((50, 1)), np.ones(50)), nmax=3), DataError,
     "validation has 1 outputs"),
    (lambda: moli.identify(DATA, nmax=3, progress=3), OptionError, "progress must be a callable"),
    (lambda: moli.identify(DATA[:6], nmax=2), DataError, "too few samples"),
    (lambda: moli.identify(DATA[:1], nmax=2), DataError, "1 sample: too few to hold out"),
    (lambda: moli.identify_many([]), DataError, "datasets is empty"),
    (lambda: DATA[:1].split(0.5), DataError, "cannot be split at the fraction 0.5"),
    (lambda: moli.estimate(DATA, "ab", [1.0, -0.5]), moli.StructureError, "indices must be a list"),
    (lambda: moli.estimate(DATA, [1, 1], [1.0, np.nan]), FilterError, "alpha must be finite"),
    (lambda: moli.estimate(DATA, [1, 1], "ab"), FilterError, "alpha must be a sequence"),
    (lambda: moli.estimate(DATA.y, [1, 1], [1.0, -0.5]), DataError, "data must be an IOData"),
    (lambda: moli.divisor([1.0, -0.5], "1"), FilterError, "degree must be an integer"),
    (lambda: moli.divisor([1.0, -0.5], 1.0), FilterError, "degree must be an integer"),
    (lambda: moli.filter_polynomial("1", 0.7, [1, 1]), FilterError, "wc must be a finite real number"),
    (lambda: moli.filter_polynomial(float("nan"), 0.7, [1, 1]), FilterError, "wc must be"),
    (lambda: moli.filter_polynomial(0.5, -0.7, [1, 1]), FilterError, "zeta must lie in"),
    (lambda: moli.filter_polynomial(0.5, 0.7, [1, 1], "1"), FilterError, "Ts must be a positive finite number"),
    (lambda: moli.filter_polynomial(0.5, 0.7, [1, 1], float("nan")), FilterError, "Ts must be"),
    (lambda: moli.filter_polynomial(0.5, 0.7, [1, 1], 1.0, float("nan")), FilterError, "spacing factor s"),
    (lambda: moli.estimate_noise_model("model", DATA), DataError, "model must be a StateSpaceModel"),
    (lambda: moli.example_data(0), DataError, "N must be an integer of at least 2"),
    (lambda: moli.example_data("10"), DataError, "N must be an integer"),
    (lambda: moli.example_data(100, -1.0), DataError, "noise must lie in"),
    (lambda: moli.experiment(moli.example_plant(), np.ones((10, 3)) * 1j), DataError, "u must be real"),
    (lambda: moli.experiment("plant", np.ones((10, 3))), DataError, "plant must be a StateSpaceModel"),
])
def test_bad_arguments_of_method_functions(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_identify_leaves_the_callers_arrays_and_options_alone():
    y, u = DATA.y.copy(), DATA.u.copy()
    opts = moli.IdentifyOptions(nmax=3)
    record = moli.IOData(y, u)
    moli.identify(record, options=opts)
    assert np.array_equal(y, DATA.y) and np.array_equal(u, DATA.u)
    assert opts == moli.IdentifyOptions(nmax=3)


@pytest.mark.parametrize("x0, message", [
    ("abc", "x0 must be an array of real"),
    ([0.0] * 6, "x0 must be 7 finite numbers"),
    ([np.nan] * 7, "x0 must be 7 finite numbers"),
    ([1j] * 7, "x0 must be real"),
])
def test_the_twin_rotor_refuses_a_bad_initial_state(x0, message):
    from moli.systems import TwinRotor, TwinRotorError

    rig = TwinRotor()
    with pytest.raises(TwinRotorError, match=message):
        rig.reset(x0)
