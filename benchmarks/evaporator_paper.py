"""Paper reproduction on the DaISy evaporator (Section V-A of the paper).

Prints the greedy path (indices, J, validation VAF per output and on average) and
the selected order on the paper's split, the same on the 11 consecutive 500/500
windows, and how often greedy finds the best list of each order (exhaustive
search, n = 3..9). Estimation means are removed from both records; VAF is the
validation VAF of the simulation from the zero state; the validation record is
used only by the order rule.

    OPENBLAS_NUM_THREADS=1 python benchmarks/evaporator_paper.py [--windows] [--exhaustive]
"""

from __future__ import annotations


import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse
import time
import warnings

import numpy as np

import moli
from moli.method.search.greedy_path import StructureSearch, exhaustive, greedy_path

from daisy_data import load

PAPER_OMEGA = moli.method.tuning.barycenter.grid(np.array([0.02, 0.0355, 0.0631, 0.1122, 0.1995, 0.3548]) * np.pi, [0.6, 0.7, 1.1])
PAPER_PATH = [(1, 2, 1), (1, 3, 1), (1, 4, 1), (1, 5, 1), (2, 5, 1), (3, 5, 1), (3, 6, 1), (4, 6, 1),
              (4, 7, 1), (4, 8, 1), (5, 8, 1), (6, 8, 1)]
MODES = {"paper-faithful (preset='paper': random barycenter)": {"preset": "paper"}, "improved preset (the earlier default)": {"preset": "improved"}}


def window(data: moli.IOData, k: int) -> tuple[moli.IOData, moli.IOData]:
    return data[k * 500 : k * 500 + 500], data[k * 500 + 500 : k * 500 + 1000]


def paper_split(data: moli.IOData) -> None:
    est, val = window(data, 0)
    for name, options in MODES.items():
        result = moli.identify(est, val, nmax=15, omega=PAPER_OMEGA, **options)
        print(f"\n## {name}: estimation 0..499, validation 500..999")
        print(result.summary())
        agree = sum(st.indices == ref for st, ref in zip(result.path[1:], PAPER_PATH))
        print(f"path agrees with the paper's on its first {_prefix(result)} lists ({agree} of 12 overall)")


def _prefix(result: moli.IdentificationResult) -> int:
    count = 0
    for st, ref in zip(result.path[1:], PAPER_PATH):
        if st.indices != ref:
            break
        count += 1
    return count


def windows(data: moli.IOData) -> None:
    print("\n## 11 windows: estimation k*500..k*500+499, validation the next 500")
    for name, options in MODES.items():
        rows = []
        for k in range(11):
            est, val = window(data, k)
            result = moli.identify(est, val, nmax=15, omega=PAPER_OMEGA, **options)
            st = result.selected
            rows.append((k, st.order, st.mean_vaf, *st.vaf, max(s.mean_vaf for s in result.path), result.seconds))
        table = np.array(rows)
        print(f"\n{name}")
        print(" k   n  sel VAF    y1     y2     y3   best on path  seconds")
        for r in rows:
            print(f"{r[0]:2d}  {r[1]:2d}  {r[2]:6.2f}  {r[3]:6.2f} {r[4]:6.2f} {r[5]:6.2f}   {r[6]:6.2f}   {r[7]:7.2f}")
        print(f"mean    {table[:, 2].mean():6.2f}  {table[:, 3].mean():6.2f} {table[:, 4].mean():6.2f} "
              f"{table[:, 5].mean():6.2f}   {table[:, 6].mean():6.2f}   {table[:, 7].mean():7.2f}")


def greedy_vs_exhaustive(data: moli.IOData) -> None:
    print("\n## greedy vs exhaustive, n = 3..9 (paper split, paper-faithful tuning)")
    print(" n  lists  greedy list   greedy VAF  best list    best VAF  rank of greedy (by VAF)  greedy best J?")
    est, val = window(data, 0)
    est = est.remove_means()
    val = val.remove_means(est.y_offset, est.u_offset)
    search = StructureSearch(est, val, PAPER_OMEGA, tuning="random")  # the paper preset's search
    path = {st.order: st for st in greedy_path(search, 9)}
    found_vaf = found_j = 0
    for n in range(3, 10):
        steps = exhaustive(search, n)
        best = max(steps, key=lambda st: st.mean_vaf)
        best_j = min(steps, key=lambda st: st.J)
        g = path[n]
        rank = 1 + sum(st.mean_vaf > g.mean_vaf for st in steps)
        found_vaf += g.indices == best.indices
        found_j += g.indices == best_j.indices
        print(f"{n:2d}  {len(steps):5d}  {str(list(g.indices)):12s} {g.mean_vaf:8.2f}    "
              f"{str(list(best.indices)):12s} {best.mean_vaf:7.2f}  {rank:3d} of {len(steps):<3d}"
              f"              {'yes' if g.indices == best_j.indices else 'no'}")
    print(f"greedy found the best-VAF list at {found_vaf} of 7 orders and the lowest-J list at {found_j} of 7")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", action="store_true", help="also run the 11 windows")
    parser.add_argument("--exhaustive", action="store_true", help="also compare with exhaustive search")
    args = parser.parse_args()
    warnings.simplefilter("ignore", moli.UnstableModelWarning)
    data = load("evaporator")
    start = time.perf_counter()
    paper_split(data)
    if args.windows:
        windows(data)
    if args.exhaustive:
        greedy_vs_exhaustive(data)
    print(f"\ntotal {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
