"""Hostile inputs: interrupted and racing writes, names that are code, files that are bombs,
numbers at the edges of double precision. moli loses nothing and injects nothing."""

from __future__ import annotations

import csv
import errno
import json
import os
import re
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import moli
from cli_util import assert_clean_error, run
from moli.app.figures import measured_vs_simulated
from moli.app.fleet_report import write_summary
from moli.data import atomic_files
from moli.data.clocks import period_kind
from moli.data.display import FIGURE_LABEL_CHARS, REPORT_NAME_CHARS, figure_label
from moli.errors import DataError, ModelFileError

CHANNELS = ["--inputs", "u1", "--outputs", "y1"]




def siso(N: int = 300, seed: int = 0, names: tuple[str, str] = ("y1", "u1")) -> moli.IOData:
    u = np.random.default_rng(seed).standard_normal(N)
    y = moli.StateSpaceModel([[0.8]], [[0.5]], [[1.0]]).simulate(u)[:, 0]
    return moli.IOData(y, u, output_names=[names[0]], input_names=[names[1]])


def write_csv(path: Path, data: moli.IOData) -> Path:
    moli.to_dataframe(data).to_csv(path)
    return path


def model(n: int = 1) -> moli.StateSpaceModel:
    return moli.StateSpaceModel(0.5 * np.eye(n), np.ones((n, 1)), np.ones((1, n)))


# --- writes: whole or not at all ---------------------------------------------------------

def test_a_write_killed_before_its_rename_keeps_the_old_model(tmp_path, monkeypatch):
    path = tmp_path / "model.json"
    model(1).save(path)
    before = path.read_bytes()

    def killed(*args):
        raise KeyboardInterrupt  # the process stops between writing and renaming

    monkeypatch.setattr(atomic_files.os, "replace", killed)
    with pytest.raises(KeyboardInterrupt):
        model(3).save(path)
    assert path.read_bytes() == before
    assert os.listdir(tmp_path) == ["model.json"]  # no temporary file left behind


def test_a_full_disk_keeps_the_old_model(tmp_path, monkeypatch):
    path = tmp_path / "model.json"
    model(1).save(path)
    before = path.read_bytes()

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(atomic_files.os, "fsync", full)
    with pytest.raises(moli.ModelFileError, match="No space left"):
        model(3).save(path)
    assert path.read_bytes() == before and os.listdir(tmp_path) == ["model.json"]


def test_a_writer_killed_mid_write_leaves_the_old_model(tmp_path):
    path = tmp_path / "model.json"
    model(1).save(path)
    before = path.read_bytes()
    # a child that stops forever inside its write, then is killed with SIGKILL
    child = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import sys, time, numpy as np, moli
        from moli.data import atomic_files
        real = atomic_files.os.fsync
        def stall(fd):
            print("writing", flush=True); time.sleep(60)
        atomic_files.os.fsync = stall
        moli.StateSpaceModel(np.eye(40) * 0.5, np.ones((40, 1)), np.ones((1, 40))).save({str(path)!r})
    """)], stdout=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(Path(moli.__file__).parents[1])})
    assert child.stdout.readline().strip() == "writing"
    child.kill()
    child.wait(timeout=30)
    assert path.read_bytes() == before


def _stalled_writer(path: Path) -> subprocess.Popen:
    """A child that stops inside its save of ``path`` (after writing, before the rename)."""
    child = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import time, numpy as np, moli
        from moli.data import atomic_files
        def stall(fd):
            print("writing", flush=True); time.sleep(60)
        atomic_files.os.fsync = stall
        moli.StateSpaceModel(np.eye(4) * 0.5, np.ones((4, 1)), np.ones((1, 4))).save({str(path)!r})
    """)], stdout=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(Path(moli.__file__).parents[1])})
    assert child.stdout.readline().strip() == "writing"
    return child


def _age(path: Path, seconds: float) -> None:
    past = path.stat().st_mtime - seconds
    os.utime(path, (past, past))


def test_the_next_save_removes_a_killed_writers_leftover_but_not_a_live_ones(tmp_path):
    path = tmp_path / "model.json"
    killed = _stalled_writer(path)
    killed.kill()
    killed.wait(timeout=30)
    [leftover] = tmp_path.glob(".model.json.*.part")
    live = _stalled_writer(tmp_path / "other.json")    # a save in progress beside this one
    try:
        [writing] = tmp_path.glob(".other.json.*.part")
        for name in (leftover, writing):  # both unchanged past the grace a writer elsewhere gets
            _age(name, 2 * atomic_files.GRACE_SECONDS)
        model(1).save(path)
        assert not leftover.exists() and writing.exists()
        assert moli.load_model(path).n == 1
    finally:
        live.kill()
        live.wait(timeout=30)


