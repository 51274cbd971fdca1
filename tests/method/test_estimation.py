import warnings

import numpy as np
import pytest
from scipy.signal import lfilter

import moli
from moli.method.least_squares.estimation import fit_batch
from moli.method.least_squares.realization import realize

from systems_util import generic_indices, random_system

CASES = [(n, p, m) for p in (1, 2, 3) for m in (1, 2, 3) for n in (p, min(8, p + 3), 8)]
# Three filters of different character (complex slow, real fast, complex fast). The
# bound below is round-off times the regression's condition number; eight clustered
# slow roots (e.g. wc = 0.08) push that to ~1e10 and the error to ~1e-6, so such
# filters are exercised by the looser noisy-data tests instead.
FILTERS = [(0.3, 0.7), (1.0, 1.1), (0.6, 0.9)]


def _noise_free(system: moli.StateSpaceModel, N: int, seed: int) -> moli.IOData:
    u = np.random.default_rng(seed).standard_normal((N, system.m))
    return moli.IOData(system.simulate(u), u)


@pytest.mark.parametrize("n, p, m", CASES)
def test_exact_recovery_of_markov_parameters(n, p, m):
    rng = np.random.default_rng(100 * n + 10 * p + m)
    system = random_system(n, p, m, rng)
    data = _noise_free(system, 400, seed=n + p + m)
    indices = generic_indices(n, p)
    truth = system.markov(22)[1:]
    for wc, zeta in FILTERS:
        with warnings.catch_warnings():
            # noise-free multi-output data make the observer-form parameters non-unique
            # (the fit is exact, the minimum-norm solution is one of many): expected here
            warnings.simplefilter("ignore", moli.IllConditionedWarning)
            model = moli.estimate(data, indices, moli.filter_polynomial(wc, zeta, indices))
        error = np.max(np.abs(model.markov(22)[1:] - truth)) / np.max(np.abs(truth))
        # noise-free data: the regression is exact, so only round-off (amplified by the
        # conditioning of slow filters, ~1e-11 seen) separates the Markov parameters
        assert error < 1e-8, (wc, zeta, error)


def observer_form_matrices(theta, alphas, indices, m):
    """docs/method.md §4 written out entry by entry: A_D, C_D, D, B, G."""
    p = len(indices)
    n = sum(indices)
    A_D, C_D = np.zeros((n, n)), np.zeros((p, n))
    D, B, G = np.zeros((n, p)), np.zeros((n, m)), np.zeros((p, p))
    start = 0
    for j, l in enumerate(indices):
        a = alphas[j]
        for i in range(l - 1):
            A_D[start + i + 1, start + i] = 1.0
        for i in range(l):
            A_D[start + i, start + l - 1] = -a[l - i]
        C_D[j, start + l - 1] = 1.0
        for r in range(p + m):
            for i in range(l):
                value = theta[j][r * l + i]
                if r < p:
                    D[start + i, r] = value
                else:
                    B[start + i, r - p] = value
        for i in range(j):
            G[j, i] = theta[j][(p + m) * l + i]
        start += l
    return A_D, C_D, D, B, G


@pytest.mark.parametrize("indices, m", [((2,), 1), ((3, 1), 2), ((1, 3, 2), 2), ((2, 2, 2), 3)])
def test_observer_form_is_io_equivalent_to_realization(indices, m):
    rng = np.random.default_rng(sum(indices) + m)
    p = len(indices)
    alphas = moli.divisors(moli.filter_polynomial(0.4, 0.8, indices), indices)
    theta = [0.3 * rng.standard_normal((p + m) * l + j) for j, l in enumerate(indices)]
    A, B, C = (M[0] for M in realize([t[None] for t in theta], [alphas], indices, m))
    A_D, C_D, D, B_o, G = observer_form_matrices(theta, alphas, indices, m)
    np.testing.assert_allclose(B, B_o)
    # observer form driven by the model's own output: same output, same state
    u = rng.standard_normal((60, m))
    y = moli.StateSpaceModel(A, B, C).simulate(u)
    xi = np.zeros(sum(indices))
    for k in range(60):
        y_obs = np.linalg.solve(np.eye(p) - G, C_D @ xi)
        np.testing.assert_allclose(y_obs, y[k], atol=1e-9 * (1 + np.abs(y).max()))
        xi = A_D @ xi + D @ y[k] + B_o @ u[k]
    # and each output satisfies its filtered regression exactly (paper eqs. 3-4)
    z = np.concatenate([y, u], axis=1)
    for j, l in enumerate(indices):
        w = np.column_stack(
            [lfilter(np.r_[np.zeros(l - i), 1.0], alphas[j], z[:, r]) for r in range(p + m) for i in range(l)]
        )
        fitted = w @ theta[j][: (p + m) * l] + y[:, :j] @ theta[j][(p + m) * l :]
        np.testing.assert_allclose(fitted, y[:, j], atol=1e-9 * (1 + np.abs(y).max()))


