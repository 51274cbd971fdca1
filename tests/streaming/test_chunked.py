"""Chunked batch estimation equals the whole-record least-squares solution."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import moli
from moli.streaming.chunked import ChunkedEstimator
from moli.errors import DataError, FilterError, OptionError, StructureError
from moli.method.least_squares.estimation import filtered_regressors
from moli.method.least_squares.realization import realize
from moli.method.structure.filters import divisors

from systems_util import plant_record

INDICES = (2, 2, 2)
ALPHA = moli.filter_polynomial(0.5, 0.7, INDICES)


def record(N, noise, seed=3):
    return plant_record(N, noise, seed)


def whole_record_markov(y, u):
    """docs/method.md §3 on the whole record with lstsq, realized by moli's realize."""
    z = np.concatenate([y, u], axis=1)
    alphas = divisors(ALPHA, INDICES)
    thetas = []
    for j, a in enumerate(alphas):
        phi = np.concatenate([filtered_regressors(z, a), y[:, :j]], axis=1)[2:]
        thetas.append(np.linalg.lstsq(phi, y[2:, j], rcond=None)[0][None])
    A, B, C = realize(thetas, [alphas], INDICES, 3)
    return moli.StateSpaceModel(A[0], B[0], C[0]).markov(30)


@settings(max_examples=10, deadline=None)
@given(st.lists(st.integers(1, 700), min_size=1, max_size=6))
def test_any_chunking_gives_the_whole_record_solution(sizes):
    y, u, _ = record(1500, noise=0.1)
    est = ChunkedEstimator(INDICES, ALPHA, 3)
    bounds = np.minimum(np.cumsum([0] + sizes + [1500]), 1500)
    for a, b in zip(bounds[:-1], bounds[1:]):
        est.add(y[a:b], u[a:b])
    # Both are backward-stable least-squares solutions of a problem with condition ~1e3:
    # they agree to ~1e-12 relative; the Markov parameters are O(1).
    assert np.max(np.abs(est.model().markov(30) - whole_record_markov(y, u))) < 1e-9


def test_noise_free_gives_the_true_markov_parameters():
    y, u, (A, B, C) = record(800, noise=0.0)
    est = ChunkedEstimator(INDICES, ALPHA, 3).add(y[:333], u[:333]).add(y[333:], u[333:])
    truth = np.array([C @ np.linalg.matrix_power(A, k) @ B for k in range(20)])
    with pytest.warns(moli.IllConditionedWarning):  # exact data: the g_ji are not unique
        model = est.model()
    # Exact fit (residuals at round-off): Markov parameters to round-off, cf. docs/method.md §4.
    assert np.max(np.abs(model.markov(21)[1:] - truth)) < 1e-9


def test_too_few_samples_and_bad_input_raise():
    y, u, _ = record(30, noise=0.1)
    est = ChunkedEstimator(INDICES, ALPHA, 3).add(y[:10], u[:10])
    with pytest.raises(DataError, match="too few samples"):
        est.model()
    with pytest.raises(DataError):
        est.add(y[:5], u[:4])
    with pytest.raises(DataError):
        est.add(np.full((3, 3), np.inf), u[:3])
    with pytest.raises(StructureError):
        ChunkedEstimator([2, 0, 2], ALPHA, 3)
    with pytest.raises(OptionError):
        ChunkedEstimator(INDICES, ALPHA, 0)
    with pytest.raises(FilterError):
        ChunkedEstimator(INDICES, [1.0, 0.1], 3)  # degree 1, list needs 2
    assert est.samples == 10
