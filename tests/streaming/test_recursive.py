"""Recursive MOLI: agreement with batch least squares, the Kalman form, chunk independence."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import moli
from moli.errors import DataError, FilterError, OptionError, StructureError
from moli.method.least_squares.estimation import filtered_regressors
from moli.method.structure.filters import divisors
from moli.streaming.recursive import RecursiveMoli
from moli.models.simulation import simulate_batch

INDICES = (2, 2, 2)
ALPHA = moli.filter_polynomial(0.5, 0.7, INDICES)


def plant(seed=1, n=6, p=3, m=3):
    """Random stable plant; 6 states and 3 outputs give generic indices (2, 2, 2)."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 0.9 / np.max(np.abs(np.linalg.eigvals(A)))
    return A, rng.standard_normal((n, m)), rng.standard_normal((p, n))


def record(N, noise=0.0, seed=2):
    A, B, C = plant()
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((N, B.shape[1]))
    y = simulate_batch(A[None], B[None], C[None], u)[0]
    return y + noise * rng.standard_normal(y.shape), u


def true_markov(count):
    A, B, C = plant()
    out, row = [], C
    for _ in range(count):
        out.append(row @ B)
        row = row @ A
    return np.array(out)


def batch_thetas(y, u, indices=INDICES, alpha=ALPHA):
    """Whole-record least squares of docs/method.md §3, by lstsq (independent of moli's solver)."""
    z = np.concatenate([y, u], axis=1)
    skip = max(indices)
    thetas = []
    for j, a in enumerate(divisors(alpha, indices)):
        phi = np.concatenate([filtered_regressors(z, a), y[:, :j]], axis=1)[skip:]
        thetas.append(np.linalg.lstsq(phi, y[skip:, j], rcond=None)[0])
    return thetas


def test_noise_free_reaches_true_and_batch_markov():
    y, u = record(1000)
    model = RecursiveMoli(INDICES, ALPHA, 3).update_many(y, u).model
    # The ridge term |theta|^2/p0 biases the estimate by O(1/(p0 N)) ~ 1e-7 here (measured
    # 1e-7 at N = 1000); 1e-6 is the required agreement.
    assert np.max(np.abs(model.markov(31)[1:] - true_markov(30))) < 1e-6
    batch = moli.estimate(moli.IOData(y, u), INDICES, ALPHA)
    assert np.max(np.abs(model.markov(31) - batch.markov(31))) < 1e-6


def test_noisy_estimate_converges_to_batch_solution():
    y, u = record(4000, noise=0.1)
    est = RecursiveMoli(INDICES, ALPHA, 3)
    gaps = []
    for N in (500, 4000):
        est.update_many(y[est.samples : N], u[est.samples : N])
        gaps.append(max(np.max(np.abs(t - b)) for t, b in zip(est.theta, batch_thetas(y[:N], u[:N]))))
    # The only difference is the prior's weight 1/p0 against N rows: the gap shrinks with N
    # and is far below the parameters' statistical spread (~1e-2 at this noise level).
    assert gaps[1] < gaps[0]
    assert gaps[1] < 1e-6


def kalman_rls(phi, y, p0, r2):
    """Textbook Kalman-form RLS (no forgetting), one sample at a time."""
    k = phi.shape[1]
    theta, P = np.zeros(k), p0 * np.eye(k)
    for row, target in zip(phi, y):
        gain = P @ row / (row @ P @ row + r2)
        theta = theta + gain * (target - row @ theta)
        P = P - np.outer(gain, row @ P)
    return theta, P


def test_matches_textbook_kalman_recursion():
    y, u = record(300, noise=0.1)
    est = RecursiveMoli(INDICES, ALPHA, 3, noise_variance=0.5, p0=10.0).update_many(y, u)
    z = np.concatenate([y, u], axis=1)
    for j, a in enumerate(divisors(ALPHA, INDICES)):
        phi = np.concatenate([filtered_regressors(z, a), y[:, :j]], axis=1)[2:]
        theta, P = kalman_rls(phi, y[2:, j], p0=10.0, r2=0.5)
        # Two exact algorithms in floating point over 300 steps: agreement to ~1e-12 relative.
        assert np.allclose(est.theta[j], theta, rtol=1e-9, atol=1e-10)
        assert np.allclose(est.covariance[j], P, rtol=1e-8, atol=1e-12)


