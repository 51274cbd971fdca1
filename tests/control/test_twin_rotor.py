"""The simulated twin rotor: equilibrium, linearisation, integration accuracy, identification."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import moli
from moli.control import continuous_poles
from moli.systems.experiment import experiment
from moli.systems import (
    RigLimitWarning, TwinRotor, TwinRotorError, TwinRotorParameters, identification_experiment,
)

OMEGA = moli.method.tuning.barycenter.grid(np.array([0.8, 1.04, 1.28, 1.52, 1.76, 2.0]) * np.pi, [0.5, 0.625, 0.75])
NO_COULOMB = TwinRotorParameters(B2psi=0.0, B2phi=0.0)


def test_trim_is_an_equilibrium_with_the_documented_inputs():
    rig = TwinRotor()
    # Every derivative vanishes at the trim (exact algebra, so round-off only).
    np.testing.assert_allclose(rig.derivatives(rig.x_trim, rig.u_trim), 0.0, atol=1e-12)
    # Trim inputs of Profile B at pitch 0.2 rad, reference values computed by hand from
    # the trim equations and printed to 4 decimals.
    np.testing.assert_allclose(rig.u_trim, [0.5728, -0.1529], atol=5e-5)


def test_linearization_matches_central_differences():
    # Away from the trim, with yaw rate, so the gyroscopic cross terms are non-zero;
    # Coulomb friction off, since the linearisation leaves it out by design.
    rig = TwinRotor(NO_COULOMB)
    x = np.array([0.3, 0.4, -0.2, 0.7, 0.8, -0.3, 0.01])
    u = np.array([0.6, -0.2])
    A, B, _ = rig.linearize(x, u)
    h = 1e-6
    A_fd = np.column_stack([
        (rig.derivatives(x + h * e, u) - rig.derivatives(x - h * e, u)) / (2 * h) for e in np.eye(7)
    ])
    B_fd = np.column_stack([
        (rig.derivatives(x, u + h * e) - rig.derivatives(x, u - h * e)) / (2 * h) for e in np.eye(2)
    ])
    # Central differences err by O(h^2 f''') ~ 1e-12 plus round-off eps*|f|/h ~ 1e-9.
    np.testing.assert_allclose(A, A_fd, atol=1e-7)
    np.testing.assert_allclose(B, B_fd, atol=1e-7)


def test_linearization_at_trim_matches_the_documented_table_and_poles():
    A, B, _ = TwinRotor().linearize()
    # Reference Jacobian entries computed by hand from the Profile B parameters (4 digits).
    expected = {(1, 0): -4.6121, (1, 1): -0.0882, (1, 3): -0.0458, (1, 4): 1.6090,
                (3, 2): -0.5160, (3, 3): -0.4720, (3, 5): 1.7021, (3, 6): -20.0,
                (4, 4): -0.9091, (5, 5): -1.0, (6, 4): 0.01855, (6, 6): -0.5}
    for (i, j), value in expected.items():
        assert A[i, j] == pytest.approx(value, rel=5e-4), (i, j)
    assert B[6, 0] == pytest.approx(-0.02975, rel=5e-4)
    poles = np.linalg.eigvals(A)
    # Profile B's yaw pair is placed at the paper's -0.236 +- 0.678j (3 digits).
    assert np.min(np.abs(poles - (-0.236 + 0.678j))) < 2e-3
    assert np.min(np.abs(poles - (-0.0441 + 2.1471j))) < 2e-4


def _pitch_energy(rig, x):
    p = rig.params
    return 0.5 * p.I1 * x[1] ** 2 + p.Mg * (1 - math.cos(x[0]))


def _yaw_energy(rig, x):
    p = rig.params
    return 0.5 * p.I2 * x[3] ** 2 + 0.5 * p.K_cab * x[2] ** 2


def test_frictionless_swings_conserve_energy():
    # No friction and no rotor thrust (tau = M_R = 0, u = 0): pitch is a pendulum and
    # yaw a spring-mass, each with constant energy; the gyroscopic term vanishes with M1.
    params = dataclasses.replace(NO_COULOMB, B1psi=0.0, B1phi=0.0)
    rig = TwinRotor(params)
    x = np.array([0.4, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0])
    e0 = (_pitch_energy(rig, x), _yaw_energy(rig, x))
    for _ in range(200):  # 20 s, about 7 pitch periods
        x = rig.advance(x, [0.0, 0.0])
    # RK4 at 5 ms: relative energy drift ~ (omega h)^4 per period ~ 1e-8 over 20 s.
    assert _pitch_energy(rig, x) == pytest.approx(e0[0], rel=1e-7)
    assert _yaw_energy(rig, x) == pytest.approx(e0[1], rel=1e-7)


def test_friction_only_removes_energy():
    rig = TwinRotor()
    x = np.array([0.4, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0])
    energies = []
    for _ in range(100):
        x = rig.advance(x, [0.0, 0.0])
        energies.append(_pitch_energy(rig, x))
    # Without thrust the only pitch torques are gravity (conservative) and friction.
    assert np.all(np.diff(energies) <= 1e-15)
    assert energies[-1] < 0.9 * energies[0]


def test_fixed_step_integration_matches_an_adaptive_solver():
    rig = TwinRotor()
    rng = np.random.default_rng(5)
    u_seq = rig.u_trim + rng.choice([-0.25, 0.25], size=(50, 2)) * [1.0, 0.2]
    x = rig.x_trim.copy()
    x_ref = rig.x_trim.copy()
    for uk in u_seq:
        x = rig.advance(x, uk)
        sol = solve_ivp(lambda t, s: rig.derivatives(s, uk), (0, rig.Ts), x_ref,
                        method="DOP853", rtol=1e-11, atol=1e-13)
        x_ref = sol.y[:, -1]
    # 5 s of switching inputs: RK4 at 5 ms agrees to far below the encoder step (1.5e-3 rad).
    np.testing.assert_allclose(x, x_ref, atol=1e-8)


def test_measurements_are_quantised_and_noise_is_seeded():
    rig = TwinRotor()
    y = experiment(rig, np.tile(rig.u_trim + [0.2, 0.05], (30, 1))).y
    steps = y / rig.quantization
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    noisy = TwinRotor(noise_std=1e-3, seed=4)
    u = np.tile(noisy.u_trim, (20, 1))
    a, b = experiment(noisy, u).y, experiment(noisy, u).y
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, experiment(noisy, u, seed=5).y)


def test_inputs_saturate_and_leaving_the_envelope_warns():
    rig = TwinRotor()
    big = rig.advance(rig.x_trim, [10.0, 0.0], duration=0.5)
    capped = rig.advance(rig.x_trim, [2.5, 0.0], duration=0.5)
    np.testing.assert_array_equal(big, capped)
    with pytest.warns(RigLimitWarning):
        experiment(rig, np.tile([2.5, 2.5], (150, 1)))


def test_bad_settings_raise_value_errors():
    with pytest.raises(TwinRotorError):
        TwinRotorParameters(I1=-1.0)
    with pytest.raises(ValueError):
        TwinRotor(Ts=0.0)
    with pytest.raises(TwinRotorError, match="beyond"):
        TwinRotor(psi0=0.2, phi0=1.0e3)
    rig = TwinRotor()
    with pytest.raises(TwinRotorError):
        rig.step([1.0])


def _pitch_pair(model):
    s = continuous_poles(model.poles(), model.Ts)
    upper = s[s.imag > 1.0]
    assert upper.size, f"no oscillatory pole near the pitch mode in {s}"
    return upper[np.argmin(np.abs(np.abs(upper) - 2.15))]


def test_identification_beats_the_paper_on_unseen_samples():
    data = identification_experiment(seed=0)
    result = moli.identify(data[:150], validation=data, omega=OMEGA, nmax=8, seed=0, center=False)
    yhat = result.model.simulate(data.u)
    vaf = moli.vaf(data.y[150:], yhat[150:])
    # The paper reached 81.5 % / 79 % on the real rig; 10 seeds of the noisy rig give a
    # mean of 96.7 % with a worst output of 70.6 % (seed 7; docs/twin_rotor.md); this
    # noise-free seed is at 98 %, so 85 % per output is a margin, not a coin toss.
    assert np.all(vaf > 85.0), vaf
    # Frequency of the pitch mode within 10 % of the linearised rig (2.1476 rad/s).
    lin = np.linalg.eigvals(TwinRotor().linearize()[0])
    pitch_lin = lin[np.argmax(lin.imag)]
    assert abs(_pitch_pair(result.model)) == pytest.approx(abs(pitch_lin), rel=0.10)


def test_identified_pitch_damping_matches_the_linearization_without_coulomb_friction(no_coulomb_seed0):
    # The linearisation leaves Coulomb friction out; with it on, the identified damping
    # is the amplitude-dependent effective one (2-4.5 times larger, docs/twin_rotor.md).
    # With Coulomb friction and quantisation off the linearisation is the rig's
    # small-signal truth, and the identified pair must match frequency and damping.
    rig, data, result = no_coulomb_seed0  # the paper's experiment, seed 0, shared with the doc check
    assert rig.params == NO_COULOMB and rig.quantization == 0.0 and data.N == 600
    lin = np.linalg.eigvals(rig.linearize()[0])
    pitch_lin = lin[np.argmax(lin.imag)]
    pitch_id = _pitch_pair(result.model)
    # 10 %: over 10 seeds the damping error spans -17.5 % to +19.9 % (15 s of data hold
    # only 5 pitch periods; docs/twin_rotor.md), this seed is at -0.7 %.
    assert abs(pitch_id) == pytest.approx(abs(pitch_lin), rel=0.10)
    zeta = -pitch_id.real / abs(pitch_id)
    zeta_lin = -pitch_lin.real / abs(pitch_lin)
    assert zeta == pytest.approx(zeta_lin, rel=0.10)
