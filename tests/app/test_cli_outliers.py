"""The command line on outliers and on what its scores mean."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

import moli
from moli.app import cli
from moli.app.fleet_report import SCORES

IO = ["--inputs", "u1,u2,u3", "--outputs", "y1,y2,y3", "--nmax", "4"]


@pytest.fixture
def spiked_csv(tmp_path: Path) -> Path:
    data = moli.example_data(N=600, seed=4)
    y = data.y.copy()
    y[[100, 250, 400], 1] += 12 * y[:, 1].std()  # three glitches on y2
    moli.to_dataframe(moli.IOData(y, data.u)).to_csv(tmp_path / "plant.csv")
    return tmp_path / "plant.csv"


def run(*args: str):
    return CliRunner().invoke(cli.cli, list(args), prog_name="moli")


def test_fit_warns_about_outliers_and_keeps_them_by_default(spiked_csv, tmp_path):
    result = run("fit", str(spiked_csv), *IO, "--out", str(tmp_path / "m.json"))
    assert result.exit_code == 0, result.output
    assert "moli: warning: output 'y2' has 3 outlier(s), the first at sample 100" in result.stderr
    saved = json.loads((tmp_path / "m.json").read_text())
    assert saved["info"]["data"]["outliers_removed"] == {}


def test_fit_with_outliers_remove_interpolates_them_and_records_it(spiked_csv, tmp_path):
    result = run("fit", str(spiked_csv), *IO, "--outliers", "remove", "--out", str(tmp_path / "m.json"))
    assert result.exit_code == 0, result.output
    assert "outliers replaced by linear interpolation: {'y2': 3}" in result.stdout
    assert "outlier" not in result.stderr  # nothing left to warn about
    saved = json.loads((tmp_path / "m.json").read_text())
    assert saved["info"]["data"]["outliers_removed"] == {"y2": 3}


def test_validate_says_what_vaf_and_fit_are(tmp_path):
    data = moli.example_data(N=300, seed=5)
    moli.to_dataframe(data).to_csv(tmp_path / "plant.csv")
    plant = moli.example_plant()
    plant.save(tmp_path / "m.json")
    result = run("validate", str(tmp_path / "m.json"), str(tmp_path / "plant.csv"),
                 "--plot", str(tmp_path / "v.png"))
    assert result.exit_code == 0, result.output
    assert SCORES in result.stdout
    for words in ("clipped at 0", "not clipped", "simulation", "not a prediction"):
        assert words in SCORES
