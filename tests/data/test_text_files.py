"""Text tables: encodings, delimiters, decimal marks, text columns and cell errors.

Every file is written here with known values; ``repr`` of a float round-trips exactly,
so values read back must be identical (a decimal comma only swaps one character).
"""

from __future__ import annotations

import numpy as np
import pytest

from moli import DataError, OptionError, read_data
from moli.data import detect_encoding

RNG = np.random.default_rng(11)
U = RNG.standard_normal((25, 2))
Y = RNG.standard_normal((25, 1))
TS = 0.5
IN, OUT = "débit °C", "Qualität ß"  # names that only survive the right decoding


def table_text(sep: str = ",", decimal: str = ".", status: bool = True) -> str:
    head = ["time", IN, "pump", OUT] + (["état"] if status else [])
    lines = [sep.join(head)]
    for k in range(len(U)):
        cells = [repr(k * TS), repr(float(U[k, 0])), repr(float(U[k, 1])), repr(float(Y[k, 0]))]
        cells = [c.replace(".", decimal) for c in cells] + (["arrêté" if k % 3 else "réglé"] if status else [])
        lines.append(sep.join(cells))
    return "\n".join(lines) + "\n"


def check(data) -> None:
    np.testing.assert_array_equal(data.u, U)
    np.testing.assert_array_equal(data.y, Y)
    assert data.input_names == (IN, "pump") and data.output_names == (OUT,)
    assert data.Ts == TS  # steps k * 0.5 are exact in binary


@pytest.mark.parametrize("encoding, sep, decimal, newline", [
    ("utf-8", ",", ".", "\n"),
    ("utf-8-sig", ",", ".", "\r\n"),  # with a byte-order mark, Windows line ends
    ("utf-16", "\t", ".", "\r\n"),  # Python writes a byte-order mark
    ("latin-1", ";", ",", "\n"),
    ("cp1252", ";", ",", "\r"),
])
def test_encodings_delimiters_and_decimal_marks_are_found(tmp_path, encoding, sep, decimal, newline):
    path = tmp_path / "rec.csv"
    path.write_bytes(table_text(sep, decimal).replace("\n", newline).encode(encoding))
    check(read_data(path, [IN, "pump"], [OUT]))


def test_given_options_override_the_sniffing(tmp_path):
    path = tmp_path / "rec.txt"
    path.write_bytes(table_text("|", ",").encode("latin-1"))
    check(read_data(path, [IN, "pump"], [OUT], delimiter="|", decimal=",", encoding="latin-1"))


def test_whitespace_separated_txt_and_tsv(tmp_path):
    text = table_text(",", ".", status=False).replace(IN, "flow").replace(OUT, "level")
    (tmp_path / "rec.txt").write_text(text.replace(",", "   "))
    (tmp_path / "rec.tsv").write_text(text.replace(",", "\t"))
    for name in ("rec.txt", "rec.tsv"):
        data = read_data(tmp_path / name, ["flow", "pump"], ["level"])
        np.testing.assert_array_equal(data.u, U)
        assert data.Ts == TS


@pytest.mark.parametrize("raw, expected", [
    ("x;y\n1;2\n".encode("utf-8"), "utf-8"),
    ("é;y\n1;2\n".encode("utf-8-sig"), "utf-8-sig"),
    ("é;y\n1;2\n".encode("utf-16-le"), "utf-16-le"),  # no byte-order mark: found by the detector
    ("température;état\n1;arrêté\n".encode("latin-1"), "cp1252"),
    ("cost €;flow – x\n1;2\n".encode("cp1252"), "cp1252"),
    ("время;температура;состояние\n1;2;норма\n".encode("cp1251"), "cp1251"),
    ("χρόνος;θερμοκρασία\n1;εντάξει\n".encode("cp1253"), "cp1253"),
    (("時間;温度;状態\n" + "0,1;1,5;正常\n" * 50).encode("shift_jis"), "shift_jis"),
    # a status word repeated on every row, the only letters of the data lines, misleads
    # a detector's letter statistics; it counts once here
    (("time;Ventil öffnung;état\n" + "0,5;1,25;réglé\n" * 300).encode("latin-1"), "cp1252"),
])
def test_detect_encoding(raw, expected):
    found = detect_encoding(raw)
    # the detector may name an alias (utf_16_le): compare what the names decode to
    assert raw.decode(found) == raw.decode(expected)


def test_a_text_column_not_asked_for_is_ignored_and_one_asked_for_is_an_error(tmp_path):
    path = tmp_path / "rec.csv"
    path.write_bytes(table_text(";", ",").encode("latin-1"))
    with pytest.raises(DataError, match=r"rec.csv, line 2, column 'état': 'réglé' is not a number"):
        read_data(path, [IN, "état"], [OUT])


def test_a_bad_cell_is_located_by_its_line_in_the_file(tmp_path):
    # blank lines are skipped but still counted, as an editor numbers them
    path = tmp_path / "rec.csv"
    for newline in ("\n", "\r\n"):
        path.write_bytes(f"u1,y1,note{newline}1,2,a{newline}{newline}3,4,b{newline}  {newline}"
                         f"5,oops,c{newline}".encode())
        with pytest.raises(DataError, match=r"rec.csv, line 6, column 'y1': 'oops' is not a number"):
            read_data(path, ["u1"], ["y1"])
    path.write_text("u1,y1\n1,2\n3,inf\n")
    with pytest.raises(DataError, match=r"line 3, column 'y1': inf is not a finite number"):
        read_data(path, ["u1"], ["y1"])


