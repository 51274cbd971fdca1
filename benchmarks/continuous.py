"""Continuous-time identification against the discrete path (docs/continuous.md).

Usage::

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=src python benchmarks/continuous.py \\
        [--seeds 20] [--parts 1,2,3,4] [--jobs 2] [--out DIR]

Parts (plant and records in continuous_cases.py: poles -1, -2 +- 3j, -20 rad/s, 2x2,
observability indices (2, 2); two held random binary inputs switching at exponential
times of mean 0.1 s; white output noise at 30 dB per output):

1. Fast sampling: 1 ms for 20 s. ``identify(data, time="continuous")`` with the default
   order rule (paired) and with ``order_rule="tolerance"`` (the best validation VAF), and ``identify(data)`` followed by
   ``to_continuous()``: selected order, each true pole's relative error to the nearest
   estimated pole, the worst, seconds.
2. Irregular sampling: steps uniform in 0.5..1.5 ms, three stretches of 100 samples
   missing, simulated exactly. The first 70 % estimates, the rest validates (as
   ``identify`` holds out by default). Fresh-data fit (a new uniformly sampled record from
   rest, noise-free) of its model against the model from part 1's record of the seed.
3. Exactness of the filtering: ``observer_rows`` against RK4 (held inputs, linear
   outputs) on noise-free irregular stamps; the pole error at order 4 on noise-free
   records for T = 20, 10, 5, 2.5 ms and its log-log slope.
4. DaISy records with a stated sampling period: first 2/3 estimates, last 1/3 is
   fresh data; both paths simulated over it from the operating point (zero deviation).
5. The order rule's width, chosen on other seeds (100-109) than parts 1 and 2 report:
   the order the paired rule selects at 0.5 to 3 standard errors, at one standard error
   with a negligible loss of 0.001 to 0.03 points, and the best-VAF rule,
   on the uniform and the irregular record of each seed (one search each; the path does
   not depend on the rule).

Output in --out: continuous.json (every per-case figure) and continuous.md (summary).
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, Callable  # noqa: E402

import numpy as np  # noqa: E402
from joblib import Parallel, delayed  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import continuous_cases as cc  # noqa: E402
import daisy_data  # noqa: E402

import moli  # noqa: E402
from moli.data.daisy import list_daisy  # noqa: E402
from moli.method.continuous.estimation import StampedRecord, observer_rows  # noqa: E402
from moli.method.continuous.filters import unit_divisors  # noqa: E402
from moli.method.pipeline.preparation import HOLDOUT_FRACTION  # noqa: E402
from moli.method.selection.order_rules import select_by_shares, select_order  # noqa: E402

Case = dict[str, Any]
METHODS = ("continuous", "continuous_tolerance", "discrete")
PERIODS = (20e-3, 10e-3, 5e-3, 2.5e-3)
CONVERGENCE_SEEDS = 3
ORDER_SEEDS = range(100, 110)          # part 5 chooses on these, parts 1 and 2 report on 0..seeds-1
ORDER_WIDTHS = (0.5, 1.0, 1.5, 2.0, 3.0)
NEGLIGIBLE_LOSSES = (0.001, 0.003, 0.01, 0.03)   # points of VAF that pass whatever the standard error
SKIPPED_DAISY = ("distill2",)   # three step responses, not an input-output record


def timed(call: Callable[[], Any]) -> tuple[Any, float]:
    start = time.perf_counter()
    value = call()
    return value, time.perf_counter() - start


def continuous_line(result: Any, seconds: float) -> Case:
    return {"order": result.selected.order, "seconds": seconds, **cc.pole_errors(result.model.poles())}


def identify_stamped(record: cc.Record) -> Any:
    """``identify(time="continuous")`` on a stamped record, the default hold-out made by hand
    (the stamps of each part must follow it)."""
    data = cc.stamped(record.y, record.u, record.t)
    estimation, validation = data.split(1.0 - HOLDOUT_FRACTION)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return moli.identify(estimation, validation, time="continuous")


def seed_case(seed: int, parts: set[int]) -> Case:
    """Parts 1 and 2 of one seed (part 2 needs part 1's default continuous model)."""
    record = cc.uniform_record(seed)
    data = moli.IOData(record.y, record.u, Ts=cc.PERIOD)
    case: Case = {"seed": seed}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        uniform, seconds = timed(lambda: moli.identify(data, time="continuous"))
        case["continuous"] = continuous_line(uniform, seconds)
        if 1 in parts:
            best, seconds = timed(lambda: moli.identify(data, time="continuous", order_rule="tolerance"))
            case["continuous_tolerance"] = continuous_line(best, seconds)
            discrete, seconds = timed(lambda: moli.identify(data))
        line: Case = {"order": discrete.selected.order, "seconds": seconds}
        try:
            line.update(cc.pole_errors(discrete.model.to_continuous().poles()), failed=None)
        except moli.MoliError as exc:
            line.update(cc.pole_errors(np.array([])), failed=str(exc)[:200])
        case["discrete"] = line
    if 2 in parts:
        irregular, seconds = timed(lambda: identify_stamped(cc.irregular_record(seed)))
        fresh = cc.uniform_record(seed, noisy=False, stream=3)
        # plant linear through the origin and fresh record from rest: the deviation
        # models simulated from the zero state predict it whatever their offsets
        fits = {name: cc.fit(fresh.y, result.model.simulate(fresh.u, fresh.t))
                for name, result in (("irregular", irregular), ("uniform", uniform))}
        case["irregular"] = {**continuous_line(irregular, seconds), **{f"fit_{k}": v for k, v in fits.items()}}
    return case


def exactness_case(wc: float) -> Case:
    """``observer_rows`` against RK4 on 2 s of noise-free irregular stamps."""
    rng = np.random.default_rng([0, 4])
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 1999))])
    u = cc.binary_input(t, rng)
    y = cc.simulate_exact(t, u)
    alpha = unit_divisors(0.7, (2, 2), moli.IdentifyOptions().s)[0]
    rows = observer_rows(StampedRecord((t,), (y,), (u,)), wc, alpha, False, 0)[0]
    substeps = 100
    reference = cc.reference_filtering(t, y, u, wc, alpha, substeps)
    method = rows[:, : reference.shape[1]]
    scale = np.max(np.abs(reference), axis=0)
    return {"wc": wc, "zeta": 0.7, "substeps": substeps, "samples": t.size,
            "max_relative_difference": float(np.max(np.max(np.abs(method - reference), axis=0) / scale))}