def test_only_moli_temporary_files_of_ended_writers_are_removed(tmp_path):
    ended = subprocess.Popen([sys.executable, "-c", "pass"])
    ended.wait(timeout=30)
    names = {
        f".model.json.{ended.pid}.abcd_123.part": False,     # its writer ended: removed
        f".model.json.{os.getpid()}.abcd_124.part": True,    # this process is alive: kept
        ".model.json.abcd1234.part": True,                   # no process id: not named by moli
        f"model.json.{ended.pid}.abcd1234.part": True,       # not hidden: not named by moli
        f".notes.{ended.pid}.abcd1234.part.bak": True,
        ".notes.part": True,
    }
    for name in names:
        (tmp_path / name).write_text("partial")
        _age(tmp_path / name, 2 * atomic_files.GRACE_SECONDS)
    recent = tmp_path / f".report.html.{ended.pid}.abcd1235.part"
    recent.write_text("partial")   # changed within the grace: a writer on another machine may own it
    stale = tmp_path / f".report.html.{os.getpid()}.abcd1236.part"
    stale.write_text("partial")
    _age(stale, 2 * atomic_files.STALE_SECONDS)   # unchanged for two days: its id was reused
    model(1).save(tmp_path / "model.json")
    assert {name: (tmp_path / name).exists() for name in names} == names
    assert recent.exists() and not stale.exists()


def test_two_concurrent_writers_leave_one_complete_model(tmp_path):
    path = tmp_path / "model.json"
    model(5).save(path)
    script = textwrap.dedent("""
        import sys, numpy as np, moli
        n = int(sys.argv[1])
        m = moli.StateSpaceModel(np.eye(n) * 0.5, np.ones((n, 2)), np.ones((2, n)))
        for _ in range(60):
            m.save(sys.argv[2])
    """)
    env = {**os.environ, "PYTHONPATH": str(Path(moli.__file__).parents[1])}
    writers = [subprocess.Popen([sys.executable, "-c", script, str(n), str(path)], env=env) for n in (40, 5)]
    seen = set()
    while any(w.poll() is None for w in writers):  # a reader meanwhile always finds a whole model
        seen.add(moli.load_model(path).n)
    assert [w.wait(timeout=120) for w in writers] == [0, 0]
    assert seen <= {40, 5} and moli.load_model(path).n in (40, 5)


def test_an_unusable_out_is_refused_before_the_identification(tmp_path):
    data = write_csv(tmp_path / "plant.csv", siso())
    original = data.read_bytes()
    blocker = tmp_path / "afile"
    blocker.write_text("")
    assert_clean_error(run("fit", str(data), *CHANNELS, "--out", str(blocker / "model.json")), "is a file")
    assert_clean_error(run("fit", str(data), *CHANNELS, "--out", str(tmp_path)), "is a folder")
    assert_clean_error(run("fit", str(data), *CHANNELS, "--out", str(data)), "is an input of this run")
    assert data.read_bytes() == original          # the refused --out left the input as it was
    assert_clean_error(run("validate", str(data), str(data), "--plot", str(data)), "is an input")


def test_a_symbolic_link_at_out_is_replaced_not_followed(tmp_path):
    data = write_csv(tmp_path / "plant.csv", siso())
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    (tmp_path / "model.json").symlink_to(victim)
    args = ("fit", str(data), *CHANNELS, "--nmax", "2", "--out", str(tmp_path / "model.json"))
    assert_clean_error(run(*args), "exists: give --force")     # an existing file is kept...
    done = run(*args, "--force")                                # ...and --force replaces the link
    assert done.exit_code == 0, done.output + done.stderr
    assert victim.read_text() == "precious"
    assert not (tmp_path / "model.json").is_symlink() and moli.load_model(tmp_path / "model.json").n >= 1


# --- names are data -----------------------------------------------------------------------

def test_a_mathtext_channel_name_is_drawn_literally_in_the_report(tmp_path):
    data = write_csv(tmp_path / "plant.csv", siso(names=(r"flow $\frac{a}$", "valve $x")))
    done = run("fit", str(data), "--inputs", "valve $x", "--outputs", r"flow $\frac{a}$", "--nmax", "2",
               "--out", str(tmp_path / "model.json"), "--report", str(tmp_path / "report"))
    assert done.exit_code == 0, done.output + done.stderr
    assert (tmp_path / "report" / "report.html").stat().st_size > 1000


