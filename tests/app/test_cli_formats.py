"""``moli fit`` and ``moli validate`` on every file format, encoding and time axis they read.

Each file is written here from one simulated record of a known 3-state plant with two
inputs and two outputs; a fit that reads the file right (values, channels, period)
explains nearly all of its output variance.
"""

from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner, Result
from scipy.io import savemat

import moli
from moli.app import cli
from systems_util import random_system

pytest.importorskip("openpyxl")
pytest.importorskip("pyarrow")

N, TS = 300, 0.5
INPUTS, OUTPUTS = ("Ventil öffnung", "pump"), ("Temp °C", "level")
RNG = np.random.default_rng(4)
U = RNG.standard_normal((N, 2))
Y = random_system(3, 2, 2, RNG).simulate(U)
Y += 0.01 * Y.std(axis=0) * RNG.standard_normal(Y.shape)  # 1 % noise: VAF near 99.99
START = pd.Timestamp("2024-02-29 23:58:00")


def run(*args: str) -> Result:
    return CliRunner().invoke(cli.cli, list(args), prog_name="moli")


def columns(time: object) -> pd.DataFrame:
    return pd.DataFrame({"time": time, INPUTS[0]: U[:, 0], INPUTS[1]: U[:, 1],
                         OUTPUTS[0]: Y[:, 0], OUTPUTS[1]: Y[:, 1], "état": "réglé"})


def seconds() -> np.ndarray:
    return np.arange(N) * TS


def stamps() -> pd.DatetimeIndex:
    return pd.date_range(START, periods=N, freq="500ms")


def text(frame: pd.DataFrame, sep: str, decimal: str) -> str:
    return frame.to_csv(sep=sep, decimal=decimal, index=False, float_format="%.17g")


def utf16(path: Path) -> Path:
    path.write_text(text(columns(seconds()), "\t", "."), encoding="utf-16")
    return path


def latin1(path: Path) -> Path:
    path.write_bytes(text(columns(seconds()), ";", ",").encode("latin-1"))
    return path


def iso(path: Path) -> Path:
    path.write_text(text(columns(stamps().strftime("%Y-%m-%dT%H:%M:%S.%f")), ",", "."))
    return path


def xlsx(path: Path) -> Path:
    columns(stamps()).to_excel(path, sheet_name="Messung", index=False)
    return path


def parquet(path: Path) -> Path:
    columns(stamps()).to_parquet(path)
    return path


def npz(path: Path) -> Path:
    np.savez(path, u=U, y=Y, Ts=TS)
    return path


def mat(path: Path) -> Path:
    savemat(path, {"time": seconds(), "valve": U[:, 0], "pump": U[:, 1], "temp": Y[:, 0], "level": Y[:, 1]})
    return path


def iddata(path: Path) -> Path:
    savemat(path, {"z": {"OutputData": Y, "InputData": U, "Ts": TS,
                         "OutputName": np.array(OUTPUTS, dtype=object),
                         "InputName": np.array(INPUTS, dtype=object)}})
    return path


NAMED = ["--inputs", ",".join(INPUTS), "--outputs", ",".join(OUTPUTS)]
GOOD: dict[str, tuple[Callable[[Path], Path], list[str], tuple[str, ...], tuple[str, ...]]] = {
    "utf16.csv": (utf16, NAMED, INPUTS, OUTPUTS),
    "latin1.csv": (latin1, NAMED, INPUTS, OUTPUTS),
    "flags.txt": (latin1, [*NAMED, "--delimiter", ";", "--decimal", ",", "--encoding", "latin-1",
                           "--time-column", "time"], INPUTS, OUTPUTS),
    "iso.csv": (iso, NAMED, INPUTS, OUTPUTS),
    "rec.xlsx": (xlsx, [*NAMED, "--sheet", "Messung"], INPUTS, OUTPUTS),
    "rec.parquet": (parquet, NAMED, INPUTS, OUTPUTS),
    "rec.npz": (npz, [], ("u1", "u2"), ("y1", "y2")),
    "plain.mat": (mat, ["--inputs", "valve,pump", "--outputs", "temp,level"], ("valve", "pump"),
                  ("temp", "level")),
    "iddata.mat": (iddata, [], INPUTS, OUTPUTS),
}