def convergence_case(period: float, seed: int, center: bool) -> Case:
    record = cc.uniform_record(seed, period=period, noisy=False)
    data = moli.IOData(record.y, record.u, Ts=period)
    result, seconds = timed(lambda: moli.identify(data, time="continuous", order=4, center=center))
    return {"period": period, "seed": seed, "center": center, "seconds": seconds,
            **cc.pole_errors(result.model.poles())}


def daisy_names() -> list[str]:
    folder = daisy_data.daisy_dir()
    return [info.name for info in list_daisy() if info.Ts_stated and info.name not in SKIPPED_DAISY
            and (folder / f"{info.name}.dat").exists()]


def daisy_case(name: str) -> Case:
    data = daisy_data.load(name)
    estimation, fresh = data.split(int(round(2 * data.N / 3)))
    case: Case = {"name": name, "N": data.N, "p": data.p, "m": data.m, "Ts": data.Ts}
    for method, kwargs in (("discrete", {}), ("continuous", {"time": "continuous"})):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result, seconds = timed(lambda: moli.identify(estimation, **kwargs))
            model = result.model
            u = fresh.u - model.u_offset
            yhat = model.simulate(u) if method == "discrete" else model.simulate(u, fresh.time())
            case[method] = {"order": result.selected.order, "seconds": seconds,
                            "fit": cc.fit(fresh.y, yhat + model.y_offset), "failed": None}
        except moli.MoliError as exc:
            case[method] = {"failed": f"{type(exc).__name__}: {str(exc)[:200]}"}
    return case


def order_case(seed: int, kind: str) -> Case:
    """Part 5: the order each rule width selects on one search's path."""
    record = cc.uniform_record(seed) if kind == "uniform" else cc.irregular_record(seed)
    path = identify_stamped(record).path
    orders = {f"z={z:g}": path[select_by_shares(path, lambda i: path[i].errors, z)].order for z in ORDER_WIDTHS}
    orders |= {f"z=1, {d:g} pt": path[select_by_shares(path, lambda i: path[i].errors, 1.0, d)].order
               for d in NEGLIGIBLE_LOSSES}
    return {"seed": seed, "kind": kind, **orders, "best VAF": path[select_order(path, 0.0)].order}