@pytest.mark.parametrize("body", [
    "1;2,5\n3;\n5;6\n",      # empty cell
    "1;2,5\n;4\n5;6\n",
    "1;2,5\n3;NA\n5;6\n",
    "1;2,5\n;\n5;6\n",       # a row of empty cells
])
def test_missing_samples_end_a_segment(tmp_path, body):
    path = tmp_path / "rec.csv"
    path.write_text("u1;y1;note\n" + body.replace("\n", ";x\n"))
    data = read_data(path, ["u1"], ["y1"])
    # the row of line 3 (sample 1) lacks a value: samples 0 and 2 are the two segments left
    assert data.bounds == ((0, 1), (1, 2))
    np.testing.assert_array_equal(data.u[:, 0], [1.0, 5.0])
    np.testing.assert_array_equal(data.y[:, 0], [2.5, 6.0])


@pytest.mark.parametrize("content, message", [
    (bytes(np.random.default_rng(0).integers(0, 256, 2000, dtype=np.uint8)), "holds binary data"),
    (b"\x00\x01\x02PK", "holds binary data"),
    (b"", "is empty"),
    (b"\n \n", "is empty"),
    (b"u1,y1\n", "has no data rows"),
    (b"0.1,0.2\n0.3,0.4\n", "the first row holds numbers, not column names"),
    (b"u1,y1\n1,2\n3,4,5\n", "cannot read .* as a table with ',' between columns"),
])
def test_unreadable_text_is_a_data_error(tmp_path, content, message):
    path = tmp_path / "bad.csv"
    path.write_bytes(content)
    with pytest.raises(DataError, match=message):
        read_data(path, ["u1"], ["y1"])


def test_a_wrong_given_encoding_names_the_byte_and_line(tmp_path):
    path = tmp_path / "rec.csv"
    path.write_bytes("u1,y1\n1,2\n3,4\nété,5\n".encode("latin-1"))
    with pytest.raises(DataError, match=r"is not utf-8 text: byte 0xe9 on line 4"):
        read_data(path, ["u1"], ["y1"], encoding="utf-8")


@pytest.mark.parametrize("options, message", [
    ({"delimiter": "ab"}, "delimiter must be one character"),
    ({"delimiter": "."}, "delimiter must be one character"),
    ({"decimal": ";"}, "decimal must be '.' or ','"),
    ({"delimiter": ",", "decimal": ","}, "both ','"),
    ({"encoding": "klingon"}, "unknown text encoding 'klingon'"),
    ({"encoding": "rot13"}, "unknown text encoding 'rot13'"),       # a codec, but of text to text
    ({"sheet": "Data"}, "sheet applies to .xlsx files, not .csv"),
    ({"time_tolerance": 0.7}, r"time_tolerance must be a number in \[0, 0.5\)"),
    ({"time_column": 3}, "time_column must be a column name"),
])
def test_bad_options_are_refused_before_the_file_is_read(tmp_path, options, message):
    # the file does not exist: the option error must come first
    with pytest.raises(OptionError, match=message):
        read_data(tmp_path / "absent.csv", ["u1"], ["y1"], **options)


def test_text_options_do_not_apply_to_other_formats(tmp_path):
    with pytest.raises(OptionError, match=r"encoding applies to text files \(.csv, .tsv, .txt\), not .npz"):
        read_data(tmp_path / "absent.npz", ["u1"], ["y1"], encoding="utf-8")


def test_channel_names_must_be_a_list_not_one_string(tmp_path):
    with pytest.raises(DataError, match=r"inputs must be a sequence of column names .* got 'u1,u2'"):
        read_data(tmp_path / "absent.csv", "u1,u2", ["y1"])


def test_the_caller_gets_the_file_untouched(tmp_path):
    path = tmp_path / "rec.csv"
    path.write_bytes(table_text(";", ",").encode("latin-1"))
    before = path.read_bytes()
    names = [IN, "pump"]
    read_data(path, names, [OUT])
    assert path.read_bytes() == before and names == [IN, "pump"]


def test_a_table_read_in_chunks_is_the_same_record(tmp_path, monkeypatch):
    # chunks of 4 rows: every chunk boundary falls between the 25 rows of the table, a
    # text cell sits in a later chunk than the first, and the status column is dropped
    from moli.data import frame_files

    path = tmp_path / "rec.csv"
    path.write_bytes(table_text(";", ",").encode("cp1252"))
    monkeypatch.setattr(frame_files, "CHUNK_ROWS", 4)
    check(read_data(path, [IN, "pump"], [OUT]))
    lines = path.read_bytes().decode("cp1252").splitlines()
    lines[19] = lines[19].replace(";", ";x", 1)  # a text cell on line 20, the fifth chunk
    path.write_bytes(("\n".join(lines) + "\n").encode("cp1252"))
    with pytest.raises(DataError, match=r"rec.csv, line 20, column 'débit °C': 'x"):
        read_data(path, [IN, "pump"], [OUT])


def test_columns_left_unread_are_still_listed(tmp_path):
    path = tmp_path / "rec.csv"
    path.write_text(table_text())
    with pytest.raises(DataError, match=r"no column 'flow'; columns: 'time', 'débit °C', 'pump', 'Qualität ß', 'état'$"):
        read_data(path, ["flow"], [OUT])
