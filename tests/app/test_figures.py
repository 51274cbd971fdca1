"""Figures of long records: min-max envelopes that cover every sample in bounded points."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import moli
from moli.app import figures

FINITE = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(values=arrays(float, st.integers(1, 400), elements=FINITE), bins=st.integers(1, 50),
       Ts=st.floats(0.01, 10.0))
def test_every_bin_spans_its_samples_least_to_largest(values, bins, Ts):
    t = np.arange(len(values)) * Ts
    edges, low, high = figures.envelope(t, values, bins)
    assert len(edges) == len(low) == len(high) <= bins + 1
    assert edges[0] == t[0] and edges[-1] == t[-1] and np.all(np.diff(edges) >= 0)
    covered = 0
    for b in range(len(edges) - 1):
        last = b == len(edges) - 2
        # the step band of bin b spans [edges[b], edges[b + 1]); the last bin includes its end
        inside = (t >= edges[b]) & ((t <= edges[b + 1]) if last else (t < edges[b + 1]))
        assert inside.any()
        # exact equality: the band's edges are samples of the bin, not interpolations
        assert low[b] == values[inside].min() and high[b] == values[inside].max()
        covered += int(inside.sum())
    assert covered == len(values)


def _record(N: int) -> tuple[moli.IOData, moli.Comparison]:
    data = moli.example_data(N=N, seed=1)
    model = moli.estimate(data, (2, 2, 2), moli.filter_polynomial(0.5, 0.7, (2, 2, 2)))
    return data, moli.compare(model, data)


def test_a_short_record_is_drawn_sample_by_sample():
    data, comparison = _record(600)
    fig = figures.measured_vs_simulated(data, comparison)
    assert len(fig.axes) == data.p
    for i, ax in enumerate(fig.axes):
        drawn = [line.get_xydata() for line in ax.get_lines()]
        assert len(drawn) == 2 and not ax.collections
        np.testing.assert_array_equal(drawn[0], np.column_stack([data.time(), data.y[:, i]]))
        np.testing.assert_array_equal(drawn[1], np.column_stack([data.time(), comparison.yhat[:, i]]))


def test_a_long_record_is_drawn_as_bounded_envelopes_that_hold_every_sample():
    N = 30 * figures.MAX_DRAWN_SAMPLES
    data, comparison = _record(N)
    fig = figures.measured_vs_simulated(data, comparison)
    overview = fig.axes[0::2]
    detail = fig.axes[1::2]
    assert len(overview) == len(detail) == data.p
    for i, ax in enumerate(overview):
        points = sum(len(line.get_xydata()) for line in ax.get_lines())
        points += sum(len(path.vertices) for band in ax.collections for path in band.get_paths())
        # two lines and one step band of ENVELOPE_BINS + 1 edges each; a step band's outline
        # has four vertices per edge at most, plus closing vertices
        assert points <= 2 * (figures.ENVELOPE_BINS + 1) + 4 * (figures.ENVELOPE_BINS + 2) + 8
        low_line, high_line = (line.get_xydata()[:, 1] for line in ax.get_lines())
        assert low_line.min() == comparison.yhat[:, i].min()
        assert high_line.max() == comparison.yhat[:, i].max()
        band = ax.collections[0].get_paths()[0].vertices[:, 1]
        assert band.min() == data.y[:, i].min() and band.max() == data.y[:, i].max()
    for i, ax in enumerate(detail):
        (measured, simulated) = ax.get_lines()
        np.testing.assert_array_equal(measured.get_ydata(), data.y[-figures.DETAIL_SAMPLES:, i])
        np.testing.assert_array_equal(simulated.get_ydata(),
                                      comparison.yhat[-figures.DETAIL_SAMPLES:, i])


@pytest.mark.parametrize("N", [1, 5])
def test_an_envelope_of_few_samples_has_one_bin_per_sample(N):
    values = np.arange(N, dtype=float)[::-1]
    edges, low, high = figures.envelope(np.arange(N, dtype=float), values, bins=10)
    np.testing.assert_array_equal(low[:-1], values)
    np.testing.assert_array_equal(high[:-1], values)
