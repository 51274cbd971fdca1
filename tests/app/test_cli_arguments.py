"""Command-line arguments at their edges: one ``moli: error:`` line and exit code 2 before any
work, never a traceback, never a destroyed file (docs/cli.md, "Exit codes")."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import numpy as np
import pytest

import moli
from cli_util import assert_clean_error, run


CHANNELS = ["--inputs", "u1", "--outputs", "y1"]


def siso(N: int = 300) -> moli.IOData:
    u = np.random.default_rng(0).standard_normal(N)
    return moli.IOData(moli.StateSpaceModel([[0.8]], [[0.5]], [[1.0]]).simulate(u)[:, 0], u)


def write_csv(path: Path, data: moli.IOData) -> Path:
    moli.to_dataframe(data).to_csv(path)
    return path


def model() -> moli.StateSpaceModel:
    return moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]])


@pytest.fixture
def plant(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    return write_csv(tmp_path / "plant.csv", siso())


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_an_out_that_is_a_pipe_is_refused_and_left_a_pipe(plant, tmp_path):
    pipe = tmp_path / "pipe"
    os.mkfifo(pipe)
    assert_clean_error(run("fit", str(plant), *CHANNELS, "--nmax", "2", "--out", str(pipe), "--force"),
                       "a device, a pipe or a socket")
    assert stat.S_ISFIFO(pipe.stat().st_mode)      # an atomic write would have put a file in its place
    with pytest.raises(moli.ModelFileError, match="a device, a pipe or a socket"):
        model().save(pipe)


def test_a_figure_suffix_no_format_has_is_refused_before_the_scores(plant, tmp_path):
    model().save(tmp_path / "m.json")
    done = run("validate", "m.json", str(plant), "--plot", str(tmp_path / "fig.txt"))
    assert_clean_error(done, "names no figure format")
    assert done.stdout == ""


@pytest.mark.parametrize("data", [5, "x", {"sha256": 5, "N": 3}, {"sha256": "ab"}])
def test_info_describes_a_model_whose_data_record_is_not_moli_s(tmp_path, data):
    path = tmp_path / "m.json"
    model().save(path)
    content = json.loads(path.read_text())
    content["info"]["data"] = data
    path.write_text(json.dumps(content))
    done = run("info", str(path))
    assert done.exit_code == 0 and "Traceback" not in done.stderr, done.stderr


@pytest.mark.parametrize("flags, message", [
    (["--timeout", "inf"], "--timeout"),               # waits count milliseconds in 32 bits
    (["--timeout", "3e6"], "--timeout"),
    (["--scheduler", "garbage"], "--scheduler"),
    (["--ts", "-1"], "Ts must be a positive"),          # each record failed with it
    (["--ts", "1e-310"], "Ts = 1e-310 lies outside"),
])
def test_fit_many_refuses_bad_flags_before_any_record(plant, tmp_path, flags, message):
    assert_clean_error(run("fit-many", str(plant), *CHANNELS, "--nmax", "2", "--out", str(tmp_path / "fleet"),
                           *flags), message)
    assert not (tmp_path / "fleet").exists()


def test_fit_many_refuses_a_channel_named_twice(plant, tmp_path):
    assert_clean_error(run("fit-many", str(plant), "--inputs", "u1,u1", "--outputs", "y1", "--out",
                           str(tmp_path / "fleet")), "each named once")


def test_validate_many_refuses_a_max_drop_that_flags_nothing(plant, tmp_path):
    folder = tmp_path / "models"
    folder.mkdir()
    model().save(folder / "plant.json")
    assert_clean_error(run("validate-many", str(folder), str(plant), "--max-drop", "nan"), "--max-drop")


def test_an_encoding_that_reads_no_text_file_is_refused(plant, tmp_path):
    assert_clean_error(run("fit", str(plant), *CHANNELS, "--encoding", "rot13"), "unknown text encoding")
    bare = tmp_path / "utf16.csv"
    bare.write_bytes(plant.read_text().encode("utf-16-le"))          # no byte-order mark
    assert_clean_error(run("fit", str(bare), *CHANNELS, "--encoding", "utf-16"), "give the byte order")


def test_folders_where_files_are_expected_are_named_as_folders(plant, tmp_path):
    (tmp_path / "dir.json").mkdir()
    (tmp_path / "dir.csv").mkdir()
    assert_clean_error(run("fit", str(plant), *CHANNELS, "--options", "dir.json"), "--options: cannot read")
    assert_clean_error(run("fit", "dir.csv", *CHANNELS), "is a folder, not a data file")


def test_a_time_format_that_does_not_match_says_so(plant):
    assert_clean_error(run("fit", str(plant), *CHANNELS, "--time-format", "%Y"), "is not a time in the format")


def test_a_constant_output_prints_no_numpy_warning(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    u = np.random.default_rng(1).standard_normal((300, 1))
    y = np.column_stack([moli.StateSpaceModel([[0.8]], [[0.5]], [[1.0]]).simulate(u)[:, 0], np.zeros(300)])
    write_csv(tmp_path / "flat.csv", moli.IOData(y, u))
    done = run("fit", "flat.csv", "--inputs", "u1", "--outputs", "y1,y2", "--nmax", "3", "--out", "m.json")
    assert done.exit_code == 0, done.stderr
    assert "overflow" not in done.stderr and "RuntimeWarning" not in done.stderr, done.stderr


def test_info_prints_a_huge_pole_in_a_few_digits(tmp_path):
    path = tmp_path / "m.json"
    moli.StateSpaceModel([[1e300]], [[1.0]], [[1.0]]).save(path)
    done = run("info", str(path))
    assert done.exit_code == 0, done.stderr
    # fixed decimals printed all 301 digits of the pole
    assert "1e+300" in done.stdout and max(map(len, done.stdout.splitlines())) < 120