def test_long_names_are_shortened_in_figures():
    data = siso(names=("y" * 100_000, "u1"))
    fig = measured_vs_simulated(data, moli.compare(model(1), data))
    labels = [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel()]
    assert labels and all(len(label) <= FIGURE_LABEL_CHARS for label in labels)
    # escapes lengthen a name: counted before it is shortened, not after
    assert len(figure_label("$" * 100)) <= FIGURE_LABEL_CHARS
    assert len(figure_label("\n" * 100)) <= FIGURE_LABEL_CHARS


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet="ab$\\", min_size=1, max_size=80), st.integers(1, 40))
def test_a_name_cut_in_the_middle_keeps_its_ends_and_stays_literal(name, limit):
    label = figure_label(name, limit)
    assert len(label) <= limit
    escaped = name.replace("$", r"\$")
    if len(escaped) <= limit:
        assert label == escaped
    else:
        start, _, end = label.partition("…")
        # both ends of the escaped name, each at most a character short of its half
        assert escaped.startswith(start) and escaped.endswith(end)
        assert len(start) >= (limit - 1) - (limit - 1) // 2 - 1 and len(end) >= (limit - 1) // 2 - 1
        # every dollar still escaped: matplotlib draws the label as text, never as mathtext
        assert label.count("$") == label.count(r"\$")


def test_channels_that_differ_at_the_end_stay_apart_in_figures():
    names = [f"Plant1/Area2/Reactor3/Feed valve {k}.OP" for k in (101, 102)]
    assert len(set(figure_label(n, 28) for n in names)) == 2


def test_a_megabyte_channel_name_is_read_and_reported_whole_in_the_model_only(tmp_path):
    # unclosed brackets once made the period-column check quadratic in the name's length
    name = "flow (" + "(" * 1_000_000
    data = write_csv(tmp_path / "plant.csv", siso(names=(name, "u1")))
    done = run("fit", str(data), "--inputs", "u1", "--outputs", name, "--nmax", "2",
               "--out", str(tmp_path / "model.json"), "--report", str(tmp_path / "report"))
    assert done.exit_code == 0, done.output + done.stderr
    assert moli.load_model(tmp_path / "model.json").output_names == (name,)
    page = (tmp_path / "report" / "report.html").read_text()
    shown = re.findall(r"flow \(+…?", page)
    assert shown and all(len(text) <= REPORT_NAME_CHARS for text in shown)


def test_period_names_with_unclosed_brackets_match_as_before():
    # the matches end at the last closing bracket; nothing after it is ever inside one
    assert period_kind("Ts [s] (((") == "period" and period_kind("Fs [Hz] [[(") == "rate"
    assert period_kind("Ts (s) [x") is None and period_kind("[Ts") == "period"


def test_csv_cells_never_become_spreadsheet_formulas(tmp_path):
    names = ["=HYPERLINK(\"http://x\")", "+cmd|' /C calc'!A0", "@SUM(1)", "-1+2", "\tx", "\rx", "-2.5", "plain"]
    rows = [{"name": name, "fit": -3.25} for name in names]
    csv_path, _ = write_summary(rows, ("name", "fit"), tmp_path, "summary", "t", "fit")
    with csv_path.open(newline="") as handle:
        read = list(csv.DictReader(handle))
    shown = [row["name"] for row in read]
    assert shown[:6] == ["'" + name for name in names[:6]]
    assert shown[6:] == ["-2.5", "plain"]  # a negative number stays a number
    assert {row["fit"] for row in read} == {"-3.25"}


def test_a_newline_in_a_name_forges_no_line_in_info(tmp_path):
    forged = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]], output_names=["y\nstable: yes (forged)"])
    forged.save(tmp_path / "m.json")
    done = run("info", str(tmp_path / "m.json"))
    assert done.exit_code == 0
    assert not any(line.startswith("stable: yes (forged)") for line in done.output.splitlines())
    assert "y\\nstable: yes (forged)" in done.output


# --- fleets: names and outputs -----------------------------------------------------------

def test_validate_many_refuses_two_records_of_one_name(tmp_path):
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        write_csv(tmp_path / folder / "loop.csv", siso())
    (tmp_path / "models").mkdir()
    model(1).save(tmp_path / "models" / "loop.json")
    assert_clean_error(run("validate-many", str(tmp_path / "models"), str(tmp_path / "*" / "loop.csv")),
                       "are both named 'loop'")


def test_fit_many_never_overwrites_an_input_named_summary(tmp_path):
    write_csv(tmp_path / "loop.csv", siso())
    summary = write_csv(tmp_path / "summary.csv", siso(seed=1))
    before = summary.read_bytes()
    assert_clean_error(run("fit-many", str(tmp_path / "*.csv"), *CHANNELS, "--workers", "1",
                           "--out", str(tmp_path)), "is an input of this run")
    assert summary.read_bytes() == before


