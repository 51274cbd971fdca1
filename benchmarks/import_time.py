"""Time of ``import moli`` and of the first use of its main entry points, in fresh processes.

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/import_time.py [--runs 15] [--src PATH/TO/src]

Each figure is measured in a new interpreter (``python -c``), so nothing is cached in
the process; the table gives the median and the fastest of ``--runs`` runs. ``--src``
measures another checkout's package (its ``src`` folder goes first on ``sys.path``).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys

STEPS = {
    "import moli": "import moli",
    "import moli; moli.IOData": "import moli; moli.IOData",
    "import moli; moli.identify": "import moli; moli.identify",
    "import numpy (reference)": "import numpy",
}
TIMER = "import time; t = time.perf_counter(); {code}; print(time.perf_counter() - t)"


def measure(code: str, runs: int, src: str | None) -> list[float]:
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    out = []
    for _ in range(runs):
        done = subprocess.run([sys.executable, "-c", TIMER.format(code=code)], env=env,
                              capture_output=True, text=True, check=True)
        out.append(float(done.stdout.strip().splitlines()[-1]))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=15)
    parser.add_argument("--src", help="a checkout's src folder to measure instead of the installed moli")
    args = parser.parse_args()
    print(f"| step | median (s) | fastest (s) |\n|---|---|---|")
    for label, code in STEPS.items():
        times = measure(code, args.runs, args.src)
        print(f"| `{label}` | {statistics.median(times):.3f} | {min(times):.3f} |")


if __name__ == "__main__":
    main()
