"""Regularized ARX models and their balanced truncation: exact recovery, the marginal likelihood
against the dense one, the balancing against the Hankel matrix, feedthrough, bad input."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

import moli
from moli.method.kernel.arx import arx_state_space, regularized_arx
from moli.method.kernel.arx_evidence import fit_arx_output
from moli.method.kernel.arx_rows import arx_factor
from moli.method.kernel.balanced import balancing
from moli.method.kernel.empirical_bayes import neg_log_likelihood, posterior
from moli.method.kernel.kernels import kernel_matrix, square_root

# y(t) = y(t-1) - 0.34 y(t-2) + u(t-1) + 0.5 u(t-2): poles 0.5 +- 0.3j, a zero at -0.5
NUMERATOR, DENOMINATOR, POLES = [0.0, 1.0, 0.5], [1.0, -1.0, 0.34], np.array([0.5 - 0.3j, 0.5 + 0.3j])


def _arx_record(N, seed, noise=0.0):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    y = scipy.signal.lfilter(NUMERATOR, DENOMINATOR, u)
    return moli.IOData(y + noise * rng.standard_normal(N), u)


@pytest.mark.parametrize("kernel", ["TC", "DC"])
def test_noise_free_arx_data_give_the_plant_poles(kernel):
    # The record is exactly an ARX model of two lags, so the 30-lag regularized ARX reproduces it
    # (the higher lags carry only common factors, which balancing finds unreachable or unobservable)
    # and the balanced order is 2. What is left is the prior's pull: the noise variance stops at
    # e^-25 of its start (LOG_RANGE nepers), a relative noise level of e^-12.5 ~ 4e-6, so the poles
    # are asked to 1e-5 (measured: 1e-8 to 2e-7).
    result = moli.identify_kernel_arx(_arx_record(150, 3), kernel=kernel, center=False, nmax=6)
    assert result.selected.order == 2
    assert np.allclose(np.sort_complex(result.model.poles()), POLES, atol=1e-5)
    # the simulator's Hankel singular values beyond the second vanish to the same relative level
    A, B, C, _ = result.arx.state_space()
    hsv = balancing(A, B, C).hankel_singular_values
    assert hsv[2] < 1e-5 * hsv[0]


def _direct(data, lags, feedthrough):
    """Phi and Y of the ARX regression built sample by sample (no factor): outputs' lags, then inputs'."""
    rows = [t for start, stop in data.bounds for t in range(start + lags, stop)]
    shift = int(feedthrough)
    phi = np.array([[data.y[t - k, i] for i in range(data.p) for k in range(1, lags + 1)]
                    + [data.u[t - k + shift, i] for i in range(data.m) for k in range(1, lags + 1)] for t in rows])
    return phi, data.y[rows]


@pytest.mark.parametrize("feedthrough", [False, True])
def test_the_marginal_likelihood_and_posterior_are_the_dense_ones(feedthrough):
    # independent truth: -2 log p(y) = y' S^-1 y + log det S with S = sigma^2 I + Phi K Phi' formed
    # whole from regressors built sample by sample, on a record of two segments (no row crosses the
    # gap), and the posterior mean K Phi' S^-1 y; both ways are exact, so they agree to round-off
    # (1e-8 relative: S's condition number here is below 1e4)
    rng = np.random.default_rng(5)
    y, u = rng.standard_normal((70, 2)), rng.standard_normal((70, 1))
    data = moli.IOData(y, u, segment_starts=[0, 40])
    lags = 4
    phi, Y = _direct(data, lags, feedthrough)
    factor = arx_factor(data, lags, feedthrough)
    assert factor.rows == len(Y) == 70 - 2 * lags
    kernels = [kernel_matrix("TC", np.arange(1, lags + 1), np.array([0.2, 0.8])),
               kernel_matrix("DC", np.arange(1, lags + 1), np.array([-0.5, 0.3, 0.4]))]
    K = scipy.linalg.block_diag(kernels[0], kernels[0], kernels[1])
    L = scipy.linalg.block_diag(*[square_root(k) for k in (kernels[0], kernels[0], kernels[1])])
    for j in range(2):
        S = 0.3 * np.eye(len(Y)) + phi @ K @ phi.T
        dense = Y[:, j] @ np.linalg.solve(S, Y[:, j]) + np.linalg.slogdet(S)[1]
        assert neg_log_likelihood(factor, j, L, 0.3) == pytest.approx(dense, rel=1e-8)
        mean, cov_factor = posterior(factor, j, L, 0.3)
        assert np.allclose(mean, K @ phi.T @ np.linalg.solve(S, Y[:, j]), rtol=1e-8, atol=1e-10)
        assert np.allclose(cov_factor @ cov_factor.T, K - K @ phi.T @ np.linalg.solve(S, phi @ K), atol=1e-10)


def test_the_hyperparameters_are_a_maximum_of_the_dense_likelihood():
    # the search's result, put into the dense likelihood, is not bettered by any step of 0.05 in
    # any one coordinate (the likelihood is smooth, so a step that small finds any slope the
    # search left: a lower value would show it stopped short of a maximum)
    data = _arx_record(120, 7, noise=0.2).remove_means()
    lags = 6
    factor = arx_factor(data, lags, False)
    fit = fit_arx_output(factor, 0, "TC", np.arange(1, lags + 1), (1, 1))
    phi, Y = _direct(data, lags, False)

    def dense(x):
        kernels = [kernel_matrix("TC", np.arange(1, lags + 1), x[i:i + 2]) for i in (0, 2)]
        S = np.exp(x[4]) * np.eye(len(Y)) + phi @ scipy.linalg.block_diag(*kernels) @ phi.T
        return Y[:, 0] @ np.linalg.solve(S, Y[:, 0]) + np.linalg.slogdet(S)[1]

    found = np.r_[fit.coordinates[0], fit.coordinates[1], np.log(fit.noise_variance)]
    assert dense(found) == pytest.approx(fit.neg_log_likelihood, rel=1e-8)
    for i in range(5):
        for step in (-0.05, 0.05):
            moved = found.copy()
            moved[i] += step
            assert dense(moved) >= dense(found) - 1e-6


def test_balancing_gives_the_hankel_singular_values_and_keeps_the_unstable_part():
    # independent truth: the Hankel singular values are the singular values of the Hankel matrix of
    # the Markov parameters C A^(i+j) B, here of 400 lags (the slowest pole 0.9: 0.9^400 ~ 5e-19)
    rng = np.random.default_rng(2)
    A = np.diag([0.9, -0.5, 0.3]) + 0.05 * rng.standard_normal((3, 3))
    B, C = rng.standard_normal((3, 2)), rng.standard_normal((2, 3))
    markov = [C @ np.linalg.matrix_power(A, k) @ B for k in range(400)]
    H = np.block([[markov[i + j] for j in range(200)] for i in range(200)])
    assert np.allclose(balancing(A, B, C).hankel_singular_values, np.linalg.svd(H, compute_uv=False)[:3],
                       rtol=1e-8)
    # an unstable mode (1.2) is kept exactly at every order, beside the stable part's truncation;
    # a change of basis couples it with the stable states (the Sylvester equation has work to do)
    M = np.eye(4) + 0.3 * rng.standard_normal((4, 4))
    unstable = M @ scipy.linalg.block_diag(A, [[1.2]]) @ np.linalg.inv(M)
    B2 = M @ np.vstack([B, rng.standard_normal((1, 2))])
    C2 = np.hstack([C, rng.standard_normal((2, 1))]) @ np.linalg.inv(M)
    kept = balancing(unstable, B2, C2)
    assert kept.unstable == 1 and kept.largest_order == 4
    for order in (1, 2, 4):
        V, W = kept.projection(order)
        assert np.allclose(W.T @ V, np.eye(order), atol=1e-10)
        assert np.min(np.abs(np.linalg.eigvals(W.T @ unstable @ V) - 1.2)) < 1e-10
    V, W = kept.projection(4)      # no truncation: the same system
    assert np.allclose(np.sort(np.linalg.eigvals(W.T @ unstable @ V)), np.sort(np.linalg.eigvals(unstable)))


def test_the_gain_bands_hold_the_true_gain():
    # a first-order plant (an output-error one: the ARX model only approximates it), 150 samples at
    # 10 dB: the 95 % bands of |G| at four frequencies held the true gain on 0.89 of the points of 40
    # records (0.86 on the first 20, 0.93 on the others; order 1 selected on 34); on 20 records (80
    # points) 0.75 is three binomial standard deviations (0.035) below 0.86. Bands of a covariance
    # that misses the shrinkage or the noise hold far less (the DC gain, the most shrunk, at 0.78).
    plant = moli.StateSpaceModel([[0.8]], [[1.0]], [[0.5]])
    omega = np.array([0.0, 0.3, 1.0, 2.5])
    truth = np.abs(plant.frequency_response(omega))[:, 0, 0]
    held = []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        u = rng.standard_normal((150, 1))
        clean = plant.simulate(u)
        data = moli.IOData(clean + np.std(clean) / np.sqrt(10) * rng.standard_normal(clean.shape), u)
        lower, upper = moli.identify_kernel_arx(data, nmax=4).model.magnitude_bands(omega)
        held.append((lower[:, 0, 0] <= truth) & (truth <= upper[:, 0, 0]))
    assert np.mean(held) >= 0.75


def test_the_simulator_is_the_arx_recursion():
    # the block observer form simulated against the difference equation run sample by sample
    rng = np.random.default_rng(4)
    outputs, inputs = 0.2 * rng.standard_normal((3, 2, 2)), rng.standard_normal((4, 2, 1))
    model = moli.StateSpaceModel(*arx_state_space(outputs, inputs))
    u = rng.standard_normal((50, 1))
    y = np.zeros((50, 2))
    for t in range(50):
        y[t] = sum(outputs[k - 1] @ y[t - k] for k in range(1, 4) if t >= k) + \
            sum(inputs[k] @ u[t - k] for k in range(4) if t >= k)
    assert np.allclose(model.simulate(u), y, atol=1e-10)


def test_feedthrough_auto_finds_a_direct_term_where_there_is_one():
    # 300 samples at 20 dB: a direct term of 0.8 is 0.8 / (0.1 sd) = 8 noise levels per sample, which
    # the marginal likelihood cannot miss; without it, the model of lag 0 explains nothing more and
    # its likelihood is lower by the prior's Occam factor
    data = _arx_record(300, 1, noise=0.1)
    with_direct = moli.IOData(data.y[:, 0] + 0.8 * data.u[:, 0], data.u)
    assert regularized_arx(with_direct).feedthrough == (True,)
    assert abs(regularized_arx(with_direct).inputs[0, 0, 0] - 0.8) < 0.1
    assert regularized_arx(data).feedthrough == (False,)
    assert regularized_arx(data).inputs[0, 0, 0] == 0.0


def test_bad_input_gets_one_clear_error():
    data = _arx_record(100, 0)
    with pytest.raises(moli.OptionError, match="kernel must be one of"):
        regularized_arx(data, "gauss")
    with pytest.raises(moli.DataError, match="lags = 100 reach beyond the longest segment"):
        regularized_arx(data, lags=100)
    with pytest.raises(moli.OptionError, match="lags"):
        regularized_arx(data, lags=0)
    with pytest.raises(moli.OptionError, match="feedthrough must be"):
        regularized_arx(data, feedthrough="yes")
    with pytest.raises(moli.DataError, match="input u1 never changes"):
        regularized_arx(moli.IOData(data.y, np.ones(100)))
    with pytest.raises(moli.DataError, match="least squares needs more rows than coefficients"):
        regularized_arx(data, "none", lags=40)
    with pytest.raises(moli.DataError, match="must be an IOData"):
        moli.identify_kernel_arx(np.zeros((100, 2)))
    for nmax in (0, 2.5, True):
        with pytest.raises(moli.OptionError, match="nmax must be a positive integer"):
            moli.identify_kernel_arx(data, nmax=nmax)
    with pytest.raises(moli.OptionError, match="x0 must be one of"):
        moli.identify_kernel_arx(data, x0="guess")
    with pytest.raises(moli.DataError, match="validation must be an IOData of the same channels"):
        moli.identify_kernel_arx(data, moli.IOData(np.zeros((50, 2)), np.zeros(50)))


def test_identify_hands_the_kernel_arx_method_over_and_refuses_what_it_would_ignore():
    data = moli.example_data(N=300, seed=1)
    through_identify = moli.identify(data, method="kernel-arx", kernel="DC", nmax=6)
    direct = moli.identify_kernel_arx(data, kernel="DC", nmax=6)
    # the same split (the last 30 % held out) and the same computation: the same model to the bit
    np.testing.assert_array_equal(through_identify.model.A, direct.model.A)
    assert isinstance(through_identify, moli.KernelArxResult) and through_identify.arx.kernel == "DC"
    assert through_identify.model.info["options"]["method"] == "kernel-arx"
    with pytest.raises(moli.OptionError, match="method='kernel-arx' does not read seed"):
        moli.identify(data, method="kernel-arx", seed=3)
    with pytest.raises(moli.OptionError, match="method='kernel-arx' identifies sampled models"):
        moli.identify(data, method="kernel-arx", time="continuous")
