"""Records of several segments: missing samples, merge, drop, slices."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import moli
from moli.data import fingerprint, read_data


def _record(N: int, seed: int = 0, **kwargs) -> moli.IOData:
    rng = np.random.default_rng(seed)
    return moli.IOData(rng.standard_normal((N, 2)), rng.standard_normal(N), Ts=0.5, **kwargs)


def test_rows_with_a_nan_are_removed_and_end_a_segment():
    y = np.arange(10.0)[:, None] * [1.0, 10.0]
    u = np.arange(10.0)
    y[3, 1] = np.nan          # one channel missing is enough
    u[4] = np.nan
    data = moli.IOData(y, u)
    assert data.N == 8 and data.n_segments == 2 and data.bounds == ((0, 3), (3, 8))
    np.testing.assert_array_equal(data.u[:, 0], [0, 1, 2, 5, 6, 7, 8, 9])
    assert [s.N for s in data.segments] == [3, 5]
    assert repr(data).endswith("inputs=['u1'], segments=2)")
    np.testing.assert_array_equal(y[3], np.array([3.0, np.nan]))   # the caller's arrays untouched


def test_missing_samples_at_the_ends_only_trim():
    u = np.array([np.nan, 1.0, 2.0, 3.0, np.nan])
    data = moli.IOData(np.zeros(5), u)
    assert data.n_segments == 1 and data.N == 3 and repr(data).endswith("inputs=['u1'])")


def test_one_segment_records_are_as_before():
    data = _record(20)
    assert data.n_segments == 1 and data.bounds == ((0, 20),) and data.segment_starts == (0,)
    assert data.segments[0].N == 20
    head, tail = data.split(12)
    assert head.n_segments == tail.n_segments == 1
    assert data[::2].N == 10     # a step is still allowed on one segment


def test_merge_keeps_each_records_segments_in_order():
    a, b = _record(30, 1), _record(20, 2).drop(5, 8)
    merged = moli.merge([a, b])
    assert merged.bounds == ((0, 30), (30, 35), (35, 47))
    np.testing.assert_array_equal(merged.y, np.concatenate([a.y, b.y]))
    assert merged.Ts == a.Ts and merged.output_names == a.output_names
    for part, original in zip(merged.segments, [a, *b.segments]):
        np.testing.assert_array_equal(part.u, original.u)


@pytest.mark.parametrize("other, message", [
    (lambda: moli.IOData(np.zeros((9, 3)), np.zeros(9), Ts=0.5), "record 1 has 3 outputs and 1 inputs"),
    (lambda: moli.IOData(np.zeros((9, 2)), np.zeros(9), Ts=0.5, output_names=["a", "b"]),
     r"record 1 has channels \['a', 'b'\]"),
    (lambda: moli.IOData(np.zeros((9, 2)), np.zeros(9), Ts=0.25), r"record 1 has Ts = 0.25, record 0 has Ts = 0.5"),
    (lambda: _record(9, 3).remove_means(), "record 1 has other offsets"),
    (lambda: np.zeros((9, 3)), "record 1 is a ndarray, not an IOData"),
])
def test_merge_names_the_record_that_differs(other, message):
    with pytest.raises(moli.DataError, match=message):
        moli.merge([_record(10), other()])


def test_merge_needs_a_list_of_records():
    for bad in ([], _record(5), None):
        with pytest.raises(moli.DataError, match="non-empty list"):
            moli.merge(bad)


def test_drop_checks_its_arguments():
    data = _record(10)
    for start, stop in [(3, 3), (-1, 4), (2, 11), (0, 10), (1.0, 3)]:
        with pytest.raises(moli.DataError, match="drop"):
            data.drop(start, stop)


def test_bad_segment_starts_and_strided_slices_raise():
    for starts in ([1, 4], [0, 4, 4], [0, 12], [0, 2.5], "ab"):
        with pytest.raises(moli.DataError, match="segment_starts"):
            _record(10, segment_starts=starts)
    with pytest.raises(moli.DataError, match="step 1"):
        _record(10, segment_starts=[0, 4])[::2]


def _boundaries(data: moli.IOData) -> set[int]:
    return set(data.segment_starts[1:])


@settings(max_examples=60, deadline=None)
@given(
    N=st.integers(2, 40),
    missing=st.lists(st.integers(0, 39), max_size=6),
    cut=st.tuples(st.integers(0, 39), st.integers(1, 40)),
    window=st.tuples(st.integers(0, 39), st.integers(1, 40)),
)
def test_nan_drop_slice_and_merge_invariants(N, missing, cut, window):
    # each sample carries its own index, so the samples kept say where the boundaries must be
    index = np.arange(N, dtype=float)
    y = index.copy()
    y[[k for k in missing if k < N]] = np.nan
    if np.isnan(y).all():
        return
    data = moli.IOData(y, index)
    kept = data.u[:, 0]
    np.testing.assert_array_equal(kept, index[~np.isnan(y)])
    # a boundary exactly where a gap in the original indices is
    assert _boundaries(data) == {k for k in range(1, data.N) if kept[k] - kept[k - 1] > 1}
    assert sum(s.N for s in data.segments) == data.N
    np.testing.assert_array_equal(np.concatenate([s.u for s in data.segments]), data.u)

    a, b = sorted((min(window[0], data.N - 1), min(window[1], data.N)))
    if b > a:
        part = data[a:b]
        np.testing.assert_array_equal(part.u, data.u[a:b])
        assert _boundaries(part) == {k - a for k in _boundaries(data) if a < k < b}

    start, stop = sorted((min(cut[0], data.N - 1), min(cut[1], data.N)))
    if stop > start and (start, stop) != (0, data.N):
        dropped = data.drop(start, stop)
        np.testing.assert_array_equal(dropped.u, np.concatenate([data.u[:start], data.u[stop:]]))
        expected = {k for k in _boundaries(data) if k < start} | {k - (stop - start) for k in _boundaries(data)
                                                                  if k > stop}
        if 0 < start and stop < data.N:
            expected.add(start)
        assert _boundaries(dropped) == expected

    merged = moli.merge([data, data])
    assert merged.n_segments == 2 * data.n_segments
    assert _boundaries(merged) == _boundaries(data) | {data.N} | {k + data.N for k in _boundaries(data)}


def test_remove_means_spans_all_segments():
    data = moli.merge([_record(30, 1), moli.IOData(np.full((10, 2), 5.0), np.ones(10), Ts=0.5)])
    centred = data.remove_means()
    np.testing.assert_allclose(centred.y_offset, data.y.mean(axis=0))
    np.testing.assert_allclose(centred.y.mean(axis=0), 0.0, atol=1e-14)
    assert centred.bounds == data.bounds


def test_fingerprint_tells_the_segments_apart():
    data = _record(20)
    assert fingerprint(data) != fingerprint(moli.IOData(data.y, data.u, 0.5, segment_starts=[0, 7]))
    assert fingerprint(data) == fingerprint(moli.IOData(data.y, data.u, 0.5))


def test_csv_with_empty_cells_reads_as_segments(tmp_path):
    path = tmp_path / "plant.csv"
    rows = ["time,valve,level"] + [f"{0.5 * k},{k},{2 * k}" for k in range(8)]
    rows[3] = "1.0,,4"         # sample 2 lacks the input
    rows[6] = "2.5,5,"         # sample 5 lacks the output
    path.write_text("\n".join(rows) + "\n")
    data = read_data(path, ["valve"], ["level"])
    assert data.Ts == 0.5 and data.input_names == ("valve",) and data.output_names == ("level",)
    assert data.bounds == ((0, 2), (2, 4), (4, 6))
    np.testing.assert_array_equal(data.u[:, 0], [0, 1, 3, 4, 6, 7])


def test_a_dataframe_round_trip_keeps_the_boundaries():
    pytest.importorskip("pandas")
    data = moli.merge([_record(6, 1), _record(4, 2)])
    back = moli.from_dataframe(moli.to_dataframe(data), inputs=["u1"], outputs=["y1", "y2"])
    assert back.bounds == data.bounds and back.Ts == data.Ts
    np.testing.assert_array_equal(back.y, data.y)


def test_the_excitation_check_takes_no_window_across_a_boundary():
    # two experiments that each hold the input still: one step between them, if the
    # boundary were ignored, would pass for an input exciting two lags
    held = [moli.IOData(np.random.default_rng(k).standard_normal(100), np.full(100, level))
            for k, level in enumerate((1.0, -1.0))]
    merged = moli.merge(held)
    joined = moli.IOData(merged.y, merged.u)
    assert "excitation" in [issue.kind for issue in moli.check_data(merged, nmax=1)]
    assert "excitation" not in [issue.kind for issue in moli.check_data(joined, nmax=1)]
