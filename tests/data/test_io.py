"""Reading records from CSV, .npz, .mat, Parquet and data frames: the basics.

Encodings, delimiters and cell errors of text files: test_text_files.py; time stamps:
test_timing.py; spreadsheets, Parquet and MATLAB structs: test_file_formats.py.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

import moli
from moli.errors import DataError
from moli.data import fingerprint, from_dataframe, read_data, to_dataframe

RNG = np.random.default_rng(7)
U = RNG.standard_normal((20, 2))
Y = RNG.standard_normal((20, 2))
TS = 0.25


def write_csv(path: Path, sep: str = ",", time: bool = True) -> Path:
    head = (["time"] if time else []) + ["u1", "u2", "y1", "y2", "comment"]
    lines = [sep.join(head)]
    for k in range(len(U)):
        cells = ([f"{k * TS:.6f}"] if time else []) + [repr(float(v)) for v in (*U[k], *Y[k])] + ["ok"]
        lines.append(sep.join(cells))
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("sep", [",", ";", "\t"])
def test_csv_reads_named_columns_and_the_period_of_the_time_column(tmp_path, sep):
    data = read_data(write_csv(tmp_path / "rec.csv", sep), ["u1", "u2"], ["y2", "y1"])
    # repr() of a float round-trips exactly, so the values must be identical
    np.testing.assert_array_equal(data.u, U)
    np.testing.assert_array_equal(data.y, Y[:, ::-1])
    assert data.output_names == ("y2", "y1")
    assert data.Ts == pytest.approx(TS, rel=1e-9)


def test_stated_period_without_time_stamps_and_default_is_one(tmp_path):
    assert read_data(write_csv(tmp_path / "a.csv", time=False), ["u1"], ["y1"], Ts=2.0).Ts == 2.0
    assert read_data(tmp_path / "a.csv", ["u1"], ["y1"]).Ts == 1.0
    # time stamps and a stated period that agree: the stated one is kept
    assert read_data(write_csv(tmp_path / "b.csv"), ["u1"], ["y1"], Ts=TS).Ts == TS


@pytest.mark.parametrize(
    "content, message",
    [
        ("", "empty"),
        ("u1,y1\n", "no data rows"),
        ("u1,y1\n1,2\n3,abc\n", "line 3, column 'y1': 'abc' is not a number"),
        ("u1,y1\n1,\n3,\n", "column 'y1': no value in any row"),
        ("time,u1,y1\n0,1,2\n1,3,4\n0.5,6,7\n", "line 4, column 'time': time does not increase"),
        ("u1,y2\n1,2\n", "no column 'y1'; columns: 'u1', 'y2'"),
    ],
)
def test_csv_errors_name_the_problem(tmp_path, content, message):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with pytest.raises(DataError, match=message):
        read_data(path, ["u1"], ["y1"])


def test_missing_file_suffix_and_names(tmp_path):
    with pytest.raises(DataError, match="no data file"):
        read_data(tmp_path / "absent.csv", ["u1"], ["y1"])
    (tmp_path / "rec.xls").write_text("x")
    with pytest.raises(DataError, match="suffix must be one of .csv, .tsv, .txt, .xlsx"):
        read_data(tmp_path / "rec.xls", ["u1"], ["y1"])
    with pytest.raises(DataError, match="name the input and output columns"):
        read_data(write_csv(tmp_path / "rec.csv"))
    with pytest.raises(DataError, match="both as input and as output"):
        read_data(tmp_path / "rec.csv", ["u1"], ["u1"])


def test_npz_with_named_vectors_or_u_and_y_arrays(tmp_path):
    np.savez(tmp_path / "cols.npz", u1=U[:, 0], u2=U[:, 1], y1=Y[:, 0], Ts=TS)
    data = read_data(tmp_path / "cols.npz", ["u1", "u2"], ["y1"])
    np.testing.assert_array_equal(data.u, U)
    assert data.Ts == TS
    np.savez(tmp_path / "arrays.npz", u=U, y=Y)
    data = read_data(tmp_path / "arrays.npz")
    np.testing.assert_array_equal(data.y, Y)
    assert data.input_names == ("u1", "u2")


def test_mat_column_vectors(tmp_path):
    savemat(tmp_path / "rec.mat", {"pump": U[:, :1], "level": Y[:, 0], "Ts": TS})
    data = read_data(tmp_path / "rec.mat", ["pump"], ["level"])
    np.testing.assert_array_equal(data.u, U[:, :1])
    np.testing.assert_array_equal(data.y[:, 0], Y[:, 0])
    assert data.Ts == TS


def test_unreadable_npz_is_a_data_error(tmp_path):
    (tmp_path / "broken.npz").write_bytes(b"not a zip")
    with pytest.raises(DataError, match="cannot read"):
        read_data(tmp_path / "broken.npz", ["u1"], ["y1"])


@pytest.mark.skipif(importlib.util.find_spec("pyarrow") is None, reason="pyarrow not installed")
def test_parquet_round_trip(tmp_path):
    frame = to_dataframe(moli.IOData(Y, U, TS)).reset_index()
    frame.to_parquet(tmp_path / "rec.parquet")
    data = read_data(tmp_path / "rec.parquet", ["u1", "u2"], ["y1", "y2"])
    np.testing.assert_array_equal(data.u, U)
    assert data.Ts == pytest.approx(TS)


@pytest.mark.skipif(importlib.util.find_spec("pyarrow") is not None, reason="pyarrow installed")
def test_parquet_without_pyarrow_says_what_to_install(tmp_path):
    (tmp_path / "rec.parquet").write_bytes(b"PAR1")
    with pytest.raises(DataError, match=r"needs pyarrow: pip install 'moli\[data\]'"):
        read_data(tmp_path / "rec.parquet", ["u1"], ["y1"])


def test_dataframe_round_trip_through_iodata_methods():
    pytest.importorskip("pandas")
    original = moli.IOData(Y, U, TS, output_names=["a", "b"])
    frame = moli.to_dataframe(original)
    assert list(frame.columns) == ["a", "b", "u1", "u2"]
    back = moli.from_dataframe(frame, ["u1", "u2"], ["a", "b"])
    np.testing.assert_array_equal(back.y, Y)
    np.testing.assert_array_equal(back.u, U)
    assert back.Ts == pytest.approx(TS, rel=1e-12)
    frame.iloc[0, 0] = 123.0  # the data frame is a copy, not a view of the record
    assert original.y[0, 0] == Y[0, 0]


def test_read_data_does_not_touch_caller_lists(tmp_path):
    inputs = ["u1", "u2"]
    data = moli.read_data(write_csv(tmp_path / "rec.csv"), inputs, ["y1"])
    assert inputs == ["u1", "u2"] and data.m == 2


def test_dataframe_text_column_is_an_error():
    pd = pytest.importorskip("pandas")
    with pytest.raises(DataError, match="the data frame, row 1, column 'u': 'a' is not a number"):
        from_dataframe(pd.DataFrame({"u": ["a", "b"], "y": [1.0, 2.0]}), ["u"], ["y"])


def test_fingerprint_changes_with_any_value_or_length():
    data = moli.IOData(Y, U, TS)
    assert fingerprint(data) == fingerprint(moli.IOData(Y.copy(), U.copy(), 5.0))
    changed = Y.copy()
    changed[3, 1] += 1e-12
    assert fingerprint(moli.IOData(changed, U)) != fingerprint(data)
    assert fingerprint(data[:19]) != fingerprint(data)
