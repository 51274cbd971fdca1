"""Chunks estimated apart and merged give the single ChunkedEstimator's estimate.

Here the steps of estimate_chunks run in this process; tests/test_dask_cluster.py runs
them on a Dask LocalCluster.
"""

from functools import partial

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import moli
from moli.errors import DataError, OptionError, StructureError
from moli.fleets.chunk_reduction import estimate_chunks
from moli.streaming.chunked import ChunkedEstimator

from systems_util import plant_record

N = 1500
Y, U, _ = plant_record(N, noise=0.1, seed=3)
# (3, 2, 1): three filter degrees, so three groups of states carried across chunks
INDICES = (3, 2, 1)
ALPHA = moli.filter_polynomial(0.5, 0.7, INDICES)


def piece(a: int, b: int) -> tuple[np.ndarray, np.ndarray]:
    return Y[a:b], U[a:b]


def chunks_at(bounds) -> list:
    return [partial(piece, a, b) for a, b in zip(bounds[:-1], bounds[1:])]


def single(bounds, indices=INDICES) -> ChunkedEstimator:
    """The independent reference: one estimator fed the chunks in turn."""
    est = ChunkedEstimator(indices, moli.filter_polynomial(0.5, 0.7, indices), 3)
    for a, b in zip(bounds[:-1], bounds[1:]):
        est.add(Y[a:b], U[a:b])
    return est


def relative_gap(first: moli.StateSpaceModel, second: moli.StateSpaceModel) -> float:
    return max(np.max(np.abs(getattr(first, n) - getattr(second, n))) / np.max(np.abs(getattr(first, n)))
               for n in "ABC")


@settings(max_examples=15, deadline=None)
@given(st.lists(st.integers(1, 400), min_size=1, max_size=8))
def test_any_chunking_matches_the_single_estimator(sizes):
    # sizes from 1 sample up: chunks shorter than the filters' degree, and chunks
    # inside the first max(indices) samples that only charge the filters
    bounds = np.unique(np.minimum(np.cumsum([0, *sizes, N]), N))
    reduced = estimate_chunks(chunks_at(bounds), INDICES, ALPHA, 3)
    reference = single(bounds)
    assert reduced.samples == reference.samples == N
    # Both are backward-stable QR solutions of the same problem (condition ~1e3), the
    # chunk boundaries' states equal to round-off: 1e-10 relative leaves a wide margin.
    assert relative_gap(reference.model(), reduced.model()) < 1e-10
    for mine, theirs in zip(reduced.filter_states(), reference.filter_states()):
        np.testing.assert_allclose(mine, theirs, rtol=1e-12, atol=1e-12)


def test_reading_once_gives_the_same_estimate():
    chunks = chunks_at([0, 200, 700, N])
    twice = estimate_chunks(chunks, INDICES, ALPHA, 3)
    once = estimate_chunks(chunks, INDICES, ALPHA, 3, read_once=True)
    np.testing.assert_array_equal(once.model().A, twice.model().A)  # the same arithmetic
    with pytest.raises(OptionError, match="read_once must be True or False"):
        estimate_chunks(chunks, INDICES, ALPHA, 3, read_once="yes")


def test_empty_chunks_change_nothing():
    bounds = [0, 300, 300, 900, N]  # an empty chunk between two others
    reduced = estimate_chunks(chunks_at(bounds), INDICES, ALPHA, 3)
    reference = single([0, 300, 900, N])
    # as in the test above: equal to round-off
    assert relative_gap(reference.model(), reduced.model()) < 1e-10


def test_generic_structure_recovers_the_plant_markov_parameters():
    y, u, (A, B, C) = plant_record(900, noise=0.0, seed=5)
    chunks = [partial(lambda a: (y[a:a + 300], u[a:a + 300]), a) for a in range(0, 900, 300)]
    alpha = moli.filter_polynomial(0.5, 0.7, (2, 2, 2))
    with pytest.warns(moli.IllConditionedWarning):  # exact data: the g_ji are not unique
        model = estimate_chunks(chunks, (2, 2, 2), alpha, 3).model()
    truth = np.array([C @ np.linalg.matrix_power(A, k) @ B for k in range(20)])
    # noise-free data from a system with these indices: an exact fit (cf. test_chunked)
    assert np.max(np.abs(model.markov(21)[1:] - truth)) < 1e-9


