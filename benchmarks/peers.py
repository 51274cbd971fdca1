"""moli against the Python subspace peers (SIPPY, nfoursid) on four DaISy records.

Usage (peers are an optional extra: ``pip install -e '.[bench]'``, or
``pip install sippy-unipi nfoursid pandas matplotlib``)::

    MOLI_DATA_DIR=/path/to/daisy python benchmarks/peers.py [--out docs] [--quick]

Splits (estimation means removed from both records; every model simulated from the
zero state on the validation inputs; VAF per output, averaged over the outputs):

* evaporator: the paper split (estimation 0..499, validation 500..999) and the 11
  consecutive windows k = 0..10 (estimation k*500..k*500+499, validation the next 500;
  window 0 is the paper split);
* CD_player_arm, dryer2, glassfurnace: first half estimation, second half validation.

With ``--reverse`` every split is run the other way round (the evaporator windows
estimate on k*500+500..k*500+999 and validate on k*500..k*500+499; the other records
estimate on the second half and validate on the first), and the tables go to
``benchmarks_reversed.md``: a second look at each record, to tell a method's edge from
the luck of one split.

Methods, each at every order from p to nmax:

* moli, three presets of :func:`moli.identify`: ``paper`` (the paper's MOLI-ZOFT),
  ``improved`` (the earlier default: no refinement; today's default is compared with the
  peers by ``generalization.py``) and ``bounded``; plus ``improved`` with output-error
  refinement of the selected model. The VAF "per order" of moli is that of the greedy
  path's model of that order; "auto" is the model the order rule selects (lowest
  order within 1 point of the best mean validation VAF; validation data are used by
  that rule only).
* peers (``peers_lib.peer_fitters``): SIPPY N4SID, MOESP, CVA, PARSIM-K at horizons
  f = p = 20 and 2n (PARSIM-K also with B re-evaluation), nfoursid with 2n block rows.
  "auto" applies the same order rule to the peer's validation VAF over the orders.

Times are wall-clock seconds of one call of ``identify`` (whole automatic
identification: structure search, tuning, estimation, validation of the path,
refinement when asked) and, for a peer, of its sweep over the same orders (estimation
and validation simulation), one BLAS thread, all in this one process. Every split is
run ``--repeats`` times with the methods alternated, and each method's time is its
fastest repetition (as ``timeit`` reports): a single run on a shared machine can be
slowed by anything else it does.
"""

from __future__ import annotations


import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import peers_lib as pl  # noqa: E402

import moli  # noqa: E402
from moli.data.daisy import load_daisy  # noqa: E402

BLOCK = 500
WINDOWS = 11
NMAX = {"evaporator": 15, "CD_player_arm": 10, "dryer2": 12, "glassfurnace": 15}
MOLI_METHODS = {
    "moli paper": {"preset": "paper"},
    "moli improved": {"preset": "improved"},
    "moli bounded": {"preset": "bounded"},
    "moli improved+refine": {"preset": "improved", "refine": "selected"},
}
TOLERANCE = 1.0
# what a run's file, tables and figures are called, by direction of its splits
NAMING = {
    False: {"file": "benchmarks.md", "suffix": "", "tag": "",
            "windows": "Evaporator: mean over the 11 windows of 500 + 500 samples",
            "paper": "Evaporator: the paper split (estimation 0..499, validation 500..999)",
            "half": "first half estimation, second half validation"},
    True: {"file": "benchmarks_reversed.md", "suffix": "_reversed", "tag": ", reversed",
           "windows": "Evaporator, reversed: mean over the 11 windows (estimation on the later 500)",
           "paper": "Evaporator, reversed paper split (estimation 500..999, validation 0..499)",
           "half": "second half estimation, first half validation"},
}
NOTES_MARKER = "<!-- findings: kept when the tables above are regenerated -->"


