"""Feedback detection: closed loops are flagged, open loops are not (at the stated rate)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.signal

import moli


def pi_loop(seed: int, N: int = 1000) -> moli.IOData:
    """The plant y = 0.5 / (q - 0.9) u + v under a PI controller; white reference r.

    At each sample y[k] is measured, then u[k] = Kp (r[k] - y[k]) + I[k] is applied.
    """
    rng = np.random.default_rng(seed)
    r = rng.standard_normal(N)
    v = 0.3 * rng.standard_normal(N)
    x = integral = 0.0
    y, u = np.empty(N), np.empty(N)
    for k in range(N):
        y[k] = x + v[k]
        error = r[k] - y[k]
        u[k] = 0.5 * error + integral
        integral += 0.1 * error
        x = 0.9 * x + 0.5 * u[k]
    return moli.IOData(y, u)


def open_loop(seed: int, N: int = 1000) -> moli.IOData:
    """The same plant driven by a random binary signal (held 1 to 5 samples) in open loop."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.choice([-1.0, 1.0], size=N), rng.integers(1, 6, size=N))[:N]
    y = scipy.signal.lfilter([0.0, 0.5], [1.0, -0.9], u) + 0.3 * rng.standard_normal(N)
    return moli.IOData(y, u)


def test_pi_loop_is_flagged():
    for seed in range(20):
        check = moli.feedback_check(pi_loop(seed))
        # measured p-values below 1e-7 over these runs: none may pass
        assert check.detected and check.pvalues[0] < 1e-6
    assert "feedback detected" in check.summary() and "u1" in check.summary()


def test_open_loop_false_alarms_stay_at_the_level():
    alarms = sum(moli.feedback_check(open_loop(seed), level=0.01).detected for seed in range(100))
    # level 0.01: about 1 alarm in 100 runs (measured 1); 6 or more would happen with
    # probability 5e-4 if the test kept its level
    assert alarms <= 5


def test_mimo_loop_flags_the_controlled_input_only():
    rng = np.random.default_rng(5)
    N = 2000
    A = np.array([[0.8, 0.1], [0.0, 0.7]])
    r, v = rng.standard_normal((N, 2)), 0.5 * rng.standard_normal((N, 2))
    x = np.zeros(2)
    y, u = np.empty((N, 2)), np.empty((N, 2))
    for k in range(N):
        y[k] = x + v[k]
        u[k] = [r[k, 0] - 0.6 * y[k, 0], r[k, 1]]     # u2 is open loop
        x = A @ x + u[k]
    check = moli.feedback_check(moli.IOData(y, u))
    # over 200 seeds of this loop: u1's p-value at most 2e-18, u2 flagged in 0.5 % of
    # the runs (its level, 0.01 / 2)
    assert check.detected and check.flagged == ("u1",)
    assert check.pvalues[0] < 1e-6


def test_lag_zero_tells_feedthrough_from_feedback():
    rng = np.random.default_rng(6)
    u = rng.standard_normal(1000)
    y = 0.8 * u + 0.3 * rng.standard_normal(1000)     # open loop, direct feedthrough
    data = moli.IOData(y, u)
    assert moli.feedback_check(data).detected          # lag 0 cannot tell them apart
    assert not moli.feedback_check(data, lag_zero=False).detected


