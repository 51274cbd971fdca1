"""Every long phase of ``moli fit`` and ``moli fit-many`` shows on stderr while it runs."""

from __future__ import annotations

import json
import re
from pathlib import Path

from click.testing import CliRunner, Result

import moli
from moli.app import cli, progress

CHANNELS = ("--inputs", "u1,u2,u3", "--outputs", "y1,y2,y3")


def run(*args: str) -> Result:
    return CliRunner().invoke(cli.cli, list(args), prog_name="moli")


def test_fit_names_each_phase_on_stderr(tmp_path, monkeypatch):
    moli.to_dataframe(moli.example_data(N=800, seed=2)).to_csv(tmp_path / "plant.csv")
    # a search window shorter than the 560 estimation samples: the whole-record re-estimation runs too
    (tmp_path / "options.json").write_text(json.dumps({"search_samples": 500, "nmax": 4}))
    monkeypatch.setattr(cli, "READING_SHOWN_AFTER", 0.0)   # a small file reads faster than the delay
    done = run("fit", str(tmp_path / "plant.csv"), *CHANNELS, "--options", str(tmp_path / "options.json"),
               "--out", str(tmp_path / "model.json"), "--report", str(tmp_path / "report"))
    assert done.exit_code == 0, done.stderr
    shown = done.stderr.replace("\r", "\n")
    phases = ["reading", "structure search", "re-estimation on the whole record", "refinement",
              "covariance", "noise model", "report"]
    # each phase's line, in the order the phases run; each but the search's ends with its time
    starts = [shown.find(name) for name in phases]
    assert -1 not in starts and starts == sorted(starts), shown
    for name in phases[2:]:
        assert re.search(rf"^{name}: \d\d:\d\d$", shown, flags=re.M), (name, shown)
    assert re.search(r"^reading \S*plant.csv: \d\d:\d\d$", shown, flags=re.M), shown


def test_a_phase_shorter_than_its_delay_shows_nothing(capsys):
    with progress.Phases() as phases:
        phases.shown_after("reading quick.csv", 60.0)
    with progress.Phases() as phases:
        phases.shown_after("reading slow.csv", 0.0)
    err = capsys.readouterr().err
    assert "quick.csv" not in err
    assert "reading slow.csv: 00:00" in err


def test_fit_many_shows_the_fleet_and_the_summary(tmp_path):
    for k in range(2):
        moli.to_dataframe(moli.example_data(N=400, seed=k)).to_csv(tmp_path / f"loop{k}.csv")
    done = run("fit-many", str(tmp_path / "loop*.csv"), *CHANNELS, "--nmax", "4", "--workers", "1",
               "--out", str(tmp_path / "models"))
    assert done.exit_code == 0, done.stderr
    # the bar over the records; each model is saved as its record finishes, so no saving phase follows
    assert "fleet" in done.stderr and "2/2" in done.stderr and "saving" not in done.stderr