def order_rule(vafs: np.ndarray, tolerance: float = TOLERANCE) -> int:
    """Position of the lowest order within ``tolerance`` points of the best (NaN = failed)."""
    clean = np.nan_to_num(vafs, nan=-np.inf)
    return int(np.flatnonzero(clean >= clean.max() - tolerance)[0])


def splits(data: moli.IOData, name: str, reverse: bool = False) -> list[tuple[str, slice, slice]]:
    """Named (estimation, validation) slices of one record (swapped with ``reverse``)."""
    if name == "evaporator":
        pairs = [(f"w{k}", slice(k * BLOCK, (k + 1) * BLOCK), slice((k + 1) * BLOCK, (k + 2) * BLOCK))
                 for k in range(WINDOWS)]
    else:
        half = data.N // 2
        pairs = [("half", slice(0, half), slice(half, data.N))]
    return [(label, val, est) for label, est, val in pairs] if reverse else pairs


def run_moli(data: moli.IOData, est: slice, val: slice, nmax: int, options: dict) -> dict:
    """One automatic identification; per-order path VAF, selection and wall times."""
    stamps: list[tuple[int, float]] = []
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = moli.identify(data[est], data[val], nmax=nmax,
                               progress=lambda st: stamps.append((st.order, time.perf_counter() - start)),
                               **options)
    seconds = time.perf_counter() - start
    orders = list(range(data.p, nmax + 1))
    per_order = {st.order: st for st in result.path}
    return {
        "orders": orders,
        "vaf": [float(per_order[n].mean_vaf) if n in per_order else np.nan for n in orders],
        "vaf_outputs": [per_order[n].vaf.tolist() if n in per_order else None for n in orders],
        "auto_order": int(result.selected.order),
        "auto_vaf": float(result.selected.mean_vaf),
        "auto_vaf_outputs": result.selected.vaf.tolist(),
        "stable": [bool(per_order[n].stable) if n in per_order else False for n in orders],
        "cumulative": [dict(stamps).get(n, np.nan) for n in orders],
        "seconds": seconds,
    }


def run_peer(fit, data: moli.IOData, est: slice, val: slice, nmax: int) -> dict:
    """One peer swept over the orders p..nmax; same centring and VAF as moli."""
    y_est, u_est, y_val, u_val = pl.centred_split(np.asarray(data.y), np.asarray(data.u), est, val)
    orders = list(range(data.p, nmax + 1))
    vafs, outputs, cumulative, total = [], [], [], 0.0
    for n in orders:
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = fit(y_est, u_est, n)
            v = None if model is None else pl.simulate_vaf(*model, u_val, y_val)
        total += time.perf_counter() - start
        cumulative.append(total)
        vafs.append(np.nan if v is None else float(v.mean()))
        outputs.append(None if v is None else v.tolist())
    auto = order_rule(np.array(vafs))
    return {"orders": orders, "vaf": vafs, "vaf_outputs": outputs, "auto_order": orders[auto],
            "auto_vaf": vafs[auto], "auto_vaf_outputs": outputs[auto], "cumulative": cumulative,
            "seconds": total}


def collect(datasets: list[str], peers: dict, data_dir: str | None, repeats: int = 1,
            reverse: bool = False) -> dict:
    results: dict = {}
    for name in datasets:
        data = load_daisy(name, data_dir)
        nmax = NMAX[name]
        for label, est, val in splits(data, name, reverse):
            key = f"{name}/{label}"
            results[key] = {"p": data.p, "outputs": list(data.output_names), "methods": {}}
            runs = [(m, lambda o=o: run_moli(data, est, val, nmax, o)) for m, o in MOLI_METHODS.items()]
            runs += [(m, lambda f=f: run_peer(f, data, est, val, nmax)) for m, f in peers.items()]
            lines = results[key]["methods"]
            for _ in range(repeats):
                for method, run in runs:
                    line = run()
                    # results are deterministic: only the fastest repetition's times are kept
                    if method not in lines or line["seconds"] < lines[method]["seconds"]:
                        lines[method] = line
            moli_line = results[key]["methods"]["moli improved"]
            print(f"{key:22s} moli improved auto n={moli_line['auto_order']:2d} "
                  f"VAF {moli_line['auto_vaf']:6.2f} in {moli_line['seconds']:.3f} s", flush=True)
    return results


