"""Time stamps kept as given: checked on construction, carried by every derived record, read from files."""

from __future__ import annotations

import warnings
from datetime import datetime, timedelta

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import moli
from moli import DataError, IrregularSamplingWarning, read_data
from moli.data import from_columns, remove_outliers

N = 30


def jittered(N: int = N, seed: int = 0, spread: float = 0.5, period: float = 1e-3) -> np.ndarray:
    """Stamps whose steps are drawn from ``1 - spread`` to ``1 + spread`` periods (an irregular logger)."""
    steps = np.random.default_rng(seed).uniform(1 - spread, 1 + spread, N)
    return 100.0 + np.cumsum(steps) * period


def stamped(times: np.ndarray, **kwargs) -> moli.IOData:
    """A record whose input is its own sample index, so each sample says where it came from."""
    index = np.arange(times.size, dtype=float)
    return moli.IOData(np.column_stack([index, -index]), index, times=times, **kwargs)


def test_the_stamps_are_a_read_only_copy_and_give_the_period():
    times = jittered()
    given_times = times.copy()
    data = stamped(times)
    np.testing.assert_array_equal(data.times, given_times)
    assert not np.shares_memory(data.times, times) and not data.times.flags.writeable
    times[0] = -1.0                                   # the caller's array is theirs
    assert data.times[0] == given_times[0]
    assert data.Ts == np.median(np.diff(given_times))  # one path, no rounding between them
    np.testing.assert_array_equal(data.time(), given_times)
    assert data.time().flags.writeable                 # a fresh array, as without stamps


def test_the_period_is_the_median_step_within_segments_unless_stated():
    # two experiments, the second's clock restarts and steps by 2: the median of the steps
    # 1, 1, 2, 2 is 1.5, and would be 1 if the restart (-2) counted as a step
    times = np.r_[0.0, 1.0, 2.0, 0.0, 2.0, 4.0]
    data = stamped(times, segment_starts=[0, 3])
    assert data.Ts == 1.5 and data.n_segments == 2
    assert stamped(times, segment_starts=[0, 3], Ts=0.5).Ts == 0.5
    assert moli.IOData(np.zeros(4), np.ones(4)).Ts == 1.0 and moli.IOData(np.zeros(4), np.ones(4)).times is None
    np.testing.assert_array_equal(moli.IOData(np.zeros(4), np.ones(4), Ts=0.5).time(), [0, 0.5, 1.0, 1.5])


@pytest.mark.parametrize("times, message", [
    (np.arange(5.0), r"times must have shape \(6,\), one stamp per sample of y and u, got shape \(5,\)"),
    (np.r_[0.0, 1, 2, np.nan, 4, 5], "times must be finite: sample 3 has time nan"),
    (np.r_[0.0, 1, 2, 3, np.inf, 5], "times must be finite: sample 4 has time inf"),
    (np.r_[0.0, 1, 2, 2, 4, 5], "increase strictly within each segment: sample 3 has time 2 after 2 at sample 2"),
    (np.r_[0.0, 1, 2, 3, 0.5, 5], "increase strictly within each segment: sample 4 has time 0.5 after 3 at sample 3"),
    (np.arange(6).astype("datetime64[s]"), "times must be numbers .* got datetime64"),
    ("abcdef", "times must be an array of real"),
])
def test_bad_stamps_name_the_argument_and_the_sample(times, message):
    with pytest.raises(DataError, match=message):
        moli.IOData(np.zeros(6), np.ones(6), times=times)


def test_stamps_restart_only_at_a_segment_start_and_need_a_step_for_the_period():
    times = np.r_[0.0, 1, 2, 0, 1, 2]
    assert stamped(times, segment_starts=[0, 3]).n_segments == 2
    with pytest.raises(DataError, match="sample 3 has time 0 after 2"):
        stamped(times)
    with pytest.raises(DataError, match="no step within a segment.*Ts="):
        stamped(np.r_[5.0])
    assert stamped(np.r_[5.0], Ts=0.1).times.tolist() == [5.0]


def samples(data: moli.IOData) -> np.ndarray:
    """Which samples of :func:`stamped`'s record ``data`` holds."""
    return np.round(data.u[:, 0] + data.u_offset[0]).astype(int)   # a centred record too


def test_every_derived_record_keeps_the_stamps_of_its_samples():
    times = jittered(N)
    data = stamped(times, segment_starts=[0, 12])
    derived = {
        "slice": data[5:20], "head": data.split(9)[0],
        "tail": data.split(9)[1], "fraction": data.split(0.4)[1], "drop": data.drop(4, 15),
        "segment 1": data.segments[1], "centred": data.remove_means(),
        "longest": moli.data.iodata.longest_segment(data), "outliers": remove_outliers(data),
    }
    for name, part in derived.items():
        np.testing.assert_array_equal(part.times, times[samples(part)], err_msg=name)
        assert part.Ts == data.Ts, name                # the period stays the record's
    assert derived["drop"].bounds == ((0, 4), (4, 4 + N - 15))
    strided = stamped(times)[3:25:4]                   # one segment: a step is allowed
    np.testing.assert_array_equal(strided.times, times[3:25:4])
    with pytest.raises(DataError, match="forwards only"):
        stamped(times)[::-1]


