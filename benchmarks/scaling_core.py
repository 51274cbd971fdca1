"""Time and peak memory of ``moli.identify`` and ``moli.estimate`` against the record length.

Every measurement runs in a fresh Python process (one BLAS thread), so that its peak
resident set size (``ru_maxrss``) is its own: the interpreter, numpy and scipy, the
record, and the call. The record is a random stable plant of order ``n`` (``p``
outputs, ``m`` inputs, seeded), driven by white noise, with white output noise at
20 dB; ``identify`` holds out its last 30 % for the order rule, and ``estimate`` fits
the structure and filter that ``identify`` selects on a short record of the same plant.

    OPENBLAS_NUM_THREADS=1 python benchmarks/scaling_core.py [--sizes 1e3 1e4 1e5 1e6]
        [--p 3 --m 3] [--what identify estimate] [--nmax 8]

Importable: :func:`measure` returns one measurement as a dict.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
SRC = HERE.parent / "src"
WHAT = ("identify", "estimate", "baseline")


def plant(n: int, p: int, m: int, seed: int):
    """A stable ``(A, B, C)`` of order ``n``: real and complex modes, radii 0.5-0.95, mixed coordinates."""
    import numpy as np
    import scipy.linalg

    rng = np.random.default_rng([seed, n, p, m])
    blocks, scale = [], []
    pairs = n // 4
    for k in range(n - 2 * pairs + pairs):
        radius = rng.uniform(0.5, 0.95)
        if k < pairs:
            angle = rng.uniform(0.05, 0.6) * np.pi
            c, s = np.cos(angle), np.sin(angle)
            blocks.append(radius * np.array([[c, -s], [s, c]]))
            scale += [math.sqrt(1 - radius**2)] * 2
        else:
            blocks.append(np.array([[radius]]))
            scale.append(math.sqrt(1 - radius**2))
    rotation = np.linalg.qr(rng.standard_normal((n, n)))[0]
    A = rotation @ scipy.linalg.block_diag(*blocks) @ rotation.T
    B = rotation @ (rng.standard_normal((n, m)) * np.array(scale)[:, None])
    C = rng.standard_normal((p, n)) @ rotation.T
    return A, B, C


def record(N: int, p: int, m: int, seed: int = 0, n: int = 6):
    """``N`` samples of the seeded plant: white inputs, white output noise at 20 dB SNR."""
    import numpy as np
    import moli

    A, B, C = plant(n, p, m, seed)
    rng = np.random.default_rng([seed, N])
    u = rng.standard_normal((N, m))
    y = moli.StateSpaceModel(A, B, C).simulate(u)
    y += 0.1 * y.std(axis=0) * rng.standard_normal(y.shape)
    return moli.IOData(y, u)


def _child(N: int, p: int, m: int, what: str, seed: int, nmax: int, options: dict) -> dict:
    """The measurement itself, in this (fresh) process."""
    import resource
    import time
    import warnings

    import moli

    with warnings.catch_warnings():       # modules imported at first use: not timed
        warnings.simplefilter("ignore")
        small = record(400, p, m, seed)
        if what == "identify":
            moli.identify(small, nmax=p)
        elif what == "estimate":
            moli.estimate(small, options["indices"], options["alpha"])
    data = record(N, p, m, seed)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    out = {"N": N, "p": p, "m": m, "what": what, "seed": seed, "record_bytes": data.y.nbytes + data.u.nbytes}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if what == "identify":
            start = time.perf_counter()
            result = moli.identify(data, nmax=nmax, **options)
            out["seconds"] = time.perf_counter() - start
            out["indices"] = list(result.selected.indices)
            out["eta"] = [float(v) for v in result.selected.eta]
            out["mean_vaf"] = result.selected.mean_vaf
        elif what == "select":
            chosen = moli.identify(record(min(N, 20_000), p, m, seed), nmax=nmax, **options).selected
            # the shared filter the search chose (a model with per-output filters has no alpha)
            alpha = moli.filter_polynomial(*chosen.eta, chosen.indices)
            out["indices"], out["alpha"] = list(chosen.indices), list(alpha)
        elif what == "estimate":
            est = data.split(0.7)[0].remove_means()
            start = time.perf_counter()
            moli.estimate(est, options["indices"], options["alpha"])
            out["seconds"] = time.perf_counter() - start
            out["indices"] = options["indices"]
        else:
            out["seconds"] = 0.0
    out["rss_before"] = before
    out["peak_rss"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return out


def measure(N: int, p: int = 3, m: int = 3, what: str = "identify", seed: int = 0, nmax: int = 8,
            options: dict | None = None, src: Path | str = SRC) -> dict:
    """One measurement in a fresh process.

    Parameters
    ----------
    N, p, m : int
        Record length, outputs, inputs.
    what : {"identify", "estimate", "baseline"}
        ``identify(record, nmax=nmax, **options)``; ``estimate`` of the estimation part
        (70 %) with the structure and filter ``identify`` picks on 20,000 samples of the
        same plant (in another process); or nothing (the process with its record, for
        reference).
    seed : int
        Plant and signals.
    options : dict, optional
        Extra :class:`moli.IdentifyOptions` fields.
    src : path
        The ``src`` folder whose ``moli`` is measured.

    Returns
    -------
    dict
        ``seconds`` (the call's wall time), ``peak_rss`` (bytes, the whole process),
        ``rss_before`` (peak before the call), ``record_bytes`` (y and u), and for
        ``identify`` the selected indices, filter and mean validation VAF.
    """
    if what not in WHAT:
        raise ValueError(f"what must be one of {WHAT}, got {what!r}")
    if what == "estimate":      # the structure chosen in a process of its own: its memory is not counted
        chosen = _run(N, p, m, "select", seed, nmax, options, src)
        options = {"indices": chosen["indices"], "alpha": chosen["alpha"]}
    return _run(N, p, m, what, seed, nmax, options, src)


def _run(N: int, p: int, m: int, what: str, seed: int, nmax: int, options: dict | None, src: Path | str) -> dict:
    args = json.dumps([int(N), int(p), int(m), what, int(seed), int(nmax), options or {}])
    code = ("import sys, json; sys.path.insert(0, sys.argv[1]); sys.path.insert(0, sys.argv[2]); "
            "import single_thread, scaling_core; "
            "print(json.dumps(scaling_core._child(*json.loads(sys.argv[3]))))")
    done = subprocess.run([sys.executable, "-c", code, str(src), str(HERE), args],
                          capture_output=True, text=True, check=False)
    if done.returncode:
        raise RuntimeError(f"measurement {what} N={N} failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def slope(rows: list[dict], key: str = "seconds") -> float:
    """Least-squares slope of log(key) against log(N)."""
    import numpy as np

    x = np.log([r["N"] for r in rows])
    v = np.log([max(r[key], 1e-9) for r in rows])
    return float(np.polyfit(x, v, 1)[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", type=float, default=[1e3, 1e4, 1e5, 1e6])
    parser.add_argument("--p", type=int, default=3)
    parser.add_argument("--m", type=int, default=3)
    parser.add_argument("--nmax", type=int, default=8)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--what", nargs="+", default=["baseline", "identify", "estimate"], choices=WHAT)
    parser.add_argument("--src", default=str(SRC))
    parser.add_argument("--options", default="{}", help="JSON of extra IdentifyOptions fields")
    args = parser.parse_args()
    options = json.loads(args.options)
    print(f"{'what':>9} {'N':>9} {'seconds':>9} {'peak MB':>9} {'before MB':>10} {'record MB':>10}  selected")
    table: dict[str, list[dict]] = {}
    for what in args.what:
        for size in args.sizes:
            row = measure(int(size), args.p, args.m, what, args.seed, args.nmax, options, args.src)
            table.setdefault(what, []).append(row)
            print(f"{what:>9} {row['N']:>9} {row['seconds']:>9.3f} {row['peak_rss'] / 2**20:>9.1f} "
                  f"{row['rss_before'] / 2**20:>10.1f} {row['record_bytes'] / 2**20:>10.1f}  "
                  f"{row.get('indices', '')} {row.get('mean_vaf', '')}", flush=True)
    for what, rows in table.items():
        if what != "baseline" and len(rows) > 1:
            big = [r for r in rows if r["N"] >= 10**4] or rows
            print(f"{what}: time slope in N {slope(big):.3f} (N >= 10^4), "
                  f"peak RSS slope {slope(big, 'peak_rss'):.3f}")


if __name__ == "__main__":
    main()