# The free response of the filter state grows to 1.8 times its start at wc = 0.5, and
# to 2e4 times at wc = 0.005 (roots within 0.01 of 1: a state map far from normal);
# the round-off of either road to the states grows with it.
@pytest.mark.parametrize("wc, tolerance", [(0.5, 1e-12), (0.005, 1e-9)])
@pytest.mark.parametrize("length", [1, 2, 3, 7, 400, 5000])
def test_state_map_is_the_exact_affine_map_of_the_filter_states(length, wc, tolerance):
    alpha = moli.filter_polynomial(wc, 0.7, INDICES)
    head = ChunkedEstimator(INDICES, alpha, 3).add(Y[:100], U[:100])
    start = head.filter_states()
    stop = 100 + length
    carried = ChunkedEstimator(INDICES, alpha, 3).resume(100, start).add(Y[100:stop], U[100:stop])
    maps = head.state_map(Y[100:stop], U[100:stop])
    assert head.samples == 100  # state_map absorbs nothing
    for (T, s), S, after in zip(maps, start, carried.filter_states()):
        # the filters are linear: the same states by two roads, to round-off
        np.testing.assert_allclose(T @ S + s, after, rtol=0, atol=tolerance * np.max(np.abs(after)))


def test_merge_needs_consecutive_parts_of_the_same_structure():
    first = ChunkedEstimator(INDICES, ALPHA, 3).add(Y[:200], U[:200])
    gap = ChunkedEstimator(INDICES, ALPHA, 3).resume(300, first.filter_states()).add(Y[300:400], U[300:400])
    with pytest.raises(DataError, match="starts at sample 300, but this estimator ends at 200"):
        first.merge(gap)
    other = ChunkedEstimator((3, 3, 3), ALPHA, 3)
    with pytest.raises(OptionError, match="same indices, filter and inputs"):
        first.merge(other)
    with pytest.raises(OptionError, match="later must be a ChunkedEstimator"):
        first.merge("later")
    before = first.model().A
    first.merge(ChunkedEstimator(INDICES, ALPHA, 3).resume(200, first.filter_states()).add(Y[200:], U[200:]))
    np.testing.assert_array_equal(first.model().A, before)  # merging changes neither part


def test_resume_checks_its_arguments():
    est = ChunkedEstimator(INDICES, ALPHA, 3)
    states = est.filter_states()
    with pytest.raises(OptionError, match="start must be a sample count"):
        est.resume(-1, states)
    with pytest.raises(DataError, match="states must be finite arrays of shapes"):
        est.resume(5, states[:2])
    with pytest.raises(DataError, match="states must be finite"):
        est.resume(5, [np.full_like(s, np.nan) for s in states])
    est.add(Y[:10], U[:10])
    with pytest.raises(OptionError, match="before it absorbs any sample"):
        est.resume(10, states)


def test_estimate_chunks_rejects_bad_arguments_before_reading():
    chunks = chunks_at([0, 500, N])
    with pytest.raises(DataError, match="non-empty sequence"):
        estimate_chunks([], INDICES, ALPHA, 3)
    with pytest.raises(DataError, match=r"chunks\[1\] must be callable"):
        estimate_chunks([chunks[0], (Y, U)], INDICES, ALPHA, 3)
    with pytest.raises(StructureError):
        estimate_chunks(chunks, (2, 0, 2), ALPHA, 3)
    with pytest.raises(OptionError, match="client must be"):
        estimate_chunks(chunks, INDICES, ALPHA, 3, client="tcp://nowhere:8786")
    with pytest.raises(DataError, match=r"must return \(y, u\)"):
        estimate_chunks([lambda: Y], INDICES, ALPHA, 3)
    with pytest.raises(DataError, match="shape"):
        estimate_chunks([lambda: (Y[:, :2], U)], INDICES, ALPHA, 3)


def test_a_long_chunks_state_map_filters_only_its_tail():
    # wc = 0.5: the free response is below 1e-17 after a few thousand samples, so a chunk
    # of 20,000 is mapped from its tail; the map must still be the filters' own to round-off
    from moli.streaming.recursive import _reach

    long_y, long_u, _ = plant_record(20_100, noise=0.1, seed=4)
    alpha = moli.filter_polynomial(0.5, 0.7, INDICES)
    head = ChunkedEstimator(INDICES, alpha, 3).add(long_y[:100], long_u[:100])
    start = head.filter_states()
    carried = ChunkedEstimator(INDICES, alpha, 3).resume(100, start).add(long_y[100:], long_u[100:])
    maps = head.state_map(long_y[100:], long_u[100:])
    assert all(_reach(regressors, 20_000) < 20_000 for _, regressors, _ in head._bank._groups)
    for (T, s), S, after in zip(maps, start, carried.filter_states()):
        np.testing.assert_allclose(T @ S + s, after, rtol=0, atol=1e-12 * np.max(np.abs(after)))
