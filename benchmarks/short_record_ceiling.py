"""What any choice among moli's models could reach on the short real records: the V2 ceiling.

The short-record target (docs/regularization.md) is the mean, over the real records whose
estimation part has at most 1000 samples (DaISy halves and evaporator windows), of each
model's V2 VAF minus the best peer's, clipped to +-5 points. This script fits, on every such
record, every model moli can offer there: the default; each order from ``p`` to ``nmax``
taken as a fixed order (``identify(order=k)``: the greedy path to it, refined as the default
refines); the default with the ridge (``regularization="gcv"``); the fast preset; the
realized regularized impulse response (``method="kernel"``); the regularized ARX model
(``identify_kernel_arx``). It prints each one's figure, the figure of taking per record the
candidate with the best V1 VAF (a held-out choice), and the figure of taking the one with the
best V2 VAF: an oracle that reads the scoring data, so a ceiling that no rule choosing on
held-out data can pass.

    PYTHONPATH=src:benchmarks MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 \\
        python benchmarks/short_record_ceiling.py --peers-from <seed-0 run>/generalization.json [--jobs 2]

The peers' V2 VAF come from a ``benchmarks/generalization.py`` run (any seed: the real
records' splits do not depend on it).
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import json  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from joblib import Parallel, delayed  # noqa: E402

import generalization as gb  # noqa: E402
import generalization_cases as gc  # noqa: E402
from short_record_candidate import BEHIND, CLIP  # noqa: E402

import moli  # noqa: E402

# The models offered besides the fixed orders: name, the function of moli, its options
NAMED = (("default", "identify", {}), ("ridge (GCV)", "identify", {"regularization": "gcv"}),
         ("fast preset", "identify", {"preset": "fast"}),
         ("kernel (TC FIR realized)", "identify", {"method": "kernel"}), ("kernel ARX", "identify_kernel_arx", {}))
MAX_ESTIMATION = 1000


def scores(case: gc.Case, function: str, options: dict[str, Any]) -> tuple[float, float]:
    """(V1, V2) mean VAF of one model of the case; (0, 0) where moli refuses or fails, as the benchmark scores it."""
    half = case.val.N // 2
    nmax = gc.nmax_rule(case.est.p, case.est.m, case.est.N)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = getattr(moli, function)(case.est, case.val[:half], nmax=nmax, **options).model
            yhat = moli.compare(model, case.val).yhat
    except Exception:  # noqa: BLE001 (a failure scores 0, as in benchmarks/generalization.py)
        return 0.0, 0.0
    return gc.mean_vaf(case.val.y[:half], yhat[:half]), gc.mean_vaf(case.val.y[half:], yhat[half:])


def jobs(cases: list[gc.Case]) -> list[tuple[gc.Case, str, str, dict[str, Any]]]:
    out = []
    for case in cases:
        out += [(case, name, function, options) for name, function, options in NAMED]
        nmax = gc.nmax_rule(case.est.p, case.est.m, case.est.N)
        out += [(case, f"order {k}", "identify", {"order": k}) for k in range(case.est.p, nmax + 1)]
    return out


def clipped(values: dict[str, float], peer: dict[str, float]) -> tuple[float, int]:
    d = np.array([values[name] - peer[name] for name in peer])
    return float(np.clip(d, -CLIP, CLIP).mean()), int(np.sum(d < -BEHIND))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--peers-from", required=True, metavar="JSON", help="a benchmarks/generalization.py result")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    recorded = {c["name"]: c["best_peer"]["v2"] if c["best_peer"] else 0.0
                for c in json.loads(Path(args.peers_from).read_text())["cases"]}
    cases = [c for c in gb.build_cases(0, 0, False) if c.group != "synthetic" and c.est.N <= MAX_ESTIMATION]
    peer = {c.name: recorded[c.name] for c in cases}
    todo = jobs(cases)
    got = Parallel(n_jobs=args.jobs, backend="loky")(delayed(scores)(c, f, o) for c, _, f, o in todo)
    table: dict[str, dict[str, tuple[float, float]]] = {}
    for (case, name, _, _), score in zip(todo, got):
        table.setdefault(case.name, {})[name] = score
    print(f"{len(cases)} real records with at most {MAX_ESTIMATION} estimation samples; V2 VAF minus the best "
          f"peer's, clipped to +-{CLIP:g}\n")
    print("| model | clipped mean | records more than 2 points behind |")
    print("|---|---|---|")
    for name, _, _ in NAMED:
        mean, behind = clipped({r: table[r][name][1] for r in table}, peer)
        print(f"| {name} | {mean:+.2f} | {behind} |")
    rows = {
        "the order with the best V1, every order refined": {
            r: max((s for n, s in table[r].items() if n.startswith("order")), key=lambda s: s[0])[1] for r in table},
        "the model with the best V1, of all": {r: max(table[r].values(), key=lambda s: s[0])[1] for r in table},
        "the order with the best V2 (oracle)": {
            r: max(s[1] for n, s in table[r].items() if n.startswith("order")) for r in table},
        "the model with the best V2, of all (oracle)": {r: max(s[1] for s in table[r].values()) for r in table},
    }
    for label, values in rows.items():
        mean, behind = clipped(values, peer)
        print(f"| {label} | {mean:+.2f} | {behind} |")
    print("\n| record | best peer | default | best V2 of all (model) |")
    print("|---|---|---|---|")
    for r, models in table.items():
        best = max(models, key=lambda n: models[n][1])
        print(f"| {r} | {peer[r]:.2f} | {models['default'][1]:.2f} | {models[best][1]:.2f} ({best}) |")


if __name__ == "__main__":
    main()
