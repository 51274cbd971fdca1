"""Peak memory of ``moli.read_data`` on hostile files: a few MB on disk, GiB once inflated.

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/reader_memory.py [--size BYTES] [--src PATH/TO/src]

Builds each file of tests/hostile_files.py in a temporary folder (its unused content
inflating to ``--size`` bytes, default 2 GiB), reads it in a fresh interpreter with the
moli of ``--src`` (default: this checkout's), and prints the file's size on disk, the
reader's peak resident memory (``ru_maxrss``), its wall time and what it returned. No
address-space cap: this is what a reader costs, not whether it fits.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

import hostile_files  # noqa: E402

READ = """
import json, resource, sys, warnings
warnings.simplefilter("ignore")
import moli
try:
    data = moli.read_data(sys.argv[1], *json.loads(sys.argv[2]))
    said = repr(data)
except moli.MoliError as exc:
    said = type(exc).__name__ + ": " + str(exc)[-90:]
except MemoryError:
    said = "MemoryError"
print(json.dumps([resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, said]))
"""


def cases(folder: Path, size: int) -> list[tuple[str, Path, list]]:
    channels = [["u1"], ["y1"], 0.5]
    return [
        (".npz, no channels named", hostile_files.bomb_npz(folder / "a.npz", size), []),
        (".mat, no channels named", hostile_files.bomb_mat(folder / "a.mat", size), []),
        (".mat struct, channels named",
         hostile_files.bomb_mat(folder / "s.mat", size, as_struct=True, with_record=False), channels),
        (".xlsx, text in the sheet", hostile_files.bomb_xlsx(folder / "i.xlsx", size // 2, False), channels),
        (".xlsx, shared text", hostile_files.bomb_xlsx(folder / "s.xlsx", size // 2, True), channels),
        (".csv + zero bytes", hostile_files.zero_padded_csv(folder / "z.csv", 4 * size), channels),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--size", type=int, default=hostile_files.CAP_BYTES)
    parser.add_argument("--src", default=str(REPO / "src"))
    args = parser.parse_args()
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": args.src}
    print(f"moli from {args.src}; unused content {args.size / 2**30:g} GiB (the .xlsx half, "
          "the zero bytes four times)")
    print(f"{'file':30} {'on disk':>9} {'peak RSS':>10} {'time':>7}  result")
    with tempfile.TemporaryDirectory() as folder:
        for name, path, arguments in cases(Path(folder), args.size):
            start = time.perf_counter()
            done = subprocess.run([sys.executable, "-c", READ, str(path), json.dumps(arguments)],
                                  capture_output=True, text=True, env=env)
            elapsed = time.perf_counter() - start
            peak, said = json.loads(done.stdout) if done.returncode == 0 else (
                float("nan"), done.stderr.strip().splitlines()[-1][:90])
            print(f"{name:30} {path.stat().st_blocks * 512 / 2**20:7.1f} MB {peak:7.0f} MiB "
                  f"{elapsed:6.1f}s  {said}")


if __name__ == "__main__":
    main()
