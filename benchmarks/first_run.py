"""What a first run costs: ``moli demo`` as a new user runs it, and a fresh process's first identify.

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/first_run.py [--runs 5] [--src PATH/TO/src]

Every figure comes from new interpreters (one BLAS thread), so nothing is cached in the
process; the tables give the median and the range of ``--runs`` runs.

1. ``moli demo`` into a temporary folder, report included: the CPU time (user + system)
   and the wall time of the whole command, then the same run cut into its parts in one
   process (starting Python and importing the command line, the identification, the
   report).
2. ``moli.identify(moli.example_data(N=1000))`` twice in one fresh process: the import
   (``import moli; moli.identify``), the first call and the second, identical one, in
   CPU seconds, and the first over the second. A second row imports ``scipy.signal``
   (which brings ``scipy.stats``) before the first call: what that one-off import cost a
   first call when moli filtered with ``lfilter``; moli no longer imports either.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

FIRST_CALLS = """
import json, sys, time, warnings
warnings.simplefilter("ignore")
P = time.process_time
a = P(); import moli; moli.identify
{preload}
b = P(); data = moli.example_data(N=1000)
c = P(); moli.identify(data)
d = P(); moli.identify(data)
e = P()
print(json.dumps({{"import": b - a, "first": d - c, "second": e - d}}))
"""
# The demo's parts, in one process: what `moli demo` runs, timed between its steps.
DEMO_PARTS = """
import json, sys, tempfile, time, warnings
P = time.process_time
started = P()
from moli.app import cli
from moli.app.reading import RunWarnings
imported = P()
warnings.simplefilter("ignore")
data = cli.example_data()
result = cli._identify(data, 0.5, cli.IdentifyOptions(), RunWarnings())
identified = P()
cli.write_report(result, tempfile.mkdtemp())
reported = P()
print(json.dumps({"start and imports": imported, "identification": identified - imported,
                  "report": reported - identified}))
"""


def _env(src: str | None) -> dict[str, str]:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    if src:
        env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _child_json(code: str, env: dict[str, str]) -> dict[str, float]:
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def demo_runs(runs: int, env: dict[str, str]) -> tuple[list[float], list[float]]:
    """CPU seconds (this command and its children) and wall seconds of ``moli demo``, per run."""
    cpu, wall = [], []
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as folder:
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            started = time.perf_counter()
            subprocess.run([sys.executable, "-m", "moli", "demo", "--out", str(Path(folder) / "demo")],
                           env=env, capture_output=True, check=True)
            wall.append(time.perf_counter() - started)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return cpu, wall


def _row(label: str, values: list[float]) -> str:
    return f"| {label} | {statistics.median(values):.2f} | {min(values):.2f}-{max(values):.2f} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--src", help="a checkout's src folder to measure instead of the installed moli")
    args = parser.parse_args()
    env = _env(args.src)

    cpu, wall = demo_runs(args.runs, env)
    parts = [_child_json(DEMO_PARTS, env) for _ in range(args.runs)]
    print(f"`moli demo`, {args.runs} runs\n\n| | median (s) | range (s) |\n|---|---|---|")
    print(_row("CPU, whole command", cpu))
    print(_row("wall, whole command", wall))
    for key in parts[0]:
        print(_row(f"CPU, {key}", [part[key] for part in parts]))

    print(f"\nfirst `moli.identify` on `example_data(N=1000)`, {args.runs} fresh processes, CPU seconds\n")
    print("| | import | first call | second call | first / second |\n|---|---|---|---|---|")
    for label, preload in (("as a script runs it", ""), ("scipy.signal imported first", "import scipy.signal")):
        runs = [_child_json(FIRST_CALLS.format(preload=preload), env) for _ in range(args.runs)]
        med = {key: statistics.median(run[key] for run in runs) for key in runs[0]}
        ratio = statistics.median(run["first"] / run["second"] for run in runs)
        print(f"| {label} | {med['import']:.2f} | {med['first']:.2f} | {med['second']:.2f} | {ratio:.2f} |")


if __name__ == "__main__":
    main()
