"""The documentation runs as written.

Every ```python block of README.md and docs/*.md runs in a fresh namespace, in a
temporary folder that holds stand-ins of the data files the docs name (``plant.csv``,
``rerun.csv``, ``plant/loop01.csv``...: the built-in example plant's samples under the
documented column names). A block that reads DaISy records runs against the DaISy
folder and skips, saying so, without it. A block that cannot run here (a cluster, a
scheduler) is fenced ```python notest (reason); the test skips it with that reason.
Every test file the docs name exists.
"""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import matplotlib
import pytest

import moli
from conftest import REPO, daisy_dir

matplotlib.use("Agg")

DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
FENCE = re.compile(r"^```python(?P<info>[^\n]*)\n(?P<code>.*?)^```", re.S | re.M)
NOTEST = re.compile(r"^\s*notest\s*\((?P<reason>[^)]+)\)\s*$")
# a call of load_daisy outside a comment: the block needs the DaISy folder
NEEDS_DAISY = re.compile(r"^[^#\n]*load_daisy\(", re.M)


def blocks() -> list:
    found = []
    for path in DOCS:
        text = path.read_text(encoding="utf-8")
        for match in FENCE.finditer(text):
            line = text.count("\n", 0, match.start()) + 1
            name = f"{path.relative_to(REPO).as_posix()}:{line}"
            found.append(pytest.param(match.group("info"), match.group("code"), id=name))
    return found


def write_stand_ins(folder: Path) -> None:
    """The files the docs read, with the columns they name."""
    frame = moli.to_dataframe(moli.example_data(N=600, seed=1))
    frame = frame.assign(valve=frame["u3"], level=frame["y3"])
    frame.to_csv(folder / "plant.csv")
    moli.to_dataframe(moli.example_data(N=300, seed=2)).to_csv(folder / "rerun.csv")
    (folder / "plant").mkdir()
    for i in (1, 2):
        moli.to_dataframe(moli.example_data(N=400, seed=10 + i)).to_csv(folder / "plant" / f"loop0{i}.csv")


@pytest.mark.parametrize(("info", "code"), blocks())
def test_python_block_runs(info, code, tmp_path, monkeypatch):
    if info.strip():
        marked = NOTEST.match(info)
        assert marked, f"unknown fence ```python{info}: use ```python or ```python notest (reason)"
        pytest.skip(f"marked notest: {marked.group('reason')}")
    if NEEDS_DAISY.search(code):
        folder = daisy_dir()
        if folder is None:
            pytest.skip("needs the DaISy records: set MOLI_DATA_DIR to a folder of DaISy records")
        monkeypatch.setenv("MOLI_DATA_DIR", str(folder))
    write_stand_ins(tmp_path)
    monkeypatch.chdir(tmp_path)
    with contextlib.redirect_stdout(io.StringIO()):
        exec(compile(code, "<doc block>", "exec"), {"__name__": "__doc_block__"})


def test_docs_have_python_blocks_and_few_are_skipped():
    params = blocks()
    assert len(params) >= 10
    skipped = [p for p in params if p.values[0].strip()]
    assert len(skipped) <= 3, [p.id for p in skipped]


def test_every_test_file_the_docs_name_exists():
    named = {m for path in DOCS for m in re.findall(r"tests/[\w/]+\.py", path.read_text(encoding="utf-8"))}
    assert named and sorted(name for name in named if not (REPO / name).is_file()) == []


def test_readme_says_how_to_give_the_tests_the_daisy_records_right_after_its_commands():
    text = (REPO / "README.md").read_text(encoding="utf-8")
    after_commands = text.split("```", 2)[2].split("\n\n", 2)[1]    # the paragraph after the first block
    assert "MOLI_DATA_DIR" in after_commands and "../shared/data/daisy" in after_commands
    assert "skipped" in after_commands


def test_cli_md_shows_every_command_of_the_first_session():
    import importlib.util
    spec = importlib.util.spec_from_file_location("first_hour", REPO / "benchmarks" / "first_hour.py")
    first_hour = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(first_hour)
    page = (REPO / "docs" / "cli.md").read_text(encoding="utf-8")
    shown = page.split(first_hour.START)[1].split(first_hour.END)[0]
    commands = [line[2:] for line in shown.splitlines() if line.startswith("$ moli ")]
    assert commands == first_hour.SESSION
