"""Readers bounded by what they need: each hostile file is read under a 2 GiB address-space
cap (tests/hostile_files.py) and gives the record it holds, or one moli error.

Each bomb inflates to :data:`~hostile_files.CAP_BYTES` (2 GiB) of content the request
does not need: a reader that inflated it would pass the cap on that alone.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import moli
from moli.data import text_files

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from hostile_files import (  # noqa: E402
    CAP_BYTES, SAMPLES, bomb_mat, bomb_npz, bomb_xlsx, read_capped, record, zero_padded_csv,
)


def assert_the_record(read: dict, Ts: float | None = 0.5) -> None:
    assert "error" not in read, read["error"]
    u, y = record()
    # JSON writes floats with repr's 17 digits: the round trip is exact
    np.testing.assert_array_equal(read["u"], u)
    np.testing.assert_array_equal(read["y"], y)
    if Ts is not None:
        assert read["Ts"] == Ts


def test_an_npz_without_channels_named_reads_only_u_y_and_ts(tmp_path):
    path = bomb_npz(tmp_path / "record.npz", CAP_BYTES)
    assert path.stat().st_size < 4 << 20
    assert_the_record(read_capped(path))


def test_an_npz_with_channels_named_reads_only_those(tmp_path):
    path = bomb_npz(tmp_path / "record.npz", CAP_BYTES, with_record=False)
    assert_the_record(read_capped(path, ["u1"], ["y1"], 0.5))


@pytest.mark.parametrize("as_struct", [False, True], ids=["array", "struct"])
def test_a_mat_file_without_channels_named_reads_only_u_y_and_ts(tmp_path, as_struct):
    path = bomb_mat(tmp_path / "record.mat", CAP_BYTES, as_struct=as_struct)
    assert path.stat().st_size < 4 << 20
    assert_the_record(read_capped(path))


def test_an_unused_mat_struct_is_not_inflated_with_channels_named(tmp_path):
    path = bomb_mat(tmp_path / "record.mat", CAP_BYTES, as_struct=True, with_record=False)
    assert_the_record(read_capped(path, ["u1"], ["y1"], 0.5))


@pytest.mark.parametrize("bomb", [bomb_npz, bomb_mat], ids=["npz", "mat"])
def test_an_array_file_without_u_and_y_says_which_arrays_it_needs(tmp_path, bomb):
    path = bomb(tmp_path / f"record.{bomb.__name__[-3:]}", CAP_BYTES, with_record=False)
    said = read_capped(path)["error"]
    assert said.startswith(f"DataError: name the input and output columns of {path} (inputs=, outputs=; "
                           "--inputs, --outputs), or store them as 2-D arrays u and y, one row per sample; "
                           "columns: ")
    assert {"'junk'", "'u1'", "'y1'"} <= set(said.split("columns: ")[1].split(", "))


@pytest.mark.parametrize("encoding", ["utf-8", "utf-16", "cp1252"])
def test_a_text_file_padded_with_zero_bytes_is_one_error(tmp_path, encoding):
    path = zero_padded_csv(tmp_path / "record.csv", 3 * CAP_BYTES // 2, encoding)
    said = read_capped(path, ["u1"], ["y1"])["error"]
    assert said.startswith(f"DataError: {path} is not a text table: it holds zero bytes from byte ")
    assert "padded with zeros after a crash" in said


def test_a_long_legacy_file_is_told_from_its_beginning(tmp_path):
    path = tmp_path / "record.csv"
    u, y = record()
    rows = "".join(f"{a!r};{b!r};ok\n" for a, b in zip(u[:, 0].tolist(), y[:, 0].tolist()))
    copies = 2 * text_files.LEGACY_BYTES // len(rows) + 1   # past the part the encoding is told from
    path.write_bytes(("u1;y1;état\n" + rows * copies).encode("cp1252"))
    read = moli.read_data(path, ["u1"], ["y1"], 0.5)
    np.testing.assert_array_equal(read.u[:SAMPLES], u)
    assert read.N == SAMPLES * copies


@pytest.mark.parametrize("shared", [False, True], ids=["in the sheet", "shared"])
def test_a_huge_text_in_a_column_not_read_costs_nothing(tmp_path, shared):
    path = bomb_xlsx(tmp_path / "record.xlsx", CAP_BYTES // 2, shared)
    assert path.stat().st_size < 4 << 20
    assert_the_record(read_capped(path, ["u1"], ["y1"], 0.5))


def test_without_channels_named_a_table_reads_only_its_header(tmp_path, monkeypatch):
    from openpyxl.worksheet import _reader

    path = bomb_xlsx(tmp_path / "record.xlsx", 1000, shared=True)
    converted = []
    parse_cell = _reader.WorkSheetParser.parse_cell
    monkeypatch.setattr(_reader.WorkSheetParser, "parse_cell",
                        lambda self, element: converted.append(element.get("r")) or parse_cell(self, element))
    with pytest.raises(moli.DataError, match="name the input and output columns .*'u1', 'y1', 'note'"):
        moli.read_data(path)
    assert converted == ["A1", "B1", "C1"]


def test_a_legacy_letter_past_the_first_16_mib_is_told_from_its_own_lines(tmp_path):
    path = tmp_path / "record.csv"
    u, y = record()
    rows = "".join(f"{a!r};{b!r};ok\n" for a, b in zip(u[:, 0].tolist(), y[:, 0].tolist()))
    copies = 2 * text_files.LEGACY_BYTES // len(rows) + 1   # all ASCII up to twice the part read first
    path.write_bytes(("u1;y1;note\n" + rows * copies + "0.0;0.0;température élevée\n").encode("cp1252"))
    read = moli.read_data(path, ["u1"], ["y1"], 0.5)
    assert read.N == SAMPLES * copies + 1 and read.u[-1, 0] == 0.0
    line = 1 + SAMPLES * copies + 1   # the header, the rows, then the one with accents
    # the byte that does not decode is found block by block, its line counted across blocks
    with pytest.raises(moli.DataError, match=rf"is not utf-8 text: byte 0xe9 on line {line} does not decode"):
        moli.read_data(path, ["u1"], ["y1"], 0.5, encoding="utf-8")
