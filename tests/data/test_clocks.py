"""Where the sampling period comes from: time columns by name or content, period and rate
columns, and the notice that says which (or that Ts = 1 was assumed)."""

from __future__ import annotations

import warnings
from datetime import datetime, timedelta

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from moli import DataError, SamplingPeriodWarning, load_model, read_data
from moli.app import cli
from moli.data import from_columns

N = 40
U = np.cos(0.7 * np.arange(N))
Y = np.sin(0.3 * np.arange(N))


def notices(call) -> tuple[object, list[str]]:
    """The result of ``call`` and the text of each SamplingPeriodWarning it gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = call()
    return result, [str(w.message) for w in caught if issubclass(w.category, SamplingPeriodWarning)]


def write(path, table: dict) -> None:
    pd.DataFrame(table).to_csv(path, index=False)


@pytest.mark.parametrize("name", ["Time [s]", "time_s", "Zeit", "Elapsed Time (ms)", "TimeSec"])
def test_a_numeric_time_column_is_found_under_common_names_without_a_warning(tmp_path, name):
    write(tmp_path / "rec.csv", {"u": U, name: 0.05 * np.arange(N), "y": Y})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        data = read_data(tmp_path / "rec.csv", ["u"], ["y"])
    assert data.Ts == pytest.approx(0.05, rel=1e-12)   # the median of steps written to 17 digits
    np.testing.assert_array_equal(data.times, pd.read_csv(tmp_path / "rec.csv")[name].to_numpy())
    assert [str(w.message) for w in caught] == []   # the name says it is time: nothing was guessed


@pytest.mark.parametrize("name", ["Timestamp (UTC)", "Date/Time", "Datum"])
def test_a_date_time_column_is_found_under_common_names(tmp_path, name):
    stamps = [(datetime(2024, 5, 1) + timedelta(seconds=2 * k)).isoformat() for k in range(N)]
    write(tmp_path / "rec.csv", {"u": U, name: stamps, "y": Y})
    data, said = notices(lambda: read_data(tmp_path / "rec.csv", ["u"], ["y"]))
    assert data.Ts == 2.0 and said == []


def test_moli_fit_prints_no_warning_for_a_time_column_found_by_its_name(tmp_path):
    rng = np.random.default_rng(0)
    u = rng.standard_normal(200)
    y = np.convolve(u, np.r_[0.0, 0.5 ** np.arange(10)])[:200] + 0.1 * rng.standard_normal(200)
    write(tmp_path / "plant.csv", {"Time [s]": 0.01 * np.arange(200), "u1": u, "y1": y})
    result = CliRunner().invoke(cli.cli, ["fit", str(tmp_path / "plant.csv"), "--inputs", "u1",
                                          "--outputs", "y1", "--nmax", "2",
                                          "--out", str(tmp_path / "m.json")], prog_name="moli")
    assert result.exit_code == 0, result.stderr
    assert "warning" not in result.stderr
    assert load_model(tmp_path / "m.json").Ts == pytest.approx(0.01, rel=1e-12)  # steps written to 17 digits


def test_a_column_named_like_time_that_holds_no_time_is_passed_over(tmp_path):
    write(tmp_path / "rec.csv", {"time [s]": np.cos(np.arange(N)), "u": U, "y": Y})
    data, said = notices(lambda: read_data(tmp_path / "rec.csv", ["u"], ["y"]))
    assert data.Ts == 1.0
    assert "passed over: column 'time [s]' (named like time, but it does not hold increasing" in said[0]
    assert "Ts = 1 is assumed" in said[0]


def test_a_first_column_is_time_only_when_nothing_else_fits(tmp_path):
    seconds = 0.1 * np.arange(N) + 3.0
    (tmp_path / "blank.csv").write_text(",u,y\n" + "".join(
        f"{float(s)!r},{float(u)!r},{float(y)!r}\n" for s, u, y in zip(seconds, U, Y)))
    data, said = notices(lambda: read_data(tmp_path / "blank.csv", ["u"], ["y"]))
    assert data.Ts == pytest.approx(0.1, rel=1e-12)
    assert "from the time column 'Unnamed: 0' (found as the first column, which holds evenly" in said[0]
    stamps = pd.date_range("2024-01-01", periods=N, freq="250ms")
    write(tmp_path / "dated.csv", {"Messung": stamps.strftime("%Y-%m-%d %H:%M:%S.%f"), "u": U, "y": Y})
    assert read_data(tmp_path / "dated.csv", ["u"], ["y"]).Ts == 0.25
    # an input ramp increases evenly too: a first column with a name of its own is no clock
    write(tmp_path / "ramp.csv", {"setpoint": seconds, "u": U, "y": Y})
    data, said = notices(lambda: read_data(tmp_path / "ramp.csv", ["u"], ["y"]))
    assert data.Ts == 1.0 and "Ts = 1 is assumed" in said[0]
    # nor is a count of samples (pandas' index written to the file)
    pd.DataFrame({"u": U, "y": Y}).to_csv(tmp_path / "counted.csv")
    assert notices(lambda: read_data(tmp_path / "counted.csv", ["u"], ["y"]))[1][0].count("assumed") == 1


def test_a_period_stored_in_its_first_row_only(tmp_path):
    # as the cascaded-tanks benchmark stores it: Ts = 4 on the first row, the rest empty
    ts = [4.0] + [np.nan] * (N - 1)
    write(tmp_path / "tanks.csv", {"uEst": U, "yEst": Y, "Ts": ts})
    data, said = notices(lambda: read_data(tmp_path / "tanks.csv", ["uEst"], ["yEst"]))
    assert data.Ts == 4.0 and data.N == N    # the empty cells of Ts cut no segment
    assert "Ts = 4 from the period in column 'Ts', its first row" in said[0]
    with pytest.raises(DataError, match=r"stores Ts = 4 as the period in column 'Ts', its first "
                                        r"row, but Ts = 2 was given"):
        read_data(tmp_path / "tanks.csv", ["uEst"], ["yEst"], Ts=2.0)
    assert read_data(tmp_path / "tanks.csv", ["uEst"], ["yEst"], Ts=4.0).Ts == 4.0


def test_a_rate_column_gives_its_inverse(tmp_path):
    # as the F-16 ground-vibration benchmark stores it: Fs = 400 (Hz) on every row
    write(tmp_path / "f16.csv", {"Force": U, "Acceleration1": Y, "Fs": np.full(N, 400.0)})
    data, said = notices(lambda: read_data(tmp_path / "f16.csv", ["Force"], ["Acceleration1"]))
    assert data.Ts == 1 / 400      # the same division, so the same float
    assert "Ts = 0.0025 from 1/400, the rate in column 'Fs'" in said[0]
    # a time column beside it must agree with it
    write(tmp_path / "both.csv", {"Force": U, "Acceleration1": Y, "Fs": np.full(N, 400.0),
                                  "time": 0.01 * np.arange(N)})
    with pytest.raises(DataError, match=r"step by 0.01 \(median\), but Ts = 0.0025 was stored"):
        read_data(tmp_path / "both.csv", ["Force"], ["Acceleration1"])


def test_no_time_says_that_ts_1_is_assumed_and_how_to_set_it():
    data, said = notices(lambda: from_columns({"u": U, "y": Y}, ["u"], ["y"]))
    assert data.Ts == 1.0
    assert said == ["the table: no time column and no sampling period found; Ts = 1 is assumed "
                    "(one time unit per sample): set it with Ts= in Python or --ts on the command "
                    "line, or name the time column with time_column= (--time-column)"]
    # stating the period, naming the time column, or a column under a standard name
    # (time, t, timestamp, date, datetime) is what the caller or the file plainly says
    assert notices(lambda: from_columns({"u": U, "y": Y}, ["u"], ["y"], Ts=0.5))[1] == []
    named = {"clock": np.arange(N) * 0.5, "u": U, "y": Y}
    assert notices(lambda: from_columns(named, ["u"], ["y"], time_column="clock"))[1] == []
    plain = {"t": np.arange(N) * 0.5, "u": U, "y": Y}
    data, said = notices(lambda: from_columns(plain, ["u"], ["y"]))
    assert data.Ts == 0.5 and said == []


def test_the_command_line_prints_where_ts_came_from(tmp_path):
    rng = np.random.default_rng(0)
    u = rng.standard_normal(200)
    y = np.convolve(u, 0.5 ** np.arange(10))[:200]
    write(tmp_path / "tanks.csv", {"uEst": u, "yEst": y, "Ts": [4.0] + [np.nan] * 199})
    result = CliRunner().invoke(cli.cli, ["fit", str(tmp_path / "tanks.csv"), "--inputs", "uEst",
                                          "--outputs", "yEst", "--nmax", "2",
                                          "--out", str(tmp_path / "m.json")], prog_name="moli")
    assert result.exit_code == 0, result.stderr
    assert "moli: warning: " + str(tmp_path / "tanks.csv") + ": Ts = 4 from the period in column 'Ts'" in result.stderr