def test_batch_fit_equals_single_fits():
    rng = np.random.default_rng(3)
    system = random_system(4, 2, 2, rng)
    data = _noise_free(system, 300, 1)
    data = moli.IOData(data.y + 0.05 * rng.standard_normal(data.y.shape), data.u)
    indices = (2, 2)
    etas = [(0.2, 0.7), (0.6, 1.1)]
    z = np.concatenate([data.y, data.u], axis=1)
    alphas = [moli.divisors(moli.filter_polynomial(w, s, indices), indices) for w, s in etas]
    A, B, C, _ = fit_batch(z, indices, alphas)
    for r, (w, s) in enumerate(etas):
        single = moli.estimate(data, indices, moli.filter_polynomial(w, s, indices))
        np.testing.assert_allclose(A[r], single.A, atol=1e-10)
        np.testing.assert_allclose(C[r], single.C, atol=1e-10)


def test_estimate_does_not_touch_caller_arrays():
    rng = np.random.default_rng(4)
    y, u = rng.standard_normal((100, 2)), rng.standard_normal((100, 1))
    y0, u0 = y.copy(), u.copy()
    data = moli.IOData(y, u)
    moli.estimate(data, (1, 1), moli.filter_polynomial(0.3, 1.0, (1, 1)))
    moli.identify(data, nmax=3)
    np.testing.assert_array_equal(y, y0)
    np.testing.assert_array_equal(u, u0)


def test_bad_inputs_raise_value_errors():
    rng = np.random.default_rng(5)
    data = moli.IOData(rng.standard_normal((40, 2)), rng.standard_normal((40, 2)))
    alpha = moli.filter_polynomial(0.3, 1.0, (2, 2))
    with pytest.raises(moli.StructureError, match="one entry per output"):
        moli.estimate(data, (2,), alpha)
    with pytest.raises(moli.StructureError, match=">= 1"):
        moli.estimate(data, (0, 2), alpha)
    with pytest.raises(moli.StructureError, match="integers"):
        moli.estimate(data, (1.5, 2), alpha)
    with pytest.raises(moli.FilterError, match="degree"):
        moli.estimate(data, (3, 2), alpha)
    with pytest.raises(moli.FilterError, match="monic"):
        moli.estimate(data, (2, 2), 2 * alpha)
    with pytest.raises(moli.FilterError, match="stable"):
        moli.estimate(data, (2, 2), [1.0, -2.0, 1.1])
    with pytest.raises(moli.FilterError, match="no real root"):
        moli.estimate(data, (1, 2), np.real(np.poly([0.5 + 0.3j, 0.5 - 0.3j])))
    with pytest.raises(moli.DataError, match="too few samples"):
        moli.estimate(data, (9, 9), moli.filter_polynomial(0.3, 1.0, (9, 9)))
    with pytest.raises(moli.DataError, match="IOData"):
        moli.estimate(np.zeros((40, 4)), (2, 2), alpha)
    assert issubclass(moli.MoliError, ValueError)


def test_poor_excitation_warns():
    u = np.zeros((200, 2))
    u[:, 0] = np.random.default_rng(6).standard_normal(200)
    system = random_system(2, 1, 2, np.random.default_rng(7))
    data = moli.IOData(system.simulate(u), u)
    with pytest.warns(moli.IllConditionedWarning, match="conditioned"):
        moli.estimate(data, (2,), moli.filter_polynomial(0.3, 1.0, (2,)))
