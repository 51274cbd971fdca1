"""``moli fit-many`` and ``moli validate-many`` on folders of CSV records."""

from __future__ import annotations

import csv
import os
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner, Result

import moli
from moli.app import cli
from moli.data.files import file_sha256
from moli.app import fleet_files
from moli.fleets import FleetEntry
from moli.fleets import records as fleet_module

CHANNELS = ["--inputs", "u1,u2,u3", "--outputs", "y1,y2,y3"]
OPTIONS = moli.IdentifyOptions(nmax=4)
# In a worker process this module is imported afresh, so this is the unpatched function.
IDENTIFY_ONE = fleet_module._identify_one
# Far over the second a 400-sample record takes on a loaded machine, so only the stuck record meets it.
TIMEOUT_SECONDS = 10


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
    assert "4 records on 2 processes" in done.output and "3 models" in done.output
    assert "failed: broken: DataError:" in done.stderr and "line 3, column 'y1'" in done.stderr
    assert "fleet" in done.stderr  # the progress bar
    summary = rows(out / "summary.csv")
    assert list(summary) == ["broken", "loop0", "loop1", "loop2"]  # the files' sorted order
    assert [row["status"] for row in summary.values()] == ["failed", "identified", "identified", "identified"]
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
        assert saved.info["data"]["file_sha256"] == file_sha256(plant / f"loop{k}.csv")
        assert moli.IdentifyOptions.from_dict(saved.info["options"]) == OPTIONS
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
        (["fit-many", "x.csv", *CHANNELS, "--resume", "--force"],
         "give either --resume (keep the models already made) or --force (redo them all)"),
        (["fit-many", "x.csv", *CHANNELS, "--timeout", "5", "--scheduler", "tcp://h:8786"],
         "--timeout ends the worker process of a record that runs too long: it needs local processes "
         "(--workers), not --scheduler"),
    ],
)
def test_bad_arguments_are_one_line_and_exit_2(args, message):
    done = run(*args)
    assert done.exit_code == 2 and done.stderr.strip() == f"moli: error: {message}"


def test_resume_keeps_the_models_of_the_same_options_and_files_and_redoes_the_others(tmp_path, plant):
    out = tmp_path / "models"
    loops = str(plant / "loop*.csv")
    first = run("fit-many", loops, *CHANNELS, "--nmax", "4", "--workers", "1", "--out", str(out))
    assert first.exit_code == 0, first.output + first.stderr
    made = {k: (out / f"loop{k}.json").stat().st_mtime_ns for k in range(3)}
    moli.to_dataframe(moli.example_data(N=400, seed=7)).to_csv(plant / "loop1.csv")  # the record changed
    again = run("fit-many", loops, *CHANNELS, "--nmax", "4", "--workers", "1", "--out", str(out), "--resume")
    assert again.exit_code == 0, again.output + again.stderr
    assert "redone: loop1: its file is not the one the model was made from (another SHA-256)" in again.stderr
    assert {name: row["status"] for name, row in rows(out / "summary.csv").items()} == {
        "loop0": "kept", "loop1": "identified", "loop2": "kept"}
    assert [(out / f"loop{k}.json").stat().st_mtime_ns == made[k] for k in range(3)] == [True, False, True]
    assert "3 models in" in again.output and "(2 kept from an earlier run)" in again.output
    expected = moli.identify(moli.read_data(plant / "loop1.csv", ["u1", "u2", "u3"], ["y1", "y2", "y3"]),
                             options=OPTIONS)
    np.testing.assert_array_equal(moli.load_model(out / "loop1.json").A, expected.model.A)
    other = run("fit-many", loops, *CHANNELS, "--nmax", "3", "--workers", "1", "--out", str(out), "--resume")
    assert other.exit_code == 0, other.output + other.stderr
    assert other.stderr.count("its model was made with other options: nmax 4, not 3") == 3
    assert all(row["status"] == "identified" for row in rows(out / "summary.csv").values())
    assert all(moli.load_model(out / f"loop{k}.json").info["options"]["nmax"] == 3 for k in range(3))


def hangs_on_stuck(name, item, options, read_options):
    """_identify_one, except that the record named 'stuck' never ends."""
    if name == "stuck":
        time.sleep(3600)
    return IDENTIFY_ONE(name, item, options, read_options)