def test_merge_keeps_each_records_stamps_and_refuses_a_mix():
    a, b = stamped(jittered(N, 1)), stamped(jittered(20, 2), Ts=stamped(jittered(N, 1)).Ts)
    merged = moli.merge([a, b])
    np.testing.assert_array_equal(merged.times, np.r_[a.times, b.times])
    assert merged.bounds == ((0, N), (N, N + 20))
    plain = moli.IOData(a.y, a.u, a.Ts)
    for records, message in (([a, plain], "record 1 has no time stamps and record 0 has"),
                             ([plain, a], "record 1 has time stamps and record 0 has no")):
        with pytest.raises(DataError, match=message):
            moli.merge(records)
    assert moli.merge([plain, plain]).times is None


def test_a_missing_sample_takes_its_stamp_with_it():
    times = jittered(10)
    y = np.arange(10.0)
    y[[3, 7]] = np.nan
    data = moli.IOData(y, np.ones(10), times=times)
    np.testing.assert_array_equal(data.times, np.delete(times, [3, 7]))
    assert data.bounds == ((0, 3), (3, 6), (6, 8))


def test_the_repr_counts_irregular_steps_only():
    regular = stamped(0.5 * np.arange(N))
    assert "times" not in repr(regular) and regular.Ts == 0.5
    times = 0.5 * np.arange(N)
    times[10:] += 0.2                                  # one step of 0.7: 40 % off
    assert repr(stamped(times)).endswith(", times: 1 irregular step)")
    times[20:] += 0.2
    assert repr(stamped(times)).endswith(", times: 2 irregular steps)")


def write_csv(path, stamps, u, y) -> None:
    """A CSV of ``time,u,y``; numbers written to their last digit, so they read back exactly."""
    cells = [[t if isinstance(t, str) else repr(float(t)), repr(float(a)), repr(float(b))]
             for t, a, b in zip(stamps, u, y)]
    path.write_text("time,u,y\n" + "".join(",".join(row) + "\n" for row in cells))


def test_a_jittered_csv_gives_the_stamps_of_its_time_column(tmp_path):
    stamps = jittered(N, 3, spread=0.2)                # jitter: every step within 1.5 periods
    stamps[20:] += 0.01                                # a gap of about 10 periods
    u, y = np.sin(np.arange(N)), np.cos(np.arange(N))
    write_csv(tmp_path / "rec.csv", stamps, u, y)
    with pytest.warns(IrregularSamplingWarning) as caught:
        data = read_data(tmp_path / "rec.csv", ["u"], ["y"])
    np.testing.assert_array_equal(data.times, stamps)  # repr of each float, read back exactly
    assert data.Ts == np.median(np.diff(stamps))       # as before: all steps, gap included
    assert data.bounds == ((0, 20), (20, N))
    assert [gap.index for gap in caught[0].message.gaps if gap.missing] == [20]
    np.testing.assert_array_equal(data.u[:, 0], u)


def test_date_times_become_seconds_since_the_first_stamp(tmp_path):
    start = datetime(2024, 5, 1, 12)
    seconds = np.r_[0.0, 0.25, 0.5, 0.75, 1.25, 1.5]   # one step of 2 periods: a gap
    write_csv(tmp_path / "rec.csv", [(start + timedelta(seconds=s)).isoformat() for s in seconds],
              np.arange(6.0), np.ones(6))
    with pytest.warns(IrregularSamplingWarning):
        data = read_data(tmp_path / "rec.csv", ["u"], ["y"])
    np.testing.assert_array_equal(data.times, seconds)  # quarter seconds are exact in binary
    assert data.Ts == 0.25 and data.bounds == ((0, 4), (4, 6))


def test_a_record_without_a_time_column_has_no_stamps_and_empty_cells_drop_theirs():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", moli.SamplingPeriodWarning)
        assert from_columns({"u": [1.0, 2.0], "y": [0.0, 1.0]}, ["u"], ["y"]).times is None
    data = from_columns({"t": [0.0, 0.1, 0.2, 0.3], "u": [1.0, np.nan, 2.0, 3.0], "y": [0.0] * 4}, ["u"], ["y"])
    np.testing.assert_array_equal(data.times, [0.0, 0.2, 0.3])
    assert data.bounds == ((0, 1), (1, 3))


@settings(max_examples=60, deadline=None)
@given(
    steps=st.lists(st.floats(1e-3, 1e3), min_size=2, max_size=40),
    start=st.floats(-1e6, 1e6),
    at=st.floats(0.01, 0.99),
)
def test_split_then_merge_gives_back_the_stamps(steps, start, at):
    times = start + np.cumsum(steps)
    if not np.all(np.diff(times) > 0):                 # steps lost to rounding at a large start
        return
    data = stamped(times, Ts=1.0)
    k = min(max(int(at * data.N), 1), data.N - 1)
    head, tail = data.split(k)
    joined = moli.merge([head, tail])
    np.testing.assert_array_equal(joined.times, times)
    np.testing.assert_array_equal(joined.segments[1].times, times[k:])