def test_identify_warns_on_closed_loop_data_only():
    with pytest.warns(moli.ClosedLoopWarning, match="closed-loop.*external|closed-loop.*outside"):
        moli.identify(pi_loop(1), nmax=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", moli.ClosedLoopWarning)
        moli.identify(open_loop(1), nmax=2)
    assert issubclass(moli.ClosedLoopWarning, UserWarning)


def test_feedback_check_checks_its_arguments():
    data = open_loop(0, N=200)
    with pytest.raises(moli.DataError, match="IOData"):
        moli.feedback_check(np.zeros((10, 2)))
    for name, value in (("lags", 0), ("lags", 2.5), ("level", 0.0), ("level", "high"), ("lag_zero", 1)):
        with pytest.raises(moli.DataError, match=name):
            moli.feedback_check(data, **{name: value})
    with pytest.raises(moli.DataError, match="too few"):
        moli.feedback_check(data, lags=40)
    check = moli.feedback_check(data, lags=3)
    assert check.lags == 3 and check.pvalues.shape == (1,)


def test_inputs_that_rarely_change_are_left_untested_and_the_check_says_it_cannot_tell():
    rng = np.random.default_rng(7)
    u = np.where(np.arange(300) < 120, 1.0, -1.0)      # one switch in 300 samples
    y = scipy.signal.lfilter([0.0, 0.5], [1.0, -0.9], u) + 0.1 * rng.standard_normal(300)
    with pytest.warns(moli.ClosedLoopWarning, match="cannot tell whether u1 depends on the outputs: u1: its "
                                                    "changes are spread over 1 samples, fewer than the 11"):
        check = moli.feedback_check(moli.IOData(y, u))
    # a statistic resting on one sample says nothing either way
    assert np.isnan(check.pvalues[0]) and not check.detected
    assert check.undecided == ("u1",) and "cannot tell for u1" in check.summary()
    assert "untested" in check.summary()


# -- loops whose controller adds no noise of its own -------------------------------------

def pi_loops_record(seed: int, noise_pole: float, N: int = 2100) -> moli.IOData:
    """The 2x2 plant of moli.systems under its two PI loops (no noise added to their outputs),
    tracking set-point steps held 30-150 samples that the record does not hold; output noise
    of sd 0.1, white or AR(1). N = 2100: the estimation part identify keeps of 3000 samples."""
    from moli import control as mc
    from moli.systems import LinearPlant, pi_loop_gains, pi_loop_plant

    rng = np.random.default_rng(seed)
    r = np.zeros((N, 2))
    for channel in range(2):
        k = 0
        while k < N:
            hold = int(rng.integers(30, 151))
            r[k:k + hold, channel] = rng.uniform(-1, 1)
            k += hold
    loops = mc.DecentralizedPID([mc.PIDGains(kp, ki, 0.0) for kp, ki in pi_loop_gains()], [(0, 0), (1, 1)],
                                Ts=1.0, u0=np.zeros(2), u_limits=(-np.inf, np.inf))
    run = mc.closed_loop(LinearPlant(pi_loop_plant(), 0.1, noise_pole), loops, r, seed=seed)
    return moli.IOData(run.y, run.u)


def open_pi_plant_record(seed: int, N: int = 2100) -> moli.IOData:
    """The same plant in open loop: random binary inputs held 1-5 samples, output noise of sd 0.1."""
    from moli.systems import pi_loop_plant

    rng = np.random.default_rng(seed)
    u = np.repeat(rng.choice([-1.0, 1.0], size=(N, 2)), rng.integers(1, 6, size=N), axis=0)[:N]
    return moli.IOData(pi_loop_plant().simulate(u) + 0.1 * rng.standard_normal((N, 2)), u)


def test_pi_loops_whose_controller_adds_no_noise_are_detected():
    # Such a controller's output is an exact function of the outputs and its own past wherever
    # its set-points hold still: every window between two steps fits to round-off (1e-14,
    # docs/diagnostics.md §4). Two of the record's ~39 windows must be free of a step; each
    # is with probability about 1/2, so a record without two fails with probability under
    # 1e-9: every record must be found, white or coloured noise (the F-test alone left the
    # coloured ones untested: their changes crowd onto the set-point steps)
    for seed in range(6):
        for pole in (0.0, 0.9):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                check = moli.feedback_check(pi_loops_record(seed, pole))
            assert check.detected and check.exact == ("u1", "u2"), (seed, pole, check.summary())
    assert "reproduce u1, u2 exactly" in check.summary()


def test_open_loop_records_of_the_same_plant_are_not_reproduced_exactly():
    alarms = 0
    for seed in range(100):
        check = moli.feedback_check(open_pi_plant_record(seed))
        # outputs with noise meet an input to 1e-5 in a window with probability of order
        # 1e-50: never
        assert check.exact == ()
        alarms += check.detected
    # the F-test at level 0.01 (measured: 2 alarms in these 100 records): 5 or more of 100
    # would happen with probability 0.003 if it kept its level
    assert alarms <= 4


def test_an_input_the_outputs_explain_entirely_is_feedback():
    # u = -0.5 y: the input's innovation is the output's times -0.5, so the F-test's full
    # regression leaves nothing (this counted as p = 1 before), and every window fits exactly
    rng = np.random.default_rng(3)
    v = 0.3 * rng.standard_normal(1500)
    x, y, u = 0.0, np.empty(1500), np.empty(1500)
    for k in range(1500):
        y[k] = x + v[k]
        u[k] = -0.5 * y[k]
        x = 0.9 * x + 0.5 * u[k]
    check = moli.feedback_check(moli.IOData(y, u))
    assert check.detected and check.pvalues[0] == 0.0 and check.exact == ("u1",)


def test_held_stretches_are_no_evidence_of_an_exact_fit():
    # a record whose channels sit still for stretches (a logger holding its last values, as
    # in DaISy's exchanger): a window whose rows are one held row and 15 fresh ones has
    # fewer distinct rows than its 22 columns, and fits any input exactly; it must not count
    rng = np.random.default_rng(4)
    u = rng.standard_normal(1500)
    y = scipy.signal.lfilter([0.0, 0.5], [1.0, -0.9], u) + 0.1 * rng.standard_normal(1500)
    # windows of 32 rows from sample 10 (10 lags, 22 columns): stretches that end 15 rows
    # before a window does
    for end in (10 + 32 * k + 32 - 15 for k in (5, 15, 25)):
        u[end - 100:end], y[end - 100:end] = u[end - 100], y[end - 100]
    assert moli.feedback_check(moli.IOData(y, u), lags=10).exact == ()


@pytest.mark.parametrize("period", [8, 11, 12, 13, 25])
def test_a_noise_free_periodic_open_loop_record_is_not_a_controller(period):
    # a multisine-like input repeated every `period` samples through y = 0.5 / (q - 0.9) u, no
    # noise: once its start has decayed, the outputs and the input's own past reproduce the input
    # exactly (y(t - period + 1) holds u(t - period) = u(t)), yet nothing closes a loop. Its
    # windows repeat the rows of one period (and its start's rows differ by round-off-sized
    # amounts): too few distinct rows to prove anything (a period of 12 with 11 lags was taken
    # for a controller's output, and the default identified it by the direct method)
    rng = np.random.default_rng(period)
    u = np.tile(rng.standard_normal(period), 1500 // period + 1)[:1500]
    y = scipy.signal.lfilter([0.0, 0.5], [1.0, -0.9], u)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", moli.ClosedLoopWarning)
        assert moli.feedback_check(moli.IOData(y, u)).exact == ()