def test_a_record_over_its_timeout_is_ended_and_listed(tmp_path, plant, monkeypatch):
    (plant / "broken.csv").unlink()
    (plant / "stuck.csv").write_text((plant / "loop0.csv").read_text())
    monkeypatch.setattr(fleet_module, "_identify_one", hangs_on_stuck)
    out = tmp_path / "models"
    # one worker: the records run one after the other, so the two after the stuck one show
    # that its worker was ended and another took over
    done = run("fit-many", str(plant / "*.csv"), *CHANNELS, "--nmax", "4", "--workers", "1",
               "--timeout", str(TIMEOUT_SECONDS), "--out", str(out))
    assert done.exit_code == 1, done.output + done.stderr
    assert "4 records on 1 process" in done.output and "3 models" in done.output
    assert "1 failed (1 timed out)" in done.output
    assert f"timed out: stuck: RecordTimeoutError: ran longer than the {TIMEOUT_SECONDS} s allowed" in done.stderr
    table = rows(out / "summary.csv")
    assert table["stuck"]["status"] == "timed out" and float(table["stuck"]["seconds"]) == TIMEOUT_SECONDS
    assert sorted(path.stem for path in out.glob("*.json")) == ["loop0", "loop1", "loop2"]


def test_a_warning_of_every_record_is_told_once_with_the_paths_as_given(tmp_path, monkeypatch):
    plant = tmp_path / "plant"
    plant.mkdir()
    for k in range(3):
        # no time column: each record warns that Ts = 1 is assumed, the same words but for its file
        moli.to_dataframe(moli.example_data(N=400, seed=k)).to_csv(plant / f"loop{k}.csv", index=False)
    monkeypatch.chdir(tmp_path)
    done = run("fit-many", "plant/*.csv", *CHANNELS, "--nmax", "4", "--workers", "2", "--out", "models")
    assert done.exit_code == 0, done.output + done.stderr
    told = [line for line in done.stderr.splitlines() if "Ts = 1 is assumed" in line]
    assert len(told) == 1 and told[0].startswith("  warning: 3 records (loop0, loop1, loop2): <file>: no time column")
    page = (tmp_path / "models" / "summary.html").read_text()
    assert page.count("Ts = 1 is assumed") == 1 and "<b>W1</b>, 3 records (loop0, loop1, loop2)" in page
    table = rows(tmp_path / "models" / "summary.csv")
    assert table["loop0"]["warnings"].startswith("plant/loop0.csv: no time column")  # the CSV keeps each row's own
    for text in (done.stderr, page, (tmp_path / "models" / "summary.csv").read_text()):
        assert str(tmp_path) not in text and os.sep + "plant" not in text  # no absolute path


def test_validate_many_does_not_overwrite_its_tables_without_force(tmp_path, plant):
    models = tmp_path / "models"
    run("fit-many", str(plant / "loop0.csv"), *CHANNELS, "--nmax", "4", "--workers", "1", "--out", str(models))
    assert run("validate-many", str(models), str(plant / "loop0.csv")).exit_code == 0
    written = (models / "validation.csv").stat().st_mtime_ns
    again = run("validate-many", str(models), str(plant / "loop0.csv"))
    assert again.exit_code == 2 and again.stderr.strip() == (
        f"moli: error: {models / 'validation.csv'} exists: give --force to overwrite it, or --out to write elsewhere")
    assert (models / "validation.csv").stat().st_mtime_ns == written
    forced = run("validate-many", str(models), str(plant / "loop0.csv"), "--force")
    assert forced.exit_code == 0, forced.output + forced.stderr


def test_a_slow_summary_is_rewritten_only_once_its_spacing_has_passed(tmp_path, monkeypatch):
    monkeypatch.setattr(fleet_files, "ALWAYS_REWRITTEN_ROWS", 0)     # every summary counts as large
    monkeypatch.setattr(fleet_files, "WRITE_SPACING", 1e9)         # and the spacing never passes
    sources = {name: tmp_path / f"{name}.csv" for name in ("a", "b")}
    summary = fleet_files.FleetSummary(sources, tmp_path)
    summary.add(FleetEntry("a", None, "DataError: bad", 0.1), {})  # the first: nothing written yet
    summary.add(FleetEntry("b", None, "DataError: bad", 0.1), {})  # deferred
    assert list(rows(tmp_path / "summary.csv")) == ["a"]
    summary.write("2 records on this process")
    assert list(rows(tmp_path / "summary.csv")) == ["a", "b"]
