"""``moli fit-many`` and ``moli validate-many`` on folders of CSV records."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner, Result

import moli
from moli.app import cli

CHANNELS = ["--inputs", "u1,u2,u3", "--outputs", "y1,y2,y3"]
OPTIONS = moli.IdentifyOptions(nmax=4)


def run(*args: str) -> Result:
    return CliRunner().invoke(cli.cli, list(args), prog_name="moli")


def rows(path: Path) -> dict[str, dict[str, str]]:
    with path.open(newline="") as handle:
        return {row["name"]: row for row in csv.DictReader(handle)}


@pytest.fixture
def plant(tmp_path: Path) -> Path:
    """Three loops' records and one corrupt file."""
    folder = tmp_path / "plant"
    folder.mkdir()
    for k in range(3):
        moli.to_dataframe(moli.example_data(N=400, seed=k)).to_csv(folder / f"loop{k}.csv")
    (folder / "broken.csv").write_text("time,u1,u2,u3,y1,y2,y3\n0,1,2,3,4,5,6\n1,1,2,3,oops,5,6\n")
    return folder


def test_fit_many_writes_a_model_per_record_and_lists_failures(tmp_path, plant):
    out = tmp_path / "models"
    done = run("fit-many", str(plant / "*.csv"), *CHANNELS, "--nmax", "4", "--workers", "2", "--out", str(out))
    assert done.exit_code == 1, done.output + done.stderr  # a record failed: scripts must notice
    assert "4 records on loky, 2 processes" in done.output and "3 models" in done.output
    assert "failed: broken: DataError:" in done.stderr and "line 3, column 'y1'" in done.stderr
    assert "fleet" in done.stderr  # the progress bar
    summary = rows(out / "summary.csv")
    assert list(summary) == ["broken", "loop0", "loop1", "loop2"]  # the files' sorted order
    assert summary["broken"]["fit"] == "" and "line 3, column 'y1'" in summary["broken"]["error"]
    for k in range(3):
        # the independent truth: identify on the record read back from its file
        data = moli.read_data(plant / f"loop{k}.csv", ["u1", "u2", "u3"], ["y1", "y2", "y3"])
        expected = moli.identify(data, options=OPTIONS)
        saved = moli.load_model(out / f"loop{k}.json")
        np.testing.assert_array_equal(saved.A, expected.model.A)
        fit = np.mean(moli.compare(expected.model, expected.validation).fit)
        assert saved.info["validation_fit"] == fit and float(summary[f"loop{k}"]["fit"]) == fit
        assert saved.info["data"]["source"] == str(plant / f"loop{k}.csv")
    page = (out / "summary.html").read_text()
    assert "sortBy(2)" in page and "<h2>Failures</h2>" in page and "broken" in page
    assert not (out / "broken.json").exists()


def test_validate_many_flags_the_loop_whose_fit_dropped(tmp_path, plant):
    models = tmp_path / "models"
    run("fit-many", str(plant / "loop*.csv"), *CHANNELS, "--nmax", "4", "--workers", "1", "--out", str(models))
    new = tmp_path / "new"
    new.mkdir()
    for k in range(3):
        data = moli.example_data(N=400, seed=10 + k)
        if k == 1:  # loop1's plant changed: its outputs now come from another system
            data = moli.IOData(data.y[::-1], data.u, output_names=data.output_names,
                               input_names=data.input_names)
        moli.to_dataframe(data).to_csv(new / f"loop{k}.csv")
    (new / "stray.csv").write_text((new / "loop0.csv").read_text())
    done = run("validate-many", str(models), str(new / "*.csv"), "--max-drop", "10")
    assert done.exit_code == 1, done.output + done.stderr
    table = rows(models / "validation.csv")
    assert {name: row["status"] for name, row in table.items()} == {
        "loop0": "ok", "loop1": "dropped", "loop2": "ok", "stray": "no model"}
    model = moli.load_model(models / "loop1.json")
    now = moli.compare(model, moli.read_data(new / "loop1.csv", model.input_names, model.output_names))
    assert float(table["loop1"]["fit_now"]) == pytest.approx(np.mean(now.fit), abs=1e-9)  # CSV keeps 15+ digits
    assert float(table["loop1"]["drop"]) > 10
    assert "4 loops, 2 flagged" in done.output
    clean = run("validate-many", str(models), str(new / "loop[02].csv"), "--out", str(tmp_path / "check"))
    assert clean.exit_code == 0, clean.output
    assert rows(tmp_path / "check" / "validation.csv")["loop1"]["status"] == "no new record"


@pytest.mark.parametrize(
    "args, message",
    [
        (["fit-many", "nowhere/*.csv", *CHANNELS], "no file matches 'nowhere/*.csv'"),
        (["fit-many", "x.csv", *CHANNELS, "--workers", "2", "--scheduler", "tcp://h:8786"],
         "give either --workers (local processes) or --scheduler, not both"),
        (["validate-many", "no-such-folder", "x.csv"], "no folder of models at no-such-folder"),
    ],
)
def test_bad_arguments_are_one_line_and_exit_2(args, message):
    done = run(*args)
    assert done.exit_code == 2 and done.stderr.strip() == f"moli: error: {message}"
