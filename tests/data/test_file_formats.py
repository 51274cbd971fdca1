"""Excel workbooks, Parquet, .npz and MATLAB files, good and broken."""

from __future__ import annotations

import zipfile

import numpy as np
import pandas as pd
import pytest
from scipy.io import savemat

from moli import DataError, read_data

pytest.importorskip("openpyxl")
pytest.importorskip("pyarrow")

RNG = np.random.default_rng(5)
U = RNG.standard_normal((30, 2))
Y = RNG.standard_normal((30, 3))
START = pd.Timestamp("2024-06-01 08:00:00")


def frame(step: str = "100ms") -> pd.DataFrame:
    return pd.DataFrame({
        "date": pd.date_range(START, periods=len(U), freq=step),
        "heater": U[:, 0], "fan": U[:, 1],
        "T1": Y[:, 0], "T2": Y[:, 1], "T3": Y[:, 2],
        "status": ["ok"] * len(U),
    })


def check(data, inputs=("heater", "fan"), outputs=("T1", "T2", "T3"), Ts=0.1, rtol=0.0) -> None:
    np.testing.assert_allclose(data.u, U, rtol=rtol, atol=0)
    np.testing.assert_allclose(data.y, Y, rtol=rtol, atol=0)
    assert data.input_names == inputs and data.output_names == outputs
    assert data.Ts == pytest.approx(Ts, rel=1e-12)  # date-times in whole milliseconds


def test_xlsx_sheets_by_name_or_position_with_time_stamps(tmp_path):
    path = tmp_path / "rec.xlsx"
    with pd.ExcelWriter(path, engine="openpyxl") as book:
        pd.DataFrame({"note": ["cover sheet"]}).to_excel(book, sheet_name="Notes", index=False)
        frame().to_excel(book, sheet_name="Data", index=False)
    for sheet in ("Data", 1, "1"):
        # a workbook keeps 15 significant digits: a float may come back off by one in the 16th
        check(read_data(path, ["heater", "fan"], ["T1", "T2", "T3"], sheet=sheet), rtol=1e-14)
    with pytest.raises(DataError, match="has no sheet 'Log'; sheets: 'Notes', 'Data'"):
        read_data(path, ["heater"], ["T1"], sheet="Log")


def test_xlsx_bad_cell_is_named_by_its_spreadsheet_row(tmp_path):
    table = frame().astype({"T2": object})
    table.loc[4, "T2"] = "sensor fault"
    table.to_excel(tmp_path / "rec.xlsx", index=False)
    # sample 4 sits in row 6: the header is row 1, sample 0 row 2
    with pytest.raises(DataError, match=r"rec.xlsx, sheet 'Sheet1', row 6, column 'T2': 'sensor fault' is not a number"):
        read_data(tmp_path / "rec.xlsx", ["heater"], ["T2"])


def test_parquet_with_time_stamps_and_a_named_index(tmp_path):
    frame().to_parquet(tmp_path / "a.parquet")
    check(read_data(tmp_path / "a.parquet", ["heater", "fan"], ["T1", "T2", "T3"]))
    indexed = frame().drop(columns="date").set_index(pd.Index(np.arange(len(U)) * 0.25, name="time"))
    indexed.to_parquet(tmp_path / "b.parquet")
    check(read_data(tmp_path / "b.parquet", ["heater", "fan"], ["T1", "T2", "T3"]), Ts=0.25)


def test_npz_u_and_y_arrays_are_the_default_channels(tmp_path):
    np.savez(tmp_path / "rec.npz", u=U, y=Y, Ts=0.1)
    check(read_data(tmp_path / "rec.npz"), ("u1", "u2"), ("y1", "y2", "y3"))


def test_mat_plain_arrays(tmp_path):
    savemat(tmp_path / "rec.mat", {"u": U, "y": Y, "Ts": 0.1})
    check(read_data(tmp_path / "rec.mat"), ("u1", "u2"), ("y1", "y2", "y3"))
    savemat(tmp_path / "vectors.mat", {"heater": U[:, 0], "fan": U[:, 1:], "T1": Y[:, 0],
                                        "T2": Y[:, 1], "T3": Y[:, 2], "Ts": 0.1})
    check(read_data(tmp_path / "vectors.mat", ["heater", "fan"], ["T1", "T2", "T3"]))


def iddata(**changes) -> dict:
    """What MATLAB saves for ``s = get(iddata(y, u, 0.1, ...))``: a struct of these fields."""
    fields = {"OutputData": Y, "InputData": U, "Ts": 0.1, "TimeUnit": "seconds",
              "OutputName": np.array(["T1", "T2", "T3"], dtype=object),
              "InputName": np.array(["heater", "fan"], dtype=object), "Tstart": 0.1}
    return {"run": {**fields, **changes}}


def test_mat_iddata_struct_gives_channels_names_and_period(tmp_path):
    savemat(tmp_path / "rec.mat", iddata())
    check(read_data(tmp_path / "rec.mat"))
    check(read_data(tmp_path / "rec.mat", ["heater", "fan"], ["T1", "T2", "T3"]))
    # blank names (MATLAB's default is '') fall back to u1, y1, ...
    savemat(tmp_path / "plain.mat", iddata(OutputName=np.array(["", "", ""], dtype=object)))
    assert read_data(tmp_path / "plain.mat").output_names == ("y1", "y2", "y3")


