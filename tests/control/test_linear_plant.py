"""LinearPlant: a linear model with output noise as a sampled plant, in open and closed loop."""

from __future__ import annotations

import numpy as np
import pytest

import moli
from moli import control as mc
from moli.systems import LinearPlant, experiment, pi_loop_gains, pi_loop_plant


def _plant_with_offsets() -> moli.StateSpaceModel:
    rng = np.random.default_rng(7)
    A = rng.standard_normal((3, 3))
    A *= 0.8 / np.max(np.abs(np.linalg.eigvals(A)))
    model = moli.StateSpaceModel(A, rng.standard_normal((3, 2)), rng.standard_normal((2, 3)), Ts=0.5,
                                 y_offset=[1.0, -2.0], u_offset=[0.3, 0.7])
    return model.with_input_delays([0, 2])


def _noise(noise_sd, noise_pole, N, seed=0):
    """N samples of a plant's noise alone: a zero model held at its operating point."""
    zero = moli.StateSpaceModel(np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((2, 1)))
    return experiment(LinearPlant(zero, noise_sd, noise_pole), np.zeros((N, 1)), seed=seed).y


def _autocorrelation(v, lag):
    v = v - v.mean(axis=0)
    return np.sum(v[lag:] * v[:-lag], axis=0) / np.sum(v * v, axis=0)


def test_noise_free_plant_records_the_model_simulation():
    model = _plant_with_offsets()
    u = np.random.default_rng(1).standard_normal((60, 2)) + model.u_offset
    record = experiment(LinearPlant(model, noise_sd=0.0), u)
    # the model's own simulation (input delays included) in absolute units
    np.testing.assert_allclose(record.y, model.simulate(u - model.u_offset) + model.y_offset, atol=1e-12)
    assert record.Ts == 0.5 and record.input_names == model.input_names


@pytest.mark.parametrize("pole", [0.0, 0.9])
def test_noise_has_the_given_spread_and_autocorrelation(pole):
    N = 20000
    v = _noise([0.5, 2.0], pole, N)
    # Relative standard error of a sample sd of an AR(1) series: sqrt((1 + a^2) / (2 N (1 - a^2))),
    # 0.005 (white) and 0.015 (a = 0.9) at N = 20000; 0.08 is five of the larger.
    np.testing.assert_allclose(v.std(axis=0), [0.5, 2.0], rtol=0.08)
    # Standard error of a lag-k autocorrelation estimate: about sqrt((1 - a^2) / N) <= 0.0071;
    # 0.035 is five of it.
    for lag in (1, 3):
        np.testing.assert_allclose(_autocorrelation(v, lag), pole**lag, atol=0.035)
    # the two outputs' noises are independent: correlation within five standard errors of 0
    assert abs(np.corrcoef(v.T)[0, 1]) < 5 * np.sqrt((1 + pole**2) / ((1 - pole**2) * N))


def test_noise_is_stationary_from_the_first_sample():
    # First samples over 2000 seeds: a sample sd within 5 standard errors (5 / sqrt(4000) = 0.08).
    plant = LinearPlant(moli.StateSpaceModel([[0.0]], [[0.0]], [[0.0]]), noise_sd=0.3, noise_pole=0.95)
    first = []
    for seed in range(2000):
        plant.reset(seed=seed)
        first.append(plant.measure()[0])
    assert np.std(first) == pytest.approx(0.3, rel=0.08)


def test_records_repeat_by_seed():
    model = _plant_with_offsets()
    u = np.random.default_rng(2).standard_normal((40, 2))
    plant = LinearPlant(model, noise_sd=[0.1, 0.2], noise_pole=0.5, seed=4)
    first, again = experiment(plant, u).y, experiment(plant, u).y
    np.testing.assert_array_equal(first, again)  # reset() reuses the constructor's seed
    np.testing.assert_array_equal(experiment(plant, u, seed=4).y, first)
    assert not np.allclose(experiment(plant, u, seed=5).y, first)
    # measure() does not draw: asking twice in a sample gives the same reading
    plant.reset()
    np.testing.assert_array_equal(plant.measure(), plant.measure())


def _pi_controller() -> mc.DecentralizedPID:
    gains = [mc.PIDGains(kp, ki, 0.0) for kp, ki in pi_loop_gains()]
    return mc.DecentralizedPID(gains, [(0, 0), (1, 1)], Ts=1.0, u0=np.zeros(2), u_limits=(-np.inf, np.inf))


def test_pi_loops_on_the_linear_plant_match_the_closed_loop_state_space():
    truth = pi_loop_plant()
    r = mc.setpoint_steps(120, [0.0, 0.0], [(5, 0, 1.0), (60, 1, -0.5)])
    run = mc.closed_loop(LinearPlant(truth, noise_sd=0.0), _pi_controller(), r)
    # Independent truth: the loop assembled by hand, states (x, integrator sum_{j<k} e_j),
    # u = Kp (r - x) + Ki sum, x+ = A x + B u, sum+ = sum + (r - x).
    Kp, Ki = (np.diag(g) for g in zip(*pi_loop_gains()))
    A, B = truth.A, truth.B
    x, total = np.zeros(2), np.zeros(2)
    for k in range(len(r)):
        np.testing.assert_allclose(run.y[k], x, atol=1e-12)
        u = Kp @ (r[k] - x) + Ki @ total
        np.testing.assert_allclose(run.u[k], u, atol=1e-12)
        x, total = A @ x + B @ u, total + r[k] - x
    # well damped: the integral action removes the error, overshoot stays small
    step = mc.step_metrics(run, 0, 5, 60)
    assert abs(step.steady_state_error) < 1e-3 and step.overshoot < 10


def test_closed_loop_records_repeat_by_seed():
    r = np.tile([0.5, -0.5], (50, 1))
    plant = LinearPlant(pi_loop_plant(), noise_sd=0.1, noise_pole=0.9)
    first = mc.closed_loop(plant, _pi_controller(), r, seed=3)
    again = mc.closed_loop(plant, _pi_controller(), r, seed=3)
    np.testing.assert_array_equal(first.u, again.u)
    assert not np.allclose(mc.closed_loop(plant, _pi_controller(), r, seed=4).u, first.u)


@pytest.mark.parametrize("arguments, message", [
    (dict(model=np.eye(2)), "model must be a StateSpaceModel"),
    (dict(model=moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]], [[0.2]])), "strictly proper"),
    (dict(noise_sd=-0.1), "noise_sd must be >= 0"),
    (dict(noise_sd=[0.1, 0.2, 0.3]), "one per output"),
    (dict(noise_sd=np.nan), "noise_sd"),
    (dict(noise_sd="0.1"), "noise_sd"),
    (dict(noise_pole=1.0), r"noise_pole must be in \(-1, 1\)"),
    (dict(noise_pole=-1.0), "noise_pole"),
    (dict(seed=-1), "seed must be an integer of at least 0"),
    (dict(seed=1.5), "seed must be an integer"),
])
def test_bad_arguments_are_refused(arguments, message):
    given = dict(model=pi_loop_plant(), noise_sd=0.1) | arguments
    with pytest.raises(moli.DataError, match=message):
        LinearPlant(**given)


def test_bad_inputs_are_refused():
    plant = LinearPlant(pi_loop_plant(), noise_sd=0.1)
    with pytest.raises(moli.DataError, match="u must have 2 entries"):
        plant.step([1.0, 2.0, 3.0])
    with pytest.raises(moli.DataError, match="u"):
        plant.step([np.nan, 0.0])
    with pytest.raises(moli.DataError, match="seed"):
        plant.reset(seed=-2)
