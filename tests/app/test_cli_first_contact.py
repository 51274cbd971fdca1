"""What a new user meets first: where the files go, nothing overwritten, several runs,
Ctrl-C late in a fit, short records, and a report that says what the console said."""

from __future__ import annotations

import csv
import html
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

import moli
from moli.app import cli
from moli.method.pipeline import finishing

INPUTS, OUTPUTS = "u1,u2,u3", "y1,y2,y3"
NMAX = "4"  # the path 3, 4: fast, and enough for an order rule
CHANNELS = ["--inputs", INPUTS, "--outputs", OUTPUTS, "--nmax", NMAX]


def run(*args: str) -> Result:
    return CliRunner().invoke(cli.cli, list(args), prog_name="moli")


def table(path: Path, N: int, seed: int) -> Path:
    moli.to_dataframe(moli.example_data(N=N, seed=seed)).to_csv(path)
    return path


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    table(tmp_path / "plant.csv", 400, 3)
    return tmp_path


def test_fit_writes_model_and_report_into_a_folder_of_its_own(folder):
    done = run("fit", "plant.csv", *CHANNELS)
    assert done.exit_code == 0, done.stderr
    assert sorted(p.name for p in folder.iterdir()) == ["moli-fit-plant", "plant.csv"]
    assert moli.load_model(folder / "moli-fit-plant" / "model.json").p == 3
    assert (folder / "moli-fit-plant" / "report" / "report.html").is_file()
    assert "model written to moli-fit-plant/model.json" in done.output


def test_a_second_fit_never_overwrites_without_force(folder):
    assert run("fit", "plant.csv", *CHANNELS, "--out", "m.json").exit_code == 0
    before = (folder / "m.json").read_bytes()
    again = run("fit", "plant.csv", *CHANNELS, "--nmax", "3", "--out", "m.json")
    assert again.exit_code == 2
    assert again.stderr.strip() == "moli: error: m.json exists: give --force to overwrite it, or --out to write elsewhere"
    assert "structure search" not in again.stderr        # refused before any work
    assert (folder / "m.json").read_bytes() == before
    forced = run("fit", "plant.csv", *CHANNELS, "--nmax", "3", "--out", "m.json", "--force")
    assert forced.exit_code == 0, forced.stderr
    assert moli.load_model(folder / "m.json").n == 3


def test_an_existing_report_is_not_overwritten_either(folder):
    (folder / "rep").mkdir()
    (folder / "rep" / "report.html").write_text("mine")
    refused = run("fit", "plant.csv", *CHANNELS, "--out", "m.json", "--report", "rep")
    assert refused.exit_code == 2 and "rep/report.html exists" in refused.stderr
    assert (folder / "rep" / "report.html").read_text() == "mine"
    assert not (folder / "m.json").exists()


def test_validate_writes_its_figure_into_its_output_folder(folder):
    assert run("fit", "plant.csv", *CHANNELS, "--out", "m.json").exit_code == 0
    checked = run("validate", "m.json", "plant.csv")
    assert checked.exit_code == 0, checked.stderr
    assert not (folder / "validation.png").exists()
    assert (folder / "moli-validate-plant" / "validation.png").stat().st_size > 1000
    assert run("validate", "m.json", "plant.csv").exit_code == 2       # not overwritten
    assert run("validate", "m.json", "plant.csv", "--out", "v").exit_code == 0
    assert (folder / "v" / "validation.png").is_file()


def test_several_runs_are_merged_as_experiments(folder):
    table(folder / "run1.csv", 300, 4)
    table(folder / "run2.csv", 300, 5)
    done = run("fit", "run1.csv", "run2.csv", *CHANNELS)
    assert done.exit_code == 0, done.stderr
    assert "(the 2 files merged)" in done.output
    # 600 samples in 2 segments; the held-out 30 % is the tail of run2
    assert "estimation: 420 samples in 2 segments; validation: 180 samples (held out: last 30% " \
           "of the record, from run2.csv)" in done.output
    model = moli.load_model(folder / "moli-fit-run1+run2" / "model.json")
    assert model.info["data"]["source"] == "run1.csv, run2.csv"
    assert len(model.info["data"]["file_sha256"]) == 2
    scored = run("validate", str(folder / "moli-fit-run1+run2" / "model.json"), "run1.csv", "run2.csv")
    assert scored.exit_code == 0, scored.stderr
    assert "run1.csv, run2.csv: 2 records, 600 samples" in scored.output