def summarize(results: dict, keys: list[str], methods: list[str]) -> list[dict]:
    """Per method over the given splits: best fixed order, auto VAF, times."""
    rows = []
    for method in methods:
        lines = [results[k]["methods"][method] for k in keys]
        orders = lines[0]["orders"]
        # a failed fit counts as 0 % so that failures are not hidden by the mean
        table = np.array([np.nan_to_num(np.array(l["vaf"], float), nan=0.0) for l in lines])
        mean = table.mean(axis=0)
        best = int(np.argmax(mean))
        rows.append({
            "method": method, "orders": orders, "mean_per_order": mean.tolist(),
            "best_order": orders[best], "best_fixed": float(mean[best]),
            "auto": float(np.mean([l["auto_vaf"] for l in lines])),
            "auto_orders": [l["auto_order"] for l in lines],
            "seconds": float(np.mean([l["seconds"] for l in lines])),
        })
    return rows


def fmt(value: float) -> str:
    return "—" if value is None or not np.isfinite(value) else f"{value:.2f}"


def markdown(results: dict, methods: list[str], peers: list[str], command: str,
             reverse: bool = False) -> str:
    window_keys = [k for k in results if k.startswith("evaporator/")]
    other_keys = [k for k in results if not k.startswith("evaporator/")]
    names = NAMING[reverse]
    out = ["# moli against SIPPY and nfoursid on DaISy records" + names["tag"], "",
           "Produced by:", "", "```", command, "```", "",
           f"Machine: {platform.machine()}, Python {platform.python_version()}, numpy "
           f"{np.__version__}, one BLAS thread. VAF: validation, percent, simulation from the "
           "zero state, estimation means removed from both records, averaged over the outputs "
           "unless stated. \"auto\": the order picked by the rule \"lowest order within 1 point "
           "of the best mean validation VAF\" (the paper's; validation data are used by this "
           "rule only). \"best fixed\": the single order that is best on average over the "
           "splits in the table (chosen on the validation data, so optimistic).", ""]

    def table(keys: list[str], title: str) -> None:
        rows = summarize(results, keys, methods)
        out.extend([f"## {title}", "",
                    "| method | auto VAF | auto orders | best fixed VAF | at n | time per split (s) |",
                    "|---|---|---|---|---|---|"])
        for r in rows:
            orders = ", ".join(str(o) for o in r["auto_orders"]) if len(keys) > 1 else str(r["auto_orders"][0])
            out.append(f"| {r['method']} | {fmt(r['auto'])} | {orders} | {fmt(r['best_fixed'])} | "
                       f"{r['best_order']} | {r['seconds']:.3f} |")
        out.append("")

    if window_keys:
        table(window_keys, names["windows"])
        table(["evaporator/w0"], names["paper"])
    for k in other_keys:
        table([k], f"{k.split('/')[0]}: {names['half']}")
    if not window_keys:
        return "\n".join(out)

    # per window and per output
    rows = summarize(results, window_keys, methods)
    best_peer = max((r for r in rows if r["method"] in peers), key=lambda r: r["best_fixed"])
    out.extend(["## Evaporator, per window", "",
                f"moli rows: the automatically selected model. Peer row: {best_peer['method']} at its "
                f"best fixed order n = {best_peer['best_order']}.", "",
                "| window | " + " | ".join(m for m in methods if m.startswith("moli")) +
                f" | {best_peer['method']} n={best_peer['best_order']} |",
                "|---|" + "---|" * (sum(m.startswith("moli") for m in methods) + 1)])
    at = best_peer["orders"].index(best_peer["best_order"])
    for k in window_keys:
        cells = [f"{fmt(results[k]['methods'][m]['auto_vaf'])} (n={results[k]['methods'][m]['auto_order']})"
                 for m in methods if m.startswith("moli")]
        cells.append(fmt(results[k]["methods"][best_peer["method"]]["vaf"][at]))
        out.append(f"| {k.split('/')[1]} | " + " | ".join(cells) + " |")
    names = results[window_keys[0]]["outputs"]
    out.extend(["", "Per output, mean over the 11 windows:", "",
                "| method | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)])
    for m in [m for m in methods if m.startswith("moli")]:
        per = np.mean([results[k]["methods"][m]["auto_vaf_outputs"] for k in window_keys], axis=0)
        out.append(f"| {m} (auto) | " + " | ".join(fmt(v) for v in per) + " |")
    per = np.mean([np.nan_to_num(np.array(results[k]["methods"][best_peer["method"]]["vaf_outputs"][at], float))
                   for k in window_keys], axis=0)
    out.append(f"| {best_peer['method']} n={best_peer['best_order']} | " + " | ".join(fmt(v) for v in per) + " |")

    # timing ratios
    out.extend(["", "## Time: moli's whole automatic identification against each peer's sweep", "",
                "Mean wall time per split (same orders p..nmax; each split's time is the fastest "
                "of the repetitions). Ratio = moli improved / peer (below 1: moli is faster).", "",
                "| data | moli improved (s) | " + " | ".join(peers) + " |",
                "|---|---|" + "---|" * len(peers)])
    groups = [("evaporator (11 windows)", window_keys)] + [(k.split("/")[0], [k]) for k in other_keys]
    for title, keys in groups:
        mt = np.mean([results[k]["methods"]["moli improved"]["seconds"] for k in keys])
        cells = []
        for p in peers:
            pt = np.mean([results[k]["methods"][p]["seconds"] for k in keys])
            cells.append(f"{pt:.3f} s ({mt / pt:.2f})")
        out.append(f"| {title} | {mt:.3f} | " + " | ".join(cells) + " |")
    out.append("")
    return "\n".join(out)


def figures(results: dict, methods: list[str], outdir: Path, reverse: bool = False) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    outdir.mkdir(parents=True, exist_ok=True)
    # --quick leaves PARSIM-K out of the methods run: a peer not run is not drawn
    shown = [m for m in methods if m.startswith("moli") and "refine" not in m] + [
        m for m in ("SIPPY N4SID f=2n", "SIPPY MOESP f=2n", "SIPPY CVA f=2n", "SIPPY PARSIM-K f=2n B-reval",
                    "nfoursid r=2n") if m in methods]
    window_keys = [k for k in results if k.startswith("evaporator/")]
    suffix, tag = NAMING[reverse]["suffix"], NAMING[reverse]["tag"]
    panels = [("evaporator, mean of 11 windows" + tag, window_keys), ("evaporator, paper split" + tag, ["evaporator/w0"])]
    panels += [(k.split("/")[0] + ", half/half" + tag, [k]) for k in results if not k.startswith("evaporator/")]
    paths = []
    fig, axes = plt.subplots(2, 3, figsize=(15, 8.5))
    for ax, (title, keys) in zip(axes.ravel(), panels):
        rows = {r["method"]: r for r in summarize(results, keys, shown)}
        for m in shown:
            r = rows[m]
            style = "-o" if m.startswith("moli") else "--."
            ax.plot(r["orders"], r["mean_per_order"], style, label=m, lw=1.5 if m.startswith("moli") else 1)
        ax.set_ylim(0, 100)
        ax.set_title(title)
        ax.set_xlabel("order n")
        ax.set_ylabel("mean validation VAF, %")
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[len(panels):]:
        ax.axis("off")
    axes[0, 0].legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    paths.append(outdir / f"peers_vaf_per_order{suffix}.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for m in shown:
        cum = np.nanmean([results[k]["methods"][m]["cumulative"] for k in window_keys], axis=0)
        ax.plot(results[window_keys[0]]["methods"][m]["orders"], cum, "-o" if m.startswith("moli") else "--.", label=m)
    ax.set_yscale("log")
    ax.set_xlabel("order n")
    ax.set_ylabel("cumulative wall time, s (mean of 11 windows)")
    ax.set_title("evaporator" + tag + ": cumulative run time up to order n (one BLAS thread)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    fig.tight_layout()
    paths.append(outdir / f"peers_cumulative_time{suffix}.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    rows = summarize(results, window_keys, [m for m in methods if not m.startswith("moli")])
    best = max(rows, key=lambda r: r["best_fixed"])
    at = best["orders"].index(best["best_order"])
    fig, ax = plt.subplots(figsize=(9, 4.5))
    x = np.arange(len(window_keys))
    shown_moli = [m for m in methods if m.startswith("moli") and "refine" not in m]
    width = 0.8 / (len(shown_moli) + 1)
    for i, m in enumerate(shown_moli):
        ax.bar(x + i * width, [results[k]["methods"][m]["auto_vaf"] for k in window_keys], width, label=f"{m} (auto)")
    ax.bar(x + len(shown_moli) * width, [results[k]["methods"][best["method"]]["vaf"][at] for k in window_keys],
           width, label=f"{best['method']} n={best['best_order']} (best fixed)")
    ax.set_xticks(x + 0.4 - width / 2, [k.split("/")[1] for k in window_keys])
    ax.set_ylim(50, 95)
    ax.set_ylabel("mean validation VAF, %")
    ax.set_title("evaporator windows" + tag + ": automatically selected moli models vs the best peer")
    ax.legend(fontsize=7, loc="lower right")
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    paths.append(outdir / f"peers_windows{suffix}.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    return paths


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data-dir", default=None, help="folder of the DaISy .dat files")
    parser.add_argument("--out", default=None, help="write benchmarks.md and figures/ under this folder")
    parser.add_argument("--datasets", nargs="+", default=list(NMAX))
    parser.add_argument("--quick", action="store_true", help="skip PARSIM-K (slow)")
    parser.add_argument("--json", default=None, help="also write every number to this JSON file")
    parser.add_argument("--reverse", action="store_true",
                        help="swap estimation and validation in every split; writes benchmarks_reversed.md")
    parser.add_argument("--repeats", type=int, default=3,
                        help="runs per split and method; times are the fastest run's")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    peers = pl.peer_fitters()
    if args.quick:
        peers = {k: v for k, v in peers.items() if "PARSIM" not in k}
    # warm-up: imports and first-call costs are not charged to any method
    warm = load_daisy("evaporator", args.data_dir)
    y, u = np.asarray(warm.y), np.asarray(warm.u)
    y_est, u_est, _, _ = pl.centred_split(y, u, slice(0, 300), slice(300, 600))
    pl.fit_sippy("N4SID", y_est, u_est, 3)
    pl.fit_nfoursid(y_est, u_est, 3, 6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        moli.identify(warm[0:300], warm[300:600], nmax=4)

    results = collect(args.datasets, peers, args.data_dir, args.repeats, args.reverse)
    methods = list(MOLI_METHODS) + list(peers)
    command = "MOLI_DATA_DIR=<daisy folder> python benchmarks/peers.py " + " ".join(
        a for a in sys.argv[1:] if not a.startswith("--data-dir"))
    text = markdown(results, methods, list(peers), command.strip(), args.reverse)
    print(text)
    if args.json:
        Path(args.json).write_text(json.dumps(results, default=float))
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        target = out / NAMING[args.reverse]["file"]
        notes = ""
        if target.exists() and NOTES_MARKER in target.read_text():
            # hand-written findings below the marker survive a re-run
            notes = target.read_text().split(NOTES_MARKER, 1)[1]
        target.write_text(text + "\n" + NOTES_MARKER + notes)
        paths = (figures(results, methods, out / "figures", args.reverse)
                 if "evaporator" in args.datasets else [])
        print("wrote", target, *paths)


if __name__ == "__main__":
    main()
