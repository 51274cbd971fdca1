"""Continuous-time models: zero-order hold and Tustin, both ways."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

import moli


def random_continuous(n: int, m: int, p: int, Ts: float, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """A stable continuous system whose poles satisfy |Im(lambda)| Ts < pi (ZOH is invertible
    on the principal branch of the logarithm), with a well-conditioned eigenbasis."""
    blocks = []
    while sum(b.shape[0] for b in blocks) < n:
        decay = rng.uniform(0.05, 3.0) / Ts
        if n - sum(b.shape[0] for b in blocks) >= 2 and rng.random() < 0.5:
            freq = rng.uniform(0.0, 0.9 * np.pi) / Ts
            blocks.append(np.array([[-decay, freq], [-freq, -decay]]))
        else:
            blocks.append(np.array([[-decay]]))
    modal = np.zeros((n, n))
    at = 0
    for b in blocks:
        k = b.shape[0]
        modal[at : at + k, at : at + k] = b
        at += k
    # eigenbasis of condition number at most 4: the round-off of logm and expm grows
    # with it, and the tolerances below are stated for well-conditioned modes
    Q1, _ = np.linalg.qr(rng.standard_normal((n, n)))
    Q2, _ = np.linalg.qr(rng.standard_normal((n, n)))
    T = Q1 @ np.diag(rng.uniform(0.5, 2.0, n)) @ Q2
    A = T @ modal @ np.linalg.solve(T, np.eye(n))
    return A, rng.standard_normal((n, m)), rng.standard_normal((p, n)), rng.standard_normal((p, m))


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 6), m=st.integers(1, 3), seed=st.integers(0, 10_000),
       Ts=st.sampled_from([0.01, 0.5, 2.0]), method=st.sampled_from(["zoh", "tustin"]))
def test_round_trip_recovers_the_continuous_matrices(n, m, seed, Ts, method):
    rng = np.random.default_rng(seed)
    A, B, C, D = random_continuous(n, m, 2, Ts, rng)
    sampled = moli.StateSpaceModel.from_continuous(A, B, C, D, Ts, method)
    back = sampled.to_continuous(method)
    # logm(expm(X)) = X on the principal branch (|Im(lambda)| Ts < pi): the round trip
    # is exact up to the round-off of the two matrix functions, which is relative to the
    # whole system matrix they act on (a fast A sets the scale of the errors in B)
    scale = max(1.0, np.abs(np.block([[A, B], [C, D]])).max())
    for got, expected in ((back.A, A), (back.B, B), (back.C, C), (back.D, D)):
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-10 * scale)
    again = back.to_discrete(Ts, method)
    np.testing.assert_allclose(again.A, sampled.A, rtol=0, atol=1e-10)


def test_sampling_matches_scipy():
    rng = np.random.default_rng(1)
    A, B, C, D = random_continuous(4, 2, 3, 0.2, rng)
    for method, name in (("zoh", "zoh"), ("tustin", "bilinear")):
        model = moli.StateSpaceModel.from_continuous(A, B, C, D, Ts=0.2, method=method)
        expected = scipy.signal.cont2discrete((A, B, C, D), 0.2, method=name)[:4]
        # the same formulas computed by another implementation: round-off agreement
        for got, want in zip((model.A, model.B, model.C, model.D), expected):
            np.testing.assert_allclose(got, want, atol=1e-12)


def test_first_order_lag_has_its_time_constant():
    tau, Ts = 3.0, 0.5
    a = np.exp(-Ts / tau)
    model = moli.StateSpaceModel([[a]], [[1 - a]], [[2.0]], Ts=Ts, input_names=["heater"])
    continuous = model.to_continuous()
    # exact: the sampled lag's pole exp(-Ts/tau) and unit static gain
    np.testing.assert_allclose(continuous.A, [[-1 / tau]], rtol=1e-12)
    np.testing.assert_allclose(continuous.B, [[1 / tau]], rtol=1e-12)
    np.testing.assert_allclose(continuous.poles(), [-1 / tau], rtol=1e-12)
    assert continuous.input_names == ("heater",) and continuous.is_stable()


def test_tustin_warps_frequency_exactly():
    rng = np.random.default_rng(2)
    A, B, C, D = random_continuous(3, 2, 2, 0.3, rng)
    Ts = 0.3
    discrete = moli.StateSpaceModel.from_continuous(A, B, C, D, Ts, "tustin").with_input_delays([0, 2])
    continuous = discrete.to_continuous("tustin")
    omega = np.linspace(0.1, 0.9 * np.pi / Ts, 6)
    warped = (2 / Ts) * np.tan(omega * Ts / 2)
    expected = continuous.frequency_response(warped)
    # the delays are exp(-j w d Ts) in discrete time and exp(-j w' d Ts) in continuous time:
    # remove the continuous one at the warped frequency, put the discrete one back
    delays = np.asarray(continuous.input_delays)
    expected = expected * np.exp(1j * np.outer(warped - omega, delays))[:, None, :]
    # H_d(exp(j w Ts)) = H_c(j (2/Ts) tan(w Ts / 2)) holds exactly for the bilinear map
    np.testing.assert_allclose(discrete.frequency_response(omega), expected, rtol=1e-10)
    np.testing.assert_allclose(continuous.input_delays, [0.0, 2 * Ts])


def test_a_refusal_names_every_pole_and_each_way_forward():
    model = moli.StateSpaceModel(np.diag([0.9, -0.5, -0.25]), np.ones((3, 1)), np.ones((1, 3)))
    with pytest.raises(moli.DataError) as refused:
        model.to_continuous()
    message = str(refused.value)
    assert "z = -0.5, z = -0.25. Options:" in message        # both poles, not the one at 0.9
    for way in ("(1) method='tustin'", "(2) keep the discrete model", "(3) identify from data "
                "sampled faster", "lower order"):
        assert way in message
    assert model.to_continuous("tustin").is_stable()        # the first way works


def test_poles_without_a_real_logarithm_are_refused_with_alternatives():
    negative = moli.StateSpaceModel(np.diag([0.5, -0.4]), np.ones((2, 1)), np.ones((1, 2)))
    with pytest.raises(moli.DataError, match="negative real axis.*tustin.*sampled faster"):
        negative.to_continuous()
    assert negative.to_continuous("tustin").is_stable()      # Tustin maps -0.4 inside
    at_zero = moli.StateSpaceModel(np.diag([0.5, 0.0]), np.ones((2, 1)), np.ones((1, 2)))
    with pytest.raises(moli.DataError, match="z = 0.*tustin"):
        at_zero.to_continuous()
    at_minus_one = moli.StateSpaceModel([[-1.0]], [[1.0]], [[1.0]])
    with pytest.raises(moli.DataError, match="z = -1.*no zero-order hold") as refused:
        at_minus_one.to_continuous("tustin")
    assert "method='tustin'" not in str(refused.value).split("Options")[1]   # it fails too
    with pytest.raises(moli.OptionError, match="method"):
        negative.to_continuous("euler")
    with pytest.raises(moli.OptionError, match="method"):
        moli.StateSpaceModel.from_continuous([[-1.0]], [[1.0]], [[1.0]], method="foh")
    with pytest.raises(moli.DataError, match="Ts"):
        moli.StateSpaceModel.from_continuous([[-1.0]], [[1.0]], [[1.0]], Ts=0.0)


def test_continuous_to_control():
    control = pytest.importorskip("control")
    rng = np.random.default_rng(3)
    A, B, C, D = random_continuous(3, 2, 2, 1.0, rng)
    model = moli.StateSpaceModel.from_continuous(A, B, C, D, Ts=1.0)
    sys = model.to_control(continuous=True)
    assert sys.dt == 0 and list(sys.input_labels) == ["u1", "u2"]
    np.testing.assert_allclose(sys.A, A, atol=1e-10)    # the round trip's accuracy, as above
    delayed = model.with_input_delays([1, 0])
    with pytest.raises(moli.DataError, match="pade"):
        delayed.to_control(continuous=True)
    # discrete: the delays become states, with the same frequency response
    omega = np.array([0.1, 1.0, 3.0])
    response = control.frequency_response(delayed.to_control(), omega)
    np.testing.assert_allclose(np.moveaxis(response.complex, 2, 0),
                               delayed.frequency_response(omega), rtol=1e-10)


def test_delays_that_are_not_whole_samples_are_refused():
    model = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]], Ts=1.0).with_input_delays([3])
    continuous = model.to_continuous()
    assert continuous.to_discrete(0.5).input_delays == (6,)
    with pytest.raises(moli.DataError, match="multiples"):
        continuous.to_discrete(2.0)