def test_runs_sampled_differently_are_refused_by_name(folder):
    other = moli.to_dataframe(moli.example_data(N=300, seed=4))
    other.index = other.index * 2          # the time column: sampled every 2 s, plant.csv every 1 s
    other.to_csv(folder / "other.csv")
    done = run("fit", "plant.csv", "other.csv", *CHANNELS)
    assert done.exit_code == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "record 1 = other.csv" in done.stderr and "Ts = 2" in done.stderr


def test_the_held_out_part_is_not_called_given(folder):
    done = run("fit", "plant.csv", *CHANNELS)
    assert "(given)" not in done.output
    assert "validation: 120 samples (held out: last 30% of the record)" in done.output
    page = (folder / "moli-fit-plant" / "report" / "report.html").read_text()
    assert "(given)" not in page and "held out: last 30% of the record" in page
    assert "on 120 validation samples" in page


def test_a_tiny_record_warns_on_the_console_in_the_report_and_in_the_model(folder):
    table(folder / "tiny.csv", 49, 3)
    done = run("fit", "tiny.csv", "--inputs", INPUTS, "--outputs", OUTPUTS)
    assert done.exit_code == 0, done.stderr
    assert "moli: warning: the order was chosen on 15 validation samples" in done.stderr
    assert "on 15 validation samples" in done.output
    model = moli.load_model(folder / "moli-fit-tiny" / "model.json")
    printed = [line.removeprefix("moli: warning: ") for line in done.stderr.splitlines()
               if line.startswith("moli: warning: ")]
    assert model.info["warnings"] == printed
    page = (folder / "moli-fit-tiny" / "report" / "report.html").read_text()
    for message in printed:         # every warning the console printed is in the report
        assert html.escape(message) in page


def test_ctrl_c_during_the_covariance_keeps_the_model_and_says_what_was_cut(folder, monkeypatch):
    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(finishing, "estimate_covariance", interrupt)
    done = run("fit", "plant.csv", *CHANNELS)
    assert done.exit_code == 3, done.stderr   # a model written from a partial run
    assert "moli: interrupted; keeping the model before the covariance (skipped: covariance, noise model)" \
        in done.stderr
    model = moli.load_model(folder / "moli-fit-plant" / "model.json")
    assert model.cov_factor is None and model.info["interrupted"] == {"skipped": ["covariance", "noise model"]}
    page = (folder / "moli-fit-plant" / "report" / "report.html").read_text()
    assert "Interrupted after the path: skipped covariance, noise model" in page


def test_fit_many_lists_each_records_warnings_and_uses_the_fit_default(folder):
    table(folder / "tiny.csv", 49, 3)
    done = run("fit-many", "plant.csv", "tiny.csv", "--inputs", INPUTS, "--outputs", OUTPUTS,
               "--workers", "1", "--out", "models")
    assert done.exit_code == 0, done.stderr
    rows = {row["name"]: row for row in csv.DictReader((folder / "models" / "summary.csv").open())}
    assert "chosen on 15 validation samples" in rows["tiny"]["warnings"]
    assert rows["tiny"]["validation_N"] == "15"
    assert "warning: tiny: the order was chosen on 15" in done.stderr
    # the same record gives the same model through fit and fit-many (same default preset)
    assert run("fit", "tiny.csv", "--inputs", INPUTS, "--outputs", OUTPUTS, "--out", "t.json").exit_code == 0
    one, many = moli.load_model(folder / "t.json"), moli.load_model(folder / "models" / "tiny.json")
    assert one.info["options"] == many.info["options"] and one.indices == many.indices
    assert "[default: default]" in " ".join(run("fit-many", "--help").output.split())
    # and a second fit-many into the same folder is refused
    again = run("fit-many", "plant.csv", "--inputs", INPUTS, "--outputs", OUTPUTS, "--out", "models")
    assert again.exit_code == 2 and "models/summary.csv exists" in again.stderr