def run_task(task: tuple) -> tuple[str, Case]:
    kind, *args = task
    runner = {"seed": seed_case, "exact": exactness_case, "convergence": convergence_case,
              "daisy": daisy_case, "order": order_case}[kind]
    case, seconds = timed(lambda: runner(*args))
    return kind, {**case, "task_seconds": seconds}


def median(values: list[float]) -> float:
    return float(np.median(values)) if values else float("nan")


def pct(value: float) -> str:
    return f"{100 * value:.2f} %" if np.isfinite(value) else "—"


def fast_table(seeds: list[Case]) -> list[str]:
    head = "| method | " + " | ".join(f"median error {n}" for n in cc.REPORTED) + \
           " | median worst | true order (of {}) | worst <= 2 % | failures | median s |".format(len(seeds))
    lines = [head, "|" + "---|" * (len(cc.REPORTED) + 6)]
    for method in METHODS:
        rows = [s[method] for s in seeds]
        errs = [median([r[n] for r in rows]) for n in (*cc.REPORTED, "worst")]
        failures = sum(1 for r in rows if r.get("failed"))
        lines.append(f"| {method} | " + " | ".join(pct(e) for e in errs) +
                     f" | {sum(r['order'] == 4 for r in rows)} | {sum(r['worst'] <= 0.02 for r in rows)} | "
                     f"{failures} | {median([r['seconds'] for r in rows]):.1f} |")
    return lines


def irregular_table(seeds: list[Case]) -> list[str]:
    rows = [s["irregular"] for s in seeds]
    diff = [r["fit_irregular"] - r["fit_uniform"] for r in rows]
    return [
        "| figure | value |", "|---|---|",
        f"| median fresh fit, irregular model | {median([r['fit_irregular'] for r in rows]):.3f} |",
        f"| median fresh fit, uniform model | {median([r['fit_uniform'] for r in rows]):.3f} |",
        f"| median difference (irregular - uniform), points | {median(diff):+.3f} |",
        f"| largest abs difference, points | {max(abs(d) for d in diff):.3f} |",
        f"| seeds with every pole within 3 % | {sum(r['worst'] <= 0.03 for r in rows)} of {len(rows)} |",
        f"| seeds with the true order | {sum(r['order'] == 4 for r in rows)} of {len(rows)} |",
        "| median error " + ", ".join(cc.REPORTED) + " | " +
        ", ".join(pct(median([r[n] for r in rows])) for n in cc.REPORTED) + " |",
        f"| median worst pole error | {pct(median([r['worst'] for r in rows]))} |",
        f"| median seconds | {median([r['seconds'] for r in rows]):.1f} |",
    ]


def convergence_slope(cases: list[Case], center: bool) -> tuple[list[tuple[float, float]], float]:
    points = [(T, median([c["worst"] for c in cases if c["period"] == T and c["center"] == center]))
              for T in PERIODS]
    slope = float(np.polyfit(np.log([T for T, _ in points]), np.log([e for _, e in points]), 1)[0])
    return points, slope


