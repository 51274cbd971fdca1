"""Time of the default identification on the evaporator against another checkout of moli.

Each version runs in its own subprocess (its ``src`` first on the path), alternated
``rounds`` times; each subprocess warms up once, then takes the fastest of ``repeats``
identifications of the paper split (estimation 0..499, validation 500..999, nmax as the
peers' benchmark). The ratio of the fastest times is printed, with every run's, so that
a load on the machine shows as spread rather than as a ratio.

    git worktree add /tmp/before <commit>
    MOLI_DATA_DIR=/path/to/daisy python benchmarks/cost_against.py /tmp/before/src [--rounds 3] [--option NAME=JSON]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

CHILD = """
import json, sys, time, warnings
import single_thread
import moli
import peers
from daisy_data import load
options = json.loads(sys.argv[1])
data = load("evaporator")
est, val = data[0:500], data[500:1000]
nmax = peers.NMAX["evaporator"]
warnings.simplefilter("ignore")
moli.identify(est, val, nmax=nmax, **options)
times = []
for _ in range(int(sys.argv[2])):
    start = time.perf_counter()
    result = moli.identify(est, val, nmax=nmax, **options)
    times.append(time.perf_counter() - start)
print(json.dumps({"seconds": min(times), "order": result.selected.order}))
"""


def run(src: Path, options: dict[str, object], repeats: int) -> dict[str, float]:
    env = dict(os.environ, PYTHONPATH=f"{src}{os.pathsep}{HERE}", OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(options), str(repeats)], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("baseline", type=Path, help="the src folder of the version to compare with")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--option", action="append", default=[], metavar="NAME=JSON",
                        help="an IdentifyOptions field for this checkout's runs")
    args = parser.parse_args()
    options = {name: json.loads(value) for name, value in (o.split("=", 1) for o in args.option)}
    ours = HERE.parent / "src"
    found: dict[str, list[float]] = {"baseline": [], "this": []}
    for _ in range(args.rounds):
        for label, src, opts in (("baseline", args.baseline, {}), ("this", ours, options)):
            result = run(src, opts, args.repeats)
            found[label].append(result["seconds"])
            print(f"{label:9s} {result['seconds']:.3f} s (order {result['order']})", flush=True)
    print(f"this / baseline, fastest of each: {min(found['this']) / min(found['baseline']):.2f}")


if __name__ == "__main__":
    main()
