"""Time columns: the period from time stamps, irregular steps and gaps, and Ts checks."""

from __future__ import annotations

import warnings
from datetime import datetime, timedelta, timezone

import numpy as np
import pytest

from moli import DataError, IrregularSamplingWarning, read_data
from moli.data import SamplingGap, find_gaps, from_columns

N = 40
U = np.arange(N, dtype=float) % 7
Y = np.cos(np.arange(N))


def write_stamped(path, stamps, head="timestamp") -> None:
    lines = [f"{head},u,y"] + [f"{t},{float(u)!r},{float(y)!r}" for t, u, y in zip(stamps, U, Y)]
    path.write_text("\n".join(lines) + "\n")


def iso(start: datetime, seconds) -> list[str]:
    return [(start + timedelta(seconds=float(s))).isoformat() for s in seconds]


def strictly(call):
    """Run ``call`` with every warning an error: proves that none is given."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return call()


def test_find_gaps_lists_each_irregular_step():
    times = [0.0, 1.0, 2.0, 5.0, 6.0, 6.5, 7.5]
    assert find_gaps(times, 1.0) == (
        SamplingGap(index=3, start=2.0, stop=5.0, missing=2),
        SamplingGap(index=5, start=6.0, stop=6.5, missing=0),
    )
    assert find_gaps([0.0, 1.004, 2.0], 1.0) == ()  # 0.4 % of Ts: within the default 1 %
    with pytest.raises(DataError, match="Ts must be a positive finite number"):
        find_gaps(times, 0.0)


def test_iso_time_stamps_give_the_period_in_seconds(tmp_path):
    start = datetime(2024, 3, 5, 23, 59, 58)  # crosses midnight: only the steps matter
    write_stamped(tmp_path / "rec.csv", iso(start, np.arange(N) * 0.2))
    data = strictly(lambda: read_data(tmp_path / "rec.csv", ["u"], ["y"]))
    assert data.Ts == pytest.approx(0.2, rel=1e-12)  # microsecond stamps of 0.2 s steps are exact
    np.testing.assert_array_equal(data.y[:, 0], Y)


def test_time_stamps_with_offsets_are_compared_in_utc(tmp_path):
    # the same instants written in two time zones: steps of 1 s throughout
    zones = [timezone.utc if k < N // 2 else timezone(timedelta(hours=2)) for k in range(N)]
    stamps = [(datetime(2024, 1, 1, tzinfo=timezone.utc) + timedelta(seconds=k)).astimezone(z).isoformat()
              for k, z in enumerate(zones)]
    write_stamped(tmp_path / "rec.csv", stamps)
    assert strictly(lambda: read_data(tmp_path / "rec.csv", ["u"], ["y"])).Ts == 1.0


def test_epoch_seconds_are_a_numeric_time_column(tmp_path):
    write_stamped(tmp_path / "rec.csv", [repr(1.7e9 + 0.25 * k) for k in range(N)])
    assert read_data(tmp_path / "rec.csv", ["u"], ["y"]).Ts == 0.25  # exact in binary


def test_a_gap_is_a_warning_that_says_where(tmp_path):
    seconds = np.arange(N) * 0.5
    seconds[17:] += 1.5  # three samples missing before sample 17
    write_stamped(tmp_path / "rec.csv", iso(datetime(2024, 1, 1), seconds))
    with pytest.warns(IrregularSamplingWarning) as caught:
        data = read_data(tmp_path / "rec.csv", ["u"], ["y"])
    assert data.Ts == 0.5 and data.N == N  # the median step; the samples are kept
    assert data.segment_starts == (0, 17)   # the filters restart after the gap
    warning = caught[0].message
    assert warning.gaps == (SamplingGap(index=17, start=8.0, stop=10.0, missing=3),)
    # sample 17 is on line 19 of the file (header on line 1, sample 0 on line 2)
    assert "1 gap longer than 1.5 Ts: line 19 (sample 17): t = 8 s to 10 s, 3 samples missing" in str(warning)


def test_many_gaps_are_counted_and_all_kept(tmp_path):
    seconds = np.arange(N, dtype=float)
    seconds[np.arange(N) >= 5] += 5.0
    for k in (10, 15, 20, 25, 30, 35):
        seconds[k:] += 2.0
    write_stamped(tmp_path / "rec.csv", [repr(float(s)) for s in seconds], head="t")
    with pytest.warns(IrregularSamplingWarning, match="7 gaps longer than 1.5 Ts: .*; and 2 more") as caught:
        data = read_data(tmp_path / "rec.csv", ["u"], ["y"])
    assert [g.index for g in caught[0].message.gaps] == [5, 10, 15, 20, 25, 30, 35]
    assert data.segment_starts == (0, 5, 10, 15, 20, 25, 30, 35)


def test_jitter_within_the_tolerance_is_quiet_and_beyond_it_warns(tmp_path):
    seconds = np.arange(N) * 1.0
    seconds[10] += 0.005  # 0.5 % of Ts
    write_stamped(tmp_path / "rec.csv", [repr(float(s)) for s in seconds], head="time")
    assert strictly(lambda: read_data(tmp_path / "rec.csv", ["u"], ["y"])).Ts == 1.0
    with pytest.warns(IrregularSamplingWarning, match="2 of 39 time steps differ") as caught:
        data = read_data(tmp_path / "rec.csv", ["u"], ["y"], time_tolerance=0.001)
    assert [g.index for g in caught[0].message.gaps] == [10, 11]
    assert "longer than" not in str(caught[0].message)  # jitter, no gap
    assert data.n_segments == 1


def test_stated_period_must_agree_with_the_time_stamps(tmp_path):
    write_stamped(tmp_path / "rec.csv", [repr(0.1 * k) for k in range(N)], head="time")
    assert read_data(tmp_path / "rec.csv", ["u"], ["y"], Ts=0.1005).Ts == 0.1005  # 0.5 %: agrees
    with pytest.raises(DataError, match=r"step by 0.1 \(median\), but Ts = 0.2 was given"):
        read_data(tmp_path / "rec.csv", ["u"], ["y"], Ts=0.2)


def test_time_that_does_not_increase_is_an_error(tmp_path):
    seconds = list(range(N))
    seconds[20] = seconds[19]
    write_stamped(tmp_path / "rec.csv", seconds, head="Time")
    with pytest.raises(DataError, match=r"line 22, column 'Time': time does not increase \(from 19 to 19\)"):
        read_data(tmp_path / "rec.csv", ["u"], ["y"])


def test_choosing_formatting_and_ignoring_the_time_column(tmp_path):
    stamps = [(datetime(2024, 1, 1) + timedelta(seconds=2 * k)).strftime("%d/%m/%Y %H:%M:%S")
              for k in range(N)]
    write_stamped(tmp_path / "rec.csv", stamps, head="date")
    with pytest.raises(DataError, match=r"line 2, column 'date': '01/01/2024 00:00:00' is neither"):
        read_data(tmp_path / "rec.csv", ["u"], ["y"])
    assert read_data(tmp_path / "rec.csv", ["u"], ["y"], time_format="%d/%m/%Y %H:%M:%S").Ts == 2.0
    assert read_data(tmp_path / "rec.csv", ["u"], ["y"], time_column=False).Ts == 1.0
    with pytest.raises(DataError, match="has no time column 'clock'"):
        read_data(tmp_path / "rec.csv", ["u"], ["y"], time_column="clock")


def test_a_missing_time_stamp_is_an_error(tmp_path):
    stamps = [repr(0.5 * k) for k in range(N)]
    stamps[3] = ""
    write_stamped(tmp_path / "rec.csv", stamps, head="t")
    with pytest.raises(DataError, match="line 5, column 't': the time stamp is missing"):
        read_data(tmp_path / "rec.csv", ["u"], ["y"])


def test_datetime64_columns_in_memory_and_npz(tmp_path):
    stamps = np.datetime64("2024-01-01T00:00:00") + np.arange(N) * np.timedelta64(250, "ms")
    data = from_columns({"when": stamps, "u": U, "y": Y}, ["u"], ["y"], time_column="when")
    assert data.Ts == 0.25
    np.savez(tmp_path / "rec.npz", time=stamps, u=U, y=Y)
    assert read_data(tmp_path / "rec.npz").Ts == 0.25  # u and y arrays: the channels u1, y1
