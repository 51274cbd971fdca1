"""Whether a change of code keeps every identified model: snapshot now, compare later.

Identifies every case of the generalization benchmark (benchmarks/generalization_cases.py:
the DaISy records both ways, the evaporator windows and the synthetic systems of one
seed) with the given presets, and stores each result's model (A, B, C, D, and K, the noise
covariance and the parameters' covariance factor where present) and its path (each list's J, J at the barycenter, eta
and validation VAF). ``compare`` runs the same identifications on the current code and
counts the values that differ from the snapshot, bit for bit, lists the cases whose selected
list of indices (or order) changed, and gives the largest difference of each matrix relative to
its largest entry (a covariance factor ``F`` as ``F F^T``, whose value does not depend on the
signs of ``F``'s columns).

    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/same_models.py save before.npz
    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/same_models.py compare before.npz

``--synthetic K`` sets the number of synthetic systems (80 by default), ``--seed`` their
seed, ``--presets default,improved`` the option sets, ``--set NAME=JSON`` an option changed
in each of them (to compare code across a change of a default, say).
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import json  # noqa: E402
from typing import Any  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

import generalization_cases as gc  # noqa: E402
import moli  # noqa: E402

# The matrices of a model, and how far apart a change of arithmetic may leave them (relative
# to each matrix's largest entry)
MATRICES = ("A", "B", "C", "D", "K")
TOLERANCE = 1e-9
# Frequencies of the compared frequency response, log-spaced from 1e-3 of Nyquist to Nyquist
RESPONSE_POINTS = 32
PRESETS = {"default": moli.IdentifyOptions.default, "fast": moli.IdentifyOptions.fast,
           "improved": moli.IdentifyOptions.improved, "paper": moli.IdentifyOptions.paper,
           "bounded": moli.IdentifyOptions.bounded}


def arrays(result: moli.IdentifyResult) -> dict[str, np.ndarray]:
    """The numbers of one identification that a change of code must keep."""
    model = result.model
    out = {name: np.asarray(getattr(model, name), float) for name in ("A", "B", "C", "D")}
    for name in ("K", "noise_cov", "cov_factor"):
        value = getattr(model, name, None)
        if value is not None:
            out[name] = np.asarray(value, float)
    # the input-output map itself: matrices may move along directions that leave it unchanged
    omega = np.pi / model.Ts * np.logspace(-3, 0, RESPONSE_POINTS)
    response = model.frequency_response(omega)
    out["response"] = np.concatenate([response.real.ravel(), response.imag.ravel()])
    out["path"] = np.array([[step.J, step.J_barycenter, *step.eta, *step.vaf] for step in result.path])
    out["indices"] = np.array(result.selected.indices, float)
    return out


def snapshot(synthetic: int, seed: int, presets: list[str], changes: dict[str, Any]) -> dict[str, np.ndarray]:
    cases = (gc.daisy_cases() + gc.evaporator_cases()
             + [gc.synthetic_case(seed, i) for i in range(synthetic)])
    found: dict[str, np.ndarray] = {}
    for preset in presets:
        options = PRESETS[preset](**changes)
        for case in cases:
            half, (p, m) = case.val.N // 2, (case.est.p, case.est.m)
            nmax = gc.nmax_rule(p, m, case.est.N)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result = moli.identify(case.est, case.val[:half], nmax=nmax, options=options)
            for name, value in arrays(result).items():
                found[f"{preset}|{case.name}|{name}"] = value
    return found


def _comparable(key: str, value: np.ndarray) -> np.ndarray:
    """The array as compared: a covariance factor ``F`` by ``F F^T`` (its columns' signs are free)."""
    return value @ value.T if key.endswith("|cov_factor") else value


def compare(before: dict[str, np.ndarray], now: dict[str, np.ndarray]) -> None:
    missing = sorted(set(before) ^ set(now))
    values = differ = 0
    worst: dict[str, tuple[float, str]] = {}
    structures = []
    apart: dict[str, float] = {}
    responses: dict[str, float] = {}
    for key in sorted(set(before) & set(now)):
        a, b = before[key], now[key]
        name = key.rsplit("|", 1)[1]
        if a.shape != b.shape or (name == "indices" and not np.array_equal(a, b)):
            structures.append(f"{key}: {a.shape if name != 'indices' else a.tolist()} -> "
                              f"{b.shape if name != 'indices' else b.tolist()}")
            differ += max(a.size, b.size)
            continue
        values += a.size
        same = (a == b) | (np.isnan(a) & np.isnan(b))
        differ += int(np.sum(~same))
        if not np.all(same):
            a, b = _comparable(key, a), _comparable(key, b)
            finite = np.isfinite(a) & np.isfinite(b)
            scale = max(float(np.max(np.abs(a[finite]), initial=0.0)), np.finfo(float).tiny)
            gap = float(np.max(np.abs(a - b)[finite], initial=0.0)) / scale
            if gap > worst.get(name, (-1.0, ""))[0]:
                worst[name] = (gap, key)
            if gap > TOLERANCE and name in MATRICES:
                case = key.rsplit("|", 1)[0]
                apart[case] = max(apart.get(case, 0.0), gap)
            if name == "response":
                responses[key.rsplit("|", 1)[0]] = gap
    print(f"{values} values compared, {differ} differ bit for bit; "
          f"{len(missing)} arrays in one run only{': ' + ', '.join(missing[:5]) if missing else ''}")
    print(f"selected structures or orders that differ: {len(structures)}")
    for line in structures:
        print(f"  {line}")
    print("largest difference relative to the array's largest entry (a covariance factor F as F F^T):")
    for name, (gap, key) in sorted(worst.items()):
        print(f"  {name:10s} {gap:.2e}  ({key})")
    cases = len({key.rsplit("|", 1)[0] for key in now})
    print(f"models with A, B, C, D or K apart by more than {TOLERANCE:g}: {len(apart)} of {cases}")
    for case, gap in sorted(apart.items(), key=lambda item: -item[1]):
        print(f"  {case}: {gap:.1e}, frequency response {responses.get(case, 0.0):.1e}")
    print(f"models whose frequency response is apart by more than {TOLERANCE:g}: "
          f"{sum(gap > TOLERANCE for gap in responses.values())} of {cases}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("save", "compare"))
    parser.add_argument("file")
    parser.add_argument("--synthetic", type=int, default=80)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--presets", default="default")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=JSON",
                        help="an option changed in every preset, e.g. order_tolerance=0 (repeatable)")
    args = parser.parse_args()
    changes = {}
    for item in args.set:
        name, _, value = item.partition("=")
        changes[name] = json.loads(value)
    found = snapshot(args.synthetic, args.seed, args.presets.split(","), changes)
    if args.action == "save":
        np.savez_compressed(args.file, **found)
        print(f"{len(found)} arrays saved to {args.file}")
    else:
        with np.load(args.file) as stored:
            compare(dict(stored), found)


if __name__ == "__main__":
    main()
