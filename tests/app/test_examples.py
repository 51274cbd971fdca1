"""Every script in examples/ runs and writes its files into the folder it is given."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).resolve().parents[2] / "examples").glob("*.py"))
TIME_LIMIT = 60  # seconds; each script takes well under 20 s on a laptop


def test_examples_are_found():
    assert {"quickstart.py", "csv_to_model.py", "twin_rotor.py"} <= {p.name for p in EXAMPLES}


@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.stem)
def test_example_runs(script, tmp_path):
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, str(script), str(out)], cwd=tmp_path,
                          capture_output=True, text=True, timeout=TIME_LIMIT)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Traceback" not in done.stderr
    written = [p for p in out.rglob("*") if p.is_file()]
    assert written and all(p.stat().st_size > 0 for p in written)
    assert list(tmp_path.iterdir()) == [out], "scripts must write only into the folder given"


def test_twin_rotor_writes_beside_itself_by_default(tmp_path):
    """Run from any folder without OUTDIR, it never writes over the repository's docs/figures."""
    script = next(p for p in EXAMPLES if p.name == "twin_rotor.py")
    shown = subprocess.run([sys.executable, str(script), "--help"], cwd=tmp_path, capture_output=True,
                           text=True, timeout=TIME_LIMIT).stdout
    # argparse wraps the help: compare without white space
    assert str(script.parent / "twin_rotor_figures") in "".join(shown.split())