def test_mat_iddata_with_several_experiments_is_refused(tmp_path):
    cells = np.empty(2, dtype=object)
    cells[0], cells[1] = Y, Y
    savemat(tmp_path / "rec.mat", iddata(OutputData=cells))
    with pytest.raises(DataError, match=r"run\).OutputData is a cell array of 2 experiments"):
        read_data(tmp_path / "rec.mat")


def test_a_stored_period_must_agree_with_a_given_one(tmp_path):
    np.savez(tmp_path / "rec.npz", u=U, y=Y, Ts=0.1)
    with pytest.raises(DataError, match="stores Ts = 0.1, but Ts = 0.5 was given"):
        read_data(tmp_path / "rec.npz", Ts=0.5)


def broken_files(tmp_path) -> dict[str, str]:
    """Each unreadable file and the message it must give."""
    frame().to_parquet(tmp_path / "whole.parquet")
    np.savez(tmp_path / "whole.npz", u=U, y=Y)
    with zipfile.ZipFile(tmp_path / "notes.npz", "w") as archive:
        archive.writestr("readme.txt", "not arrays")
    np.save(tmp_path / "single.npy", U)
    cases = {
        "cut.parquet": ((tmp_path / "whole.parquet").read_bytes()[:300], "as a Parquet file"),
        "garbage.parquet": (b"PAR1 not really", "as a Parquet file"),
        "cut.npz": ((tmp_path / "whole.npz").read_bytes()[:200], "as a NumPy .npz archive"),
        "garbage.npz": (b"\x93NUMPY garbage", "as a NumPy .npz archive"),
        "notes.npz": ((tmp_path / "notes.npz").read_bytes(), "is a zip archive but not a NumPy .npz"),
        "single.npz": ((tmp_path / "single.npy").read_bytes(), r"holds a single array \(.npy\)"),
        "garbage.mat": (b"MATLAB 5.0 MAT-file, nonsense", "as a MATLAB .mat file"),
        "garbage.xlsx": (b"PK\x03\x04 not a workbook", r"as an Excel .xlsx workbook"),
    }
    for name, (content, _) in cases.items():
        (tmp_path / name).write_bytes(content)
    return {name: message for name, (_, message) in cases.items()}


def test_unreadable_binary_files_are_data_errors_naming_the_file(tmp_path):
    for name, message in broken_files(tmp_path).items():
        with pytest.raises(DataError, match=message) as caught:
            read_data(tmp_path / name, ["u1"], ["y1"])
        assert name in str(caught.value)


def test_xlsx_converts_only_the_cells_of_the_needed_columns(tmp_path, monkeypatch):
    from openpyxl.worksheet import _reader

    table = frame()
    for k in range(40):  # columns no request names: a comment or status column each
        table[f"note{k}"] = [f"remark {k}-{row}" for row in range(len(table))]
    table.to_excel(tmp_path / "wide.xlsx", index=False)
    converted = []
    parse_cell = _reader.WorkSheetParser.parse_cell
    monkeypatch.setattr(_reader.WorkSheetParser, "parse_cell",
                        lambda self, element: converted.append(element.get("r")) or parse_cell(self, element))
    check(read_data(tmp_path / "wide.xlsx", ["heater", "fan"], ["T1", "T2", "T3"]), rtol=1e-14)
    # the header row, then the date (time) column and the five channels of every row
    assert len(converted) == table.shape[1] + 6 * len(table)
    assert not any(cell.startswith(("H", "I", "J")) for cell in converted[table.shape[1]:])


def test_xlsx_rows_left_out_or_blank_are_missing_samples_and_trailing_ones_dropped(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    book = openpyxl.Workbook()
    sheet = book.active
    sheet.append(["u1", "y1", "note"])
    for k in range(4):
        sheet.append([k, 2 * k, "ok"])
    sheet.append([])            # row 6: blank, a boundary
    for k in range(4, 8):       # rows 7-10
        sheet.append([k, 2 * k, "ok"])
    sheet["A12"] = 8            # row 11 is left out of the file: a boundary too
    sheet["B12"] = 16
    for k in range(13, 16):     # rows 13-15: channels end, a note goes on
        sheet.append([k - 4, 2 * k - 8, "ok"])
    sheet["C16"] = "trailing note"   # a row with no channel value ends the record
    book.save(tmp_path / "gaps.xlsx")
    data = read_data(tmp_path / "gaps.xlsx", ["u1"], ["y1"], Ts=1.0)
    assert tuple(data.segment_starts) == (0, 4, 8)
    np.testing.assert_array_equal(data.u.ravel(), np.arange(12))
    np.testing.assert_array_equal(data.y.ravel(), 2 * np.arange(12))
    sheet["B14"] = "x"
    book.save(tmp_path / "gaps.xlsx")
    with pytest.raises(DataError, match=r"gaps.xlsx, sheet 'Sheet', row 14, column 'y1': 'x' is not a number"):
        read_data(tmp_path / "gaps.xlsx", ["u1"], ["y1"], Ts=1.0)
