"""Every bad command line ends with one line ``moli: error: ...`` and exit code 2."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import moli
from moli.app import cli

IO = ["--inputs", "u1,u2,u3", "--outputs", "y1,y2,y3"]


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    moli.to_dataframe(moli.example_data(N=200, seed=1)).to_csv(tmp_path / "good.csv")
    header = "time,u1,u2,u3,y1,y2,y3\n"
    files = {
        "empty.csv": "", "header.csv": header, "one.csv": header + "0,1,2,3,4,5,6\n",
        "text.csv": header + "0,1,2,3,4,5,6\n1,a,2,3,4,5,6\n",
        "complex.csv": header + "0,1j,2,3,4,5,6\n1,1,2,3,4,5,6\n",
        "inf.csv": header + "0,inf,2,3,4,5,6\n1,1,2,3,4,5,6\n",
        "options.json": '{"nmax": "3"}', "options_cut.json": '{"nmax": 3',
    }
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    np.savez(tmp_path / "no_inputs.npz", u=np.zeros((100, 0)), y=np.zeros((100, 1)))
    np.savez(tmp_path / "no_samples.npz", u=np.zeros((0, 1)), y=np.zeros((0, 1)))
    model = moli.example_plant()
    model.save(tmp_path / "model.json")
    content = json.loads((tmp_path / "model.json").read_text())
    (tmp_path / "cut.json").write_text(json.dumps(content)[:300])
    (tmp_path / "list.json").write_text("[1, 2]")
    for name, key, value in (("text_matrix.json", "A", [["a"]]), ("offset.json", "y_offset", [1.0]),
                             ("names.json", "output_names", "y1")):
        (tmp_path / name).write_text(json.dumps({**content, key: value}))
    return tmp_path


CASES = [
    (["fit", "empty.csv", *IO], "empty.csv is empty"),
    (["fit", "header.csv", *IO], "has no data rows"),
    (["fit", "one.csv", *IO], "a single time stamp"),
    (["fit", "text.csv", *IO], "'a' is not a number"),
    (["fit", "complex.csv", *IO], "'1j' is not a number"),
    (["fit", "inf.csv", *IO], "inf is not a finite number"),
    (["fit", "no_inputs.npz"], "u has shape (100, 0)"),
    (["fit", "no_samples.npz"], "u has shape (0,)"),
    (["fit", "good.csv", *IO, "--ts", "abc"], "'--ts': 'abc' is not a valid float"),
    (["fit", "good.csv", *IO, "--ts", "-1"], "Ts must be a positive finite number"),
    (["fit", "good.csv", *IO, "--ts", "nan"], "Ts must be a positive finite number"),
    (["fit", "good.csv", *IO, "--nmax", "abc"], "'--nmax': 'abc' is not a valid integer"),
    (["fit", "good.csv", *IO, "--nmax", "0"], "IdentifyOptions.nmax must be"),
    (["fit", "good.csv", *IO, "--validation", "2"], "--validation must be a fraction"),
    (["fit", "good.csv", *IO, "--options", "options.json"], "IdentifyOptions.nmax must be"),
    (["fit", "good.csv", *IO, "--options", "options_cut.json"], "is not a JSON file"),
    (["fit", "good.csv", *IO, "--x0", "foo"], "'--x0': 'foo' is not one of"),
    (["fit", "good.csv", *IO, "--bogus"], "No such option '--bogus'"),
    (["fit", "good.csv", "--inputs", "u9", "--outputs", "y1"], "has no column 'u9'"),
    (["fit"], "give either DATA files or --daisy NAME"),
    (["validate", "cut.json", "good.csv"], "is not a JSON model file"),
    (["validate", "list.json", "good.csv"], "holds a JSON list"),
    (["validate", "text_matrix.json", "good.csv"], "A must be an array of real"),
    (["validate", "offset.json", "good.csv"], "y_offset must have 3 entries"),
    (["validate", "names.json", "good.csv"], "output_names must be a list of 3 names"),
    (["validate", "model.json", "one.csv"], "need at least two samples"),
    (["validate", "model.json", "good.csv", "--x0", "foo"], "'--x0': 'foo' is not one of"),
    (["validate", ".", "good.csv"], "cannot read the model file"),
    (["info", "cut.json"], "is not a JSON model file"),
    (["info"], "Missing argument 'MODEL'"),
    (["bogus"], "No such command 'bogus'"),
    (["fit-many", *IO, "--out", "many", "nothing*.csv"], "no file matches"),
    (["fit-many", *IO, "--out", "many", "good.csv", "--nmax", "abc"], "is not a valid integer"),
    (["validate-many", "no_folder", "good.csv"], "no folder of models"),
    (["demo", "--nmax", "0"], "IdentifyOptions.nmax must be"),
]


@pytest.mark.parametrize("args, message", CASES, ids=[" ".join(a) for a, _ in CASES])
def test_bad_command_lines_end_with_one_error_line(folder, monkeypatch, args, message):
    monkeypatch.chdir(folder)
    result = CliRunner().invoke(cli.cli, args, prog_name="moli")
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    # one error line, after any warning (a file without time says Ts = 1 was assumed)
    assert lines[-1].startswith("moli: error: "), result.stderr
    assert all(line.startswith("moli: warning: ") for line in lines[:-1]), result.stderr
    assert message in lines[-1]
    assert "Traceback" not in result.output


def test_help_still_shows_the_usage(folder):
    result = CliRunner().invoke(cli.cli, ["fit", "--help"], prog_name="moli")
    assert result.exit_code == 0 and "Usage: moli fit" in result.output