def test_forgetting_solves_weighted_least_squares():
    y, u = record(400, noise=0.1)
    lam, p0 = 0.98, 100.0
    est = RecursiveMoli(INDICES, ALPHA, 3, forgetting=lam, p0=p0).update_many(y, u)
    z = np.concatenate([y, u], axis=1)
    a = divisors(ALPHA, INDICES)[1]
    phi = np.concatenate([filtered_regressors(z, a), y[:, :1]], axis=1)[2:]
    N, k = phi.shape
    w = np.sqrt(lam ** np.arange(N - 1, -1, -1))
    # information lam^N/p0 + (1 - lam^N)/p0 = 1/p0 from prior and floor together
    rows = np.vstack([phi * w[:, None], np.eye(k) / np.sqrt(p0)])
    target = np.concatenate([y[2:, 1] * w, np.zeros(k)])
    expected = np.linalg.lstsq(rows, target, rcond=None)[0]
    assert np.allclose(est.theta[1], expected, rtol=1e-9, atol=1e-10)


@settings(max_examples=15, deadline=None)
@given(st.lists(st.integers(1, 90), min_size=1, max_size=8))
def test_chunking_does_not_change_the_estimate(sizes):
    y, u = record(400, noise=0.1)
    whole = RecursiveMoli(INDICES, ALPHA, 3, forgetting=0.99).update_many(y, u)
    pieces = RecursiveMoli(INDICES, ALPHA, 3, forgetting=0.99)
    bounds = np.minimum(np.cumsum([0] + sizes), 400)
    for a, b in zip(bounds[:-1], bounds[1:]):
        pieces.update_many(y[a:b], u[a:b])
    for k in range(bounds[-1], 400):  # the rest one sample at a time
        pieces.update(y[k], u[k])
    assert pieces.samples == 400
    # Same rows, grouped into different QR blocks: round-off only.
    for t1, t2 in zip(whole.theta, pieces.theta):
        assert np.allclose(t1, t2, rtol=1e-9, atol=1e-11)


def test_covariance_stays_bounded_and_definite_without_excitation():
    y, u = record(2000, noise=0.1)
    y[500:], u[500:] = 0.0, 0.0
    est = RecursiveMoli(INDICES, ALPHA, 3, forgetting=0.95, p0=1e3).update_many(y, u)
    for P in est.covariance:
        eig = np.linalg.eigvalsh(P)
        assert np.array_equal(P, P.T)
        # 1500 unexcited steps at lambda = 0.95 would blow plain forgetting up by 0.95^-1500;
        # the stabilised form decays the information toward 1/p0, so P <= p0 I.
        assert eig.min() > 0 and eig.max() <= 1e3 * (1 + 1e-9)


def test_caller_arrays_are_untouched():
    y, u = record(50)
    y0, u0 = y.copy(), u.copy()
    RecursiveMoli(INDICES, ALPHA, 3).update_many(y, u)
    assert np.array_equal(y, y0) and np.array_equal(u, u0)


@pytest.mark.parametrize(
    "kwargs, error",
    [
        ({"forgetting": 0.0}, OptionError),
        ({"forgetting": 1.5}, OptionError),
        ({"noise_variance": -1.0}, OptionError),
        ({"p0": 0.0}, OptionError),
    ],
)
def test_bad_options_raise(kwargs, error):
    with pytest.raises(error):
        RecursiveMoli(INDICES, ALPHA, 3, **kwargs)


def test_bad_structure_filter_and_data_raise():
    with pytest.raises(StructureError):
        RecursiveMoli((2, 0, 2), ALPHA, 3)
    with pytest.raises(FilterError):
        RecursiveMoli(INDICES, [1.0, -2.5, 1.0], 3)  # root at 2: unstable
    est = RecursiveMoli(INDICES, ALPHA, 3)
    y, u = record(20)
    with pytest.raises(DataError, match=r"\(N, 3\)"):
        est.update_many(y[:, :2], u)
    y[3, 1] = np.nan
    with pytest.raises(DataError, match="NaN"):
        est.update_many(y, u)
    with pytest.raises(DataError):
        est.update([1.0, 2.0], [0.0, 0.0, 0.0])
    assert est.samples == 0
    assert isinstance(OptionError("x"), ValueError)
