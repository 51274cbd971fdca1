"""A new user's first hour with the ``moli`` command, replayed in a fresh folder.

Usage::

    python benchmarks/first_hour.py [--write-docs]

Makes the files a new user brings (a CSV export whose time column is ``Time [s]``, a
49-row file, two runs of one plant), then runs, in a fresh temporary folder and as a
new user would type them, the commands of :data:`SESSION`: a first fit, the same fit
again, a fit into a named file twice, a validation on another run, the tiny file, the
two runs merged and ``fit-many`` over all. Prints each command and what it printed
(in the order printed, progress bars left out) and the files the session left. ``--write-docs`` puts the
same text into docs/cli.md between ``<!-- generated: first-hour -->`` and
``<!-- end generated: first-hour -->``.
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path[:0] = [str(HERE), str(ROOT / "src")]

import single_thread  # noqa: F401,E402  (before numpy: one BLAS thread)

import moli  # noqa: E402

CHANNELS = "--inputs u1,u2,u3 --outputs y1,y2,y3"
SESSION = [
    f"moli fit plant.csv {CHANNELS}",
    f"moli fit plant.csv {CHANNELS}",
    f"moli fit plant.csv {CHANNELS} --nmax 6 --out model.json",
    f"moli fit plant.csv {CHANNELS} --nmax 6 --out model.json",
    f"moli fit plant.csv {CHANNELS} --nmax 6 --out model.json --force",
    "moli validate moli-fit-plant/model.json run2.csv",
    f"moli fit tiny.csv {CHANNELS}",
    f"moli fit run1.csv run2.csv {CHANNELS}",
    f"moli fit-many run1.csv run2.csv tiny.csv {CHANNELS} --workers 1 --out models",
]
DOCS = ROOT / "docs" / "cli.md"
START, END = "<!-- generated: first-hour -->", "<!-- end generated: first-hour -->"
# tqdm redraws its bar with carriage returns; the text is what a terminal keeps
PROGRESS = re.compile(r"^(structure search|fleet):.*$")


def make_files(folder: Path) -> None:
    """plant.csv with a ``Time [s]`` column (Ts = 1 s), tiny.csv of 49 rows, two runs."""
    plant = moli.to_dataframe(moli.example_data(N=1000, seed=1))
    plant.index.name = "Time [s]"
    plant.to_csv(folder / "plant.csv")
    moli.to_dataframe(moli.example_data(N=49, seed=2)).to_csv(folder / "tiny.csv")
    for run in (1, 2):
        moli.to_dataframe(moli.example_data(N=500, seed=2 + run)).to_csv(folder / f"run{run}.csv")


def run(command: str, folder: Path) -> str:
    """One command as typed, and what the terminal shows (stdout, then stderr)."""
    args = shlex.split(command)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "COLUMNS": "100"}
    done = subprocess.run([sys.executable, "-m", "moli", *args[1:]], cwd=folder, env=env,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=600)
    lines = [line.split("\r")[-1] for line in done.stdout.splitlines()]
    shown = [line for line in lines if line.strip() and not PROGRESS.match(line.strip())]
    status = "" if done.returncode == 0 else f"[exit code {done.returncode}]"
    return "\n".join([f"$ {command}", *shown, *([status] if status else [])])


def session() -> str:
    with tempfile.TemporaryDirectory(prefix="moli-first-hour-") as name:
        folder = Path(name)
        make_files(folder)
        parts = ["$ ls\n" + "  ".join(sorted(p.name for p in folder.iterdir()))]
        parts += [run(command, folder) for command in SESSION]
        left = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*")
                      if p.is_file() and p.suffix != ".png")
        parts.append("\n".join(["$ find . -type f -not -name '*.png' | sort", *(f"./{p}" for p in left)]))
    return "\n\n".join(parts)


def write_docs(text: str) -> None:
    page = DOCS.read_text(encoding="utf-8")
    block = f"{START}\n```text\n{text}\n```\n{END}"
    page = re.sub(re.escape(START) + ".*?" + re.escape(END), lambda _: block, page, flags=re.S)
    DOCS.write_text(page, encoding="utf-8")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write-docs", action="store_true", help="rewrite the session in docs/cli.md")
    args = parser.parse_args()
    text = session()
    print(text)
    if args.write_docs:
        write_docs(text)
        print(f"written to {DOCS}")


if __name__ == "__main__":
    main()
