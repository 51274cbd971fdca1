"""Whether a change of code keeps every identified model: snapshot now, compare later.

Identifies every case of the generalization benchmark (benchmarks/generalization_cases.py:
the DaISy records both ways, the evaporator windows and the synthetic systems of one
seed) with the given presets, and stores each result's model (A, B, C, D, and K, the noise
covariance and the parameters' covariance factor where present) and its path (each list's J, J at the barycenter, eta
and validation VAF). ``compare`` runs the same identifications on the current code and
counts the values that differ from the snapshot, bit for bit and relative to each array's
largest entry.

    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/same_models.py save before.npz
    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/same_models.py compare before.npz

``--synthetic K`` sets the number of synthetic systems (80 by default), ``--seed`` their
seed, ``--presets default,improved`` the option sets.
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

import generalization_cases as gc  # noqa: E402
import moli  # noqa: E402

PRESETS = {"default": moli.IdentifyOptions.default, "improved": moli.IdentifyOptions.improved,
           "paper": moli.IdentifyOptions.paper, "bounded": moli.IdentifyOptions.bounded}


def arrays(result: moli.IdentifyResult) -> dict[str, np.ndarray]:
    """The numbers of one identification that a change of code must keep."""
    model = result.model
    out = {name: np.asarray(getattr(model, name), float) for name in ("A", "B", "C", "D")}
    for name in ("K", "noise_cov", "cov_factor"):
        value = getattr(model, name, None)
        if value is not None:
            out[name] = np.asarray(value, float)
    out["path"] = np.array([[step.J, step.J_barycenter, *step.eta, *step.vaf] for step in result.path])
    return out


def snapshot(synthetic: int, seed: int, presets: list[str]) -> dict[str, np.ndarray]:
    cases = (gc.daisy_cases() + gc.evaporator_cases()
             + [gc.synthetic_case(seed, i) for i in range(synthetic)])
    found: dict[str, np.ndarray] = {}
    for preset in presets:
        options = PRESETS[preset]()
        for case in cases:
            half, (p, m) = case.val.N // 2, (case.est.p, case.est.m)
            nmax = gc.nmax_rule(p, m, case.est.N)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result = moli.identify(case.est, case.val[:half], nmax=nmax, options=options)
            for name, value in arrays(result).items():
                found[f"{preset}|{case.name}|{name}"] = value
    return found


def compare(before: dict[str, np.ndarray], now: dict[str, np.ndarray]) -> None:
    missing = sorted(set(before) ^ set(now))
    values = differ = 0
    worst, where = 0.0, ""
    for key in sorted(set(before) & set(now)):
        a, b = before[key], now[key]
        if a.shape != b.shape:
            print(f"{key}: shape {a.shape} -> {b.shape}")
            differ += max(a.size, b.size)
            continue
        values += a.size
        same = (a == b) | (np.isnan(a) & np.isnan(b))
        differ += int(np.sum(~same))
        if not np.all(same):
            scale = max(float(np.max(np.abs(a[np.isfinite(a)]), initial=0.0)), np.finfo(float).tiny)
            gap = float(np.nanmax(np.abs(a - b))) / scale
            if gap > worst:
                worst, where = gap, key
    print(f"{values} values compared, {differ} differ bit for bit; largest difference relative to "
          f"the array's largest entry {worst:.2e}{f' ({where})' if where else ''}; "
          f"{len(missing)} arrays in one run only{': ' + ', '.join(missing[:5]) if missing else ''}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("save", "compare"))
    parser.add_argument("file")
    parser.add_argument("--synthetic", type=int, default=80)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--presets", default="default")
    args = parser.parse_args()
    found = snapshot(args.synthetic, args.seed, args.presets.split(","))
    if args.action == "save":
        np.savez_compressed(args.file, **found)
        print(f"{len(found)} arrays saved to {args.file}")
    else:
        with np.load(args.file) as stored:
            compare(dict(stored), found)


if __name__ == "__main__":
    main()