def markdown(report: dict[str, Any]) -> str:
    out = ["# Continuous-time identification benchmark", "",
           f"Command: `{report['command']}`; {report['seeds']} seeds; total {report['seconds']:.0f} s "
           f"wall on {report['jobs']} worker(s).", ""]
    if report["seed_cases"] and "discrete" in report["seed_cases"][0]:
        out += ["## 1. Fast sampling (1 ms, 20 s, 30 dB)", "",
                "Relative error of each true pole to the nearest estimated pole; median over seeds.", "",
                *fast_table(report["seed_cases"]), ""]
        failed = [(s["seed"], s["discrete"]["failed"]) for s in report["seed_cases"] if s["discrete"].get("failed")]
        out += [f"- discrete `to_continuous` failed on seed {k}: {msg}" for k, msg in failed] + ([""] if failed else [])
    if report["seed_cases"] and "irregular" in report["seed_cases"][0]:
        out += ["## 2. Irregular sampling (steps 0.5-1.5 ms, three gaps of 100 samples)", "",
                "Fresh-data fit on a new uniformly sampled noise-free record from rest.", "",
                *irregular_table(report["seed_cases"]), ""]
    if report["exactness"]:
        out += ["## 3. Exactness of the filtering", "",
                "| wc (rad/s) | zeta | samples | RK4 substeps | max relative difference |", "|---|---|---|---|---|"]
        out += [f"| {c['wc']:g} | {c['zeta']} | {c['samples']} | {c['substeps']} | {c['max_relative_difference']:.2e} |"
                for c in report["exactness"]]
        seeds = len({c["seed"] for c in report["convergence"]})
        (points, slope), (raw, raw_slope) = (convergence_slope(report["convergence"], c) for c in (True, False))
        out += ["", f"Noise-free, order 4, 20 s from rest, median over {seeds} seeds of the worst pole error "
                "(default centring, and `center=False`):", "",
                "| T (ms) | centred (default) | center=False |", "|---|---|---|"]
        out += [f"| {1e3 * T:g} | {e:.3e} | {r:.3e} |" for (T, e), (_, r) in zip(points, raw)]
        out += [f"| log-log slope | {slope:.2f} | {raw_slope:.2f} |", ""]
    if report["daisy"]:
        out += ["## 4. DaISy records (first 2/3 estimate, last 1/3 fresh)", "",
                "| record | N | p | m | Ts | discrete order | discrete fit | continuous order | continuous fit | "
                "discrete s | continuous s |", "|---|---|---|---|---|---|---|---|---|---|---|"]
        for c in report["daisy"]:
            cells = []
            for method in ("discrete", "continuous"):
                r = c[method]
                cells.append(("—", "failed") if r["failed"] else (str(r["order"]), f"{r['fit']:.2f}"))
            secs = [f"{c[m]['seconds']:.1f}" if not c[m]["failed"] else "—" for m in ("discrete", "continuous")]
            out.append(f"| {c['name']} | {c['N']} | {c['p']} | {c['m']} | {c['Ts']:g} | {cells[0][0]} | {cells[0][1]} | "
                       f"{cells[1][0]} | {cells[1][1]} | {secs[0]} | {secs[1]} |")
        out += [f"- {c['name']} {m}: {c[m]['failed']}" for c in report["daisy"] for m in ("discrete", "continuous")
                if c[m]["failed"]]
        out.append("")
    if report["order"]:
        columns = [*(f"z={z:g}" for z in ORDER_WIDTHS), *(f"z=1, {d:g} pt" for d in NEGLIGIBLE_LOSSES), "best VAF"]
        out += ["## 5. The order rule's width (seeds 100-109, true order 4)", "",
                "| record | " + " | ".join(columns) + " |", "|---|" + "---|" * len(columns)]
        for kind in ("uniform", "irregular"):
            rows = [c for c in report["order"] if c["kind"] == kind]
            out.append(f"| {kind} | " + " | ".join(f"{sum(c[k] == 4 for c in rows)} of {len(rows)}" for k in columns) + " |")
        out.append("")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--parts", default="1,2,3,4,5", help="comma-separated subset of 1,2,3,4,5")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("bench-results"))
    args = parser.parse_args()
    parts = {int(p) for p in args.parts.split(",")}
    tasks: list[tuple] = []
    if parts & {1, 2}:
        tasks += [("seed", seed, parts) for seed in range(args.seeds)]
    if 3 in parts:
        tasks += [("exact", wc) for wc in (10.0, 100.0)]
        tasks += [("convergence", T, seed, center) for T in PERIODS
                  for seed in range(min(CONVERGENCE_SEEDS, args.seeds)) for center in (True, False)]
    if 4 in parts:
        tasks += [("daisy", name) for name in daisy_names()]
    if 5 in parts:
        tasks += [("order", seed, kind) for seed in ORDER_SEEDS for kind in ("uniform", "irregular")]
    start = time.perf_counter()
    done = Parallel(n_jobs=args.jobs, backend="loky")(delayed(run_task)(task) for task in tasks)
    grouped: dict[str, list[Case]] = {kind: [] for kind in ("seed", "exact", "convergence", "daisy", "order")}
    for kind, case in done:
        grouped[kind].append(case)
    report = {"command": " ".join(["python", *sys.argv]), "seeds": args.seeds, "jobs": args.jobs,
              "parts": sorted(parts), "seconds": time.perf_counter() - start, "seed_cases": grouped["seed"],
              "exactness": grouped["exact"], "convergence": grouped["convergence"], "daisy": grouped["daisy"],
              "order": grouped["order"]}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "continuous.json").write_text(json.dumps(report, indent=1, default=str))
    (args.out / "continuous.md").write_text(markdown(report))
    print(markdown(report))


if __name__ == "__main__":
    main()