# --- readers bound their work --------------------------------------------------------------

def test_a_text_line_of_hundreds_of_kib_is_read(tmp_path):
    data = siso(N=40)
    path = tmp_path / "long.csv"
    note = "x" * 200_000  # a 200 KiB cell, as in a table of 20,000 columns: past csv's 128 KiB field limit
    with path.open("w") as handle:
        handle.write("u1,y1,note\n")
        for k, (u, y) in enumerate(zip(data.u[:, 0], data.y[:, 0])):
            handle.write(f"{float(u)!r},{float(y)!r},{note if k == 0 else 'ok'}\n")
    read = moli.read_data(path, ["u1"], ["y1"])
    np.testing.assert_array_equal(read.y, data.y)


def test_an_npz_member_not_asked_for_is_never_inflated(tmp_path):
    path = tmp_path / "record.npz"
    data = siso(N=50)
    np.savez(path, u=data.u, y=data.y, Ts=0.5)
    with zipfile.ZipFile(path, "a") as archive:
        archive.writestr("huge.npy", b"\x93NUMPY not an array at all")  # a bomb stands for any junk
    read = moli.read_data(path, ["u1"], ["y1"])
    np.testing.assert_array_equal(read.u, data.u)
    assert read.Ts == 0.5


def test_a_mat_file_reads_only_the_variables_asked_for(tmp_path, monkeypatch):
    scipy_io = pytest.importorskip("scipy.io")
    path = tmp_path / "record.mat"
    data = siso(N=50)
    scipy_io.savemat(path, {"u1": data.u[:, 0], "y1": data.y[:, 0], "junk": np.zeros(100_000)})
    asked = []
    real = scipy_io.loadmat

    def spy(*args, **kwargs):
        asked.append(kwargs.get("variable_names"))
        return real(*args, **kwargs)

    monkeypatch.setattr(scipy_io, "loadmat", spy)
    read = moli.read_data(path, ["u1"], ["y1"])
    np.testing.assert_allclose(read.y, data.y, rtol=0, atol=0)
    assert asked and "junk" not in asked[0]


# --- limits and numeric edges --------------------------------------------------------------

def test_an_nmax_beyond_the_record_is_one_error_before_the_search(tmp_path):
    data = write_csv(tmp_path / "plant.csv", siso(N=600))
    assert_clean_error(run("fit", str(data), *CHANNELS, "--nmax", "100000"), "the largest order is")
    assert_clean_error(run("fit", str(data), *CHANNELS, "--order", "100000"), "order = 100000")
    with pytest.raises(DataError, match="largest order"):
        moli.identify(siso(N=600), nmax=100000)


@pytest.mark.parametrize("factor, word", [(1e156, "overflow"), (1e-310, "underflow")])
def test_samples_at_the_edges_of_double_precision_are_one_error(tmp_path, factor, word):
    data = siso()
    scaled = moli.IOData(data.y * factor, data.u, output_names=["y1"], input_names=["u1"])
    with pytest.raises(DataError, match=word):
        moli.identify(scaled, nmax=2)
    assert [issue.kind for issue in moli.check_data(scaled)] == ["scale"]  # not "constant"
    path = tmp_path / "plant.csv"
    path.write_text("u1,y1\n" + "".join(f"{float(u)!r},{float(y)!r}\n" for u, y in zip(scaled.u[:, 0], scaled.y[:, 0])))
    assert_clean_error(run("fit", str(path), *CHANNELS, "--ts", "1", "--nmax", "2", "--out", str(tmp_path / "m.json")),
                       word)


@pytest.mark.parametrize("text", [
    "[" * 100_000 + "]" * 100_000,                               # nested past the parser's stack
    '{"format": "moli-model", "A": ' + "9" * 5000 + "}",          # past Python's digits limit
], ids=["deep", "digits"])
def test_hostile_json_is_one_error(tmp_path, text):
    path = tmp_path / "m.json"
    path.write_text(text)
    with pytest.raises(ModelFileError):
        moli.load_model(path)
    assert_clean_error(run("info", str(path)), str(path))
    assert_clean_error(run("fit", "x.csv", "--options", str(path)), "--options")


def test_a_huge_integer_in_a_model_field_is_one_error(tmp_path):
    content = model(1).to_dict()
    text = json.dumps(content).replace('"A": [[0.5]]', '"A": [[' + "9" * 4000 + "]]")
    (tmp_path / "m.json").write_text(text)
    with pytest.raises(ModelFileError, match="too large"):
        moli.load_model(tmp_path / "m.json")
