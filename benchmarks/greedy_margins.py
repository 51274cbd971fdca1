"""How close the greedy path's choices are: J gap between the two best candidates per step.

Usage::

    MOLI_DATA_DIR=/path/to/daisy python benchmarks/greedy_margins.py

Runs the default ``identify`` (nmax = 15) on the 11 evaporator windows and the half/half
splits of CD_player_arm, dryer2 and glassfurnace, and for every step of each greedy path
reports the gap between the lowest and the second-lowest J among the lists it compared.
Small gaps mean that round-off (another BLAS, another summation order) can change the
path, and with it the selected model.
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import warnings  # noqa: E402

import numpy as np  # noqa: E402

from daisy_data import load  # noqa: E402

import moli  # noqa: E402
from moli.method.search.greedy_path import StructureSearch  # noqa: E402
from moli.method.structure.indices import raised  # noqa: E402

BLOCK = 500


def splits() -> list[tuple[moli.IOData, moli.IOData]]:
    evaporator = load("evaporator")
    cuts = [(evaporator[k * BLOCK:(k + 1) * BLOCK], evaporator[(k + 1) * BLOCK:(k + 2) * BLOCK])
            for k in range(11)]
    for name in ("CD_player_arm", "dryer2", "glassfurnace"):
        data = load(name)
        cuts.append((data[: data.N // 2], data[data.N // 2:]))
    return cuts


def main() -> None:
    searches: list[StructureSearch] = []
    # keep each search's cache of fitted lists, which holds the J of every candidate
    original_fit = StructureSearch.fit

    def fit(self: StructureSearch, indices, validate: bool = True):
        if not searches or searches[-1] is not self:
            searches.append(self)
        return original_fit(self, indices, validate)

    StructureSearch.fit = fit
    gaps = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for est, val in splits():
            path = moli.identify(est, val, nmax=15, preset="improved").path
            cache = searches[-1]._cache
            for step in path[:-1]:
                costs = sorted(cache[c].J for c in raised(step.indices) if c in cache)
                if len(costs) >= 2:
                    gaps.append(costs[1] - costs[0])
    gaps = np.array(gaps)
    print(f"{gaps.size} greedy steps with two or more candidates, {len(searches)} runs")
    for bound in (1e-4, 1e-3, 1e-2):
        print(f"J gap below {bound:g}: {np.mean(gaps < bound):.0%} of the steps")
    print(f"median gap {np.median(gaps):.2e}")


if __name__ == "__main__":
    main()
