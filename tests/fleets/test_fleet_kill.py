"""``moli fit-many`` killed with ``kill -9`` halfway: what finished is on disk with a valid
summary, no worker outlives the run, and ``--resume`` finishes the rest without redoing any."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

import moli
from moli.app import cli

RECORDS = 12
CHANNELS = ["--inputs", "u1,u2,u3", "--outputs", "y1,y2,y3", "--nmax", "3"]
# The bound: no worker may be alive this long after the main process was killed.
ORPHAN_SECONDS = 10.0
# Generous: it only ends a test whose run never wrote a model, on however slow a machine.
START_SECONDS = 300.0

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads processes from /proc (Linux)")


def _stat(pid: int) -> list[str] | None:
    """/proc/PID/stat's fields after the command name; None when there is no such process."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return text.rsplit(")", 1)[1].split()


def children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        fields = _stat(int(entry.name)) if entry.name.isdigit() else None
        if fields is not None and int(fields[1]) == pid:
            found.append(int(entry.name))
    return found


def alive(pid: int) -> bool:
    fields = _stat(pid)
    return fields is not None and fields[0] not in ("Z", "X")  # a zombie has ended; only its entry waits


def models(folder: Path) -> dict[str, int]:
    return {path.stem: path.stat().st_mtime_ns for path in folder.glob("*.json")}


def summary_rows(folder: Path) -> dict[str, dict[str, str]]:
    with (folder / "summary.csv").open(newline="") as handle:
        return {row["name"]: row for row in csv.DictReader(handle)}


def test_kill_9_halfway_keeps_the_finished_models_and_resume_redoes_none(tmp_path):
    plant = tmp_path / "plant"
    plant.mkdir()
    for k in range(RECORDS):
        moli.to_dataframe(moli.example_data(N=300, seed=k)).to_csv(plant / f"loop{k:02d}.csv")
    out = tmp_path / "models"
    env = {**os.environ, "PYTHONPATH": str(Path(moli.__file__).parents[1]), "OPENBLAS_NUM_THREADS": "1"}
    main = subprocess.Popen([sys.executable, "-m", "moli", "fit-many", "plant/*.csv", *CHANNELS,
                             "--workers", "2", "--out", "models"], cwd=tmp_path, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + START_SECONDS
        while len(models(out)) < 2 and main.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        workers = children(main.pid)
        main.send_signal(signal.SIGKILL)
    finally:
        main.kill()
        main.wait()
    assert main.returncode == -signal.SIGKILL, "the run ended before it could be killed halfway"
    assert workers, "no worker process was seen"
    ended = time.monotonic() + ORPHAN_SECONDS
    while any(alive(pid) for pid in workers) and time.monotonic() < ended:
        time.sleep(0.1)
    assert not [pid for pid in workers if alive(pid)], "workers outlived the killed run"

    before = models(out)
    assert 2 <= len(before) < RECORDS
    rows = summary_rows(out)   # a whole file: it is only ever replaced by a whole one
    assert all(row["status"] == "identified" for row in rows.values())
    # the summary is rewritten right after each model: at most the last model is not in it yet
    assert set(rows) <= set(before) and len(before) - len(rows) <= 1

    done = CliRunner().invoke(cli.cli, ["fit-many", str(plant / "*.csv"), *CHANNELS, "--workers", "2",
                                        "--out", str(out), "--resume"], prog_name="moli")
    assert done.exit_code == 0, done.output + done.stderr
    after = models(out)
    assert len(after) == RECORDS and all(after[name] == when for name, when in before.items())
    statuses = {name: row["status"] for name, row in summary_rows(out).items()}
    assert statuses == {name: "kept" if name in before else "identified" for name in after}
    assert f"{RECORDS} models in {out} ({len(before)} kept from an earlier run), 0 failed" in done.output