@pytest.mark.parametrize("name", GOOD)
def test_fit_reads_every_format_with_its_period_and_channel_names(tmp_path, name):
    write, flags, inputs, outputs = GOOD[name]
    path = write(tmp_path / name)
    out = tmp_path / "model.json"
    done = run("fit", str(path), *flags, "--nmax", "4", "--out", str(out))
    assert done.exit_code == 0, done.output + done.stderr
    assert done.stderr.count("moli: warning") == 0
    model = moli.load_model(out)
    assert model.Ts == pytest.approx(TS, rel=1e-12)  # every time axis above has exact 0.5 s steps
    assert (model.input_names, model.output_names) == (inputs, outputs)
    assert model.info["data"]["file_sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    # 1 % output noise caps the VAF near 99.99; a misread file (wrong decimal mark,
    # shifted or swapped columns) could not explain 95 % of both outputs
    assert min(model.info["validation_vaf"]) > 95.0


def test_fit_warns_of_gaps_with_their_place_and_keeps_going(tmp_path):
    late = stamps() + pd.to_timedelta(np.where(np.arange(N) >= 100, 1.0, 0.0), unit="s")
    path = tmp_path / "gap.csv"
    path.write_text(text(columns(late.strftime("%Y-%m-%dT%H:%M:%S.%f")), ",", "."))
    done = run("fit", str(path), *NAMED, "--nmax", "4", "--out", str(tmp_path / "m.json"))
    assert done.exit_code == 0, done.stderr
    # sample 100 is on line 102; the 1.5 s step lacks two samples of 0.5 s
    assert ("moli: warning: " in done.stderr and
            "line 102 (sample 100): t = 49.5 s to 51 s, 2 samples missing" in done.stderr)
    # the gap is a segment boundary: the model is the one of the record split there
    with pytest.warns(moli.IrregularSamplingWarning):
        data = moli.read_data(path, INPUTS, OUTPUTS)
    assert data.segment_starts == (0, 100)
    expected = moli.identify(*data.split(0.7), nmax=4).model
    np.testing.assert_array_equal(moli.load_model(tmp_path / "m.json").A, expected.A)


def test_fit_takes_empty_cells_as_gaps_between_segments(tmp_path):
    frame = columns(seconds())
    frame.loc[90:95, OUTPUTS[0]] = np.nan        # a sensor out for six samples
    frame.loc[150, INPUTS[1]] = np.nan           # one input sample not logged
    path = tmp_path / "gaps.csv"
    path.write_text(text(frame, ",", ".").replace(",nan,", ",,").replace("nan", ""))
    out, report = tmp_path / "model.json", tmp_path / "report"
    done = run("fit", str(path), *NAMED, "--nmax", "4", "--out", str(out), "--report", str(report))
    assert done.exit_code == 0, done.output + done.stderr
    assert (report / "report.html").stat().st_size > 1000
    model = moli.load_model(out)
    assert model.Ts == pytest.approx(TS, rel=1e-12)    # the time column's 0.5 s steps, gaps or not
    assert (model.input_names, model.output_names) == (INPUTS, OUTPUTS)
    data = moli.read_data(path, INPUTS, OUTPUTS)
    assert data.bounds == ((0, 90), (90, 144), (144, 293))   # samples 90-95 and 150 removed
    expected = moli.identify(*data.split(0.7), nmax=4).model
    np.testing.assert_array_equal(model.A, expected.A)
    # as for the complete files above: 1 % noise, and each segment's start from rest
    # costs the simulation a transient of a few samples only
    assert min(model.info["validation_vaf"]) > 95.0


def garbage_npz(path: Path) -> Path:
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("data.txt", "1,2,3")
    return path


def write_bytes(content: bytes) -> Callable[[Path], Path]:
    def make(path: Path) -> Path:
        path.write_bytes(content)
        return path
    return make


BAD = {
    "garbage.csv": (write_bytes(bytes(range(256)) * 8), "holds binary data"),
    "garbage.npz": (garbage_npz, "is a zip archive but not a NumPy .npz"),
    "cut.npz": (write_bytes(b"PK\x03\x04\x14\x00"), "cannot read"),
    "garbage.parquet": (write_bytes(b"PAR1\x00\x01PAR1"), "as a Parquet file"),
    "empty column.csv": (write_bytes(b"Ventil \xc3\xb6ffnung,pump,Temp \xc2\xb0C,level\n1,,3,4\n1,,3,4\n"),
                         "column 'pump': no value in any row"),
    "text cell.csv": (write_bytes(b"Ventil \xc3\xb6ffnung,pump,Temp \xc2\xb0C,level\n1,2,3,4\n1,2,x,4\n"),
                      "line 3, column 'Temp \u00b0C': 'x' is not a number"),
}


@pytest.mark.parametrize("name", BAD)
def test_bad_files_end_in_one_error_line_and_exit_2(tmp_path, name):
    write, message = BAD[name]
    result = run("fit", str(write(tmp_path / name)), *NAMED, "--nmax", "4")
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("moli: error: "), result.stderr
    assert message in lines[0] and name in lines[0]


def test_fixed_order_selects_that_model(tmp_path):
    path = latin1(tmp_path / "rec.csv")
    done = run("fit", str(path), *NAMED, "--order", "4", "--out", str(tmp_path / "m.json"))
    assert done.exit_code == 0, done.stderr
    assert moli.load_model(tmp_path / "m.json").n == 4
    assert "the fixed order n = 4" in done.output
    wrong = run("fit", str(path), *NAMED, "--order", "6", "--nmax", "4")
    assert wrong.exit_code == 2 and "IdentifyOptions.order must be at most nmax = 4" in wrong.stderr


def test_validate_refuses_a_record_of_another_period(tmp_path):
    model = tmp_path / "m.json"
    assert run("fit", str(latin1(tmp_path / "rec.csv")), *NAMED, "--nmax", "3", "--out", str(model)).exit_code == 0
    slow = columns(np.arange(N) * 2 * TS)  # the same samples, stamped every 1 s
    (tmp_path / "slow.csv").write_text(text(slow, ",", "."))
    result = run("validate", str(model), str(tmp_path / "slow.csv"), "--plot", str(tmp_path / "v.png"))
    assert result.exit_code == 2
    assert "step by 1 (median), but Ts = 0.5 was given" in result.stderr
