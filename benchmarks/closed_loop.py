"""Closed-loop identification against open-loop identification of the same plant.

Part A, a known linear truth: ``moli.systems.pi_loop_plant`` (2x2, first-order channels,
poles 0.9 and 0.85, coupled) under the two PI loops of ``moli.systems.pi_loop_gains``
tracking random set-point steps (each reference a level uniform in [-1, 1] held 30-150
samples, independent per channel), 3000 samples, output noise of sd 0.1 (SNR 15-17 dB,
measured and printed), white or AR(1) with pole 0.9. The closed-loop record has inputs
u1, u2 and the references r1, r2. The open-loop record of the same seed applies, open
loop, the plant input of the noise-free closed loop with the same references, with noise
of its own seed. Methods (``--methods``):

- ``open``: default ``moli.identify`` on the open-loop record (the baseline);
- ``closed_default``: default ``identify`` on the closed-loop record, plant inputs only (the
  direct method where the feedback check finds a controller's output, docs/closed_loop.md);
- ``closed_open``: the same with ``closed_loop="open"``, as if the loop were open;
- ``two_stage``: ``identify(closed, reference=("r1", "r2"))``;
- ``direct``: ``identify(closed_inputs, closed_loop="direct")``.

Scores per record: relative static-gain error ``|G_hat(1) - G(1)|_F / |G(1)|_F``, the
order, the share of (frequency, channel) points where the 95 % magnitude band holds the
true gain (static gain and 14 frequencies up to Nyquist), the time per fit; per seed, the
verdicts of ``moli.feedback_check`` on the estimation part of both records.

Part B, the twin rotor (``moli.systems.TwinRotor`` with encoder and 1e-3 rad noise): per
seed, the LQ servo and the PID baseline of ``examples/twin_rotor.py`` are designed on the
model of another seed's open-loop experiment, then track random set-point steps around
the trim (pitch +-0.15 rad, yaw +-0.45 rad, held 0.5-2 s; ``--rotor-hold``) for 60 s, the length of the
open-loop ``identification_experiment``. Each closed-loop record is identified by the
methods above (the example's filter grid and order bound, center=False, the last 30 %
held out), as is the open-loop experiment of the same seed; every model is scored with
``moli.compare`` (simulation from rest) on a third seed's open-loop experiment.

    OPENBLAS_NUM_THREADS=1 python benchmarks/closed_loop.py [--seeds 50] [--rotor-seeds 10] [--first-seed 0]
        [--methods open,closed_default,closed_open,two_stage,direct] [--jobs 2] [--out DIR] [--skip-a] [--skip-b]

Prints markdown tables; with ``--out DIR`` writes ``DIR/closed_loop.json`` with a row per
seed, part, noise or controller, and method. With the defaults and ``--jobs 2`` on two
cores it takes about 5 minutes: part A 200 s (about 50 s per method, 0.7 s per fit),
part B 80 s.
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import closed_loop_cases as cases  # noqa: E402


def fits(rows: list[dict], **match: object) -> list[dict]:
    """The rows whose fields equal ``match``."""
    return [row for row in rows if all(row.get(key) == value for key, value in match.items())]


def order_span(orders: list[int]) -> str:
    """``"median [min-max]"`` of the selected orders."""
    return f"{np.median(orders):g} [{min(orders)}-{max(orders)}]"


def pi_table(rows: list[dict], methods: list[str]) -> list[str]:
    """Part A: per noise type and method, the gain error against the open-loop baseline,
    the coverage, the order and the time."""
    lines = ["| noise | method | fits (failed) | median gain error | worst | median / open "
             "| coverage | coverage, static gain | order: median [range] | unstable | s per fit | info method |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for noise in cases.NOISES:
        done = [r for r in fits(rows, noise=noise, method="open") if not r["error"]]
        baseline = np.median([r["static_gain_error"] for r in done]) if done else np.nan
        for method in methods:
            found = fits(rows, noise=noise, method=method)
            ok = [r for r in found if not r["error"]]
            failed = len(found) - len(ok)
            if not ok:
                reason = found[0]["error"][:60] if found else ""
                lines.append(f"| {noise} | {method} | 0 ({failed}) | | | | | | | | | {reason} |")
                continue
            errors = np.array([r["static_gain_error"] for r in ok])
            orders = [r["order"] for r in ok]
            cover = [r["coverage"] for r in ok if r["coverage"] is not None]
            static = [r["coverage_static"] for r in ok if r["coverage_static"] is not None]
            infos = sorted({str(r["method_info"]) for r in ok})
            lines.append(
                f"| {noise} | {method} | {len(ok)} ({failed}) | {np.median(errors):.4f} | {errors.max():.4f} | "
                f"{np.median(errors) / baseline:.2f} | {np.mean(cover) if cover else np.nan:.3f} | "
                f"{np.mean(static) if static else np.nan:.3f} | {order_span(orders)} | "
                f"{sum(not r['stable'] for r in ok)} | "
                f"{np.median([r['seconds'] for r in ok]):.2f} | {', '.join(infos)} |")
    return lines


def detection_table(rows: list[dict]) -> list[str]:
    """Part A: the feedback check's verdicts on each seed's closed-loop and open-loop records."""
    lines = ["| noise | records | closed loop: detected | reproduced exactly | open loop: detected "
             "| reproduced exactly | cannot tell |", "|---|---|---|---|---|---|---|"]
    for noise in cases.NOISES:
        found = fits(rows, noise=noise, method="open")
        if not found:
            continue
        share = {key: np.mean([r[key] for r in found]) for key in found[0] if key.endswith(("_detected", "_exact", "_undecided"))}
        lines.append(f"| {noise} | {len(found)} | {share['closed_detected']:.3f} | {share['closed_exact']:.3f} | "
                     f"{share['open_detected']:.3f} | {share['open_exact']:.3f} | {share['open_undecided']:.3f} |")
    return lines


def rotor_tables(rows: list[dict], methods: list[str]) -> list[str]:
    """Part B: per seed the open-loop model's validation VAF and each closed-loop model's
    difference to it; then the medians and the loops' behaviour."""
    closed = [(c, m) for c in ("LQ", "PID") for m in methods if m != "open"]
    seeds = sorted({r["seed"] for r in rows})

    def score(seed: int, controller: str | None, method: str) -> dict | None:
        found = [r for r in fits(rows, seed=seed, controller=controller, method=method) if not r["error"]]
        return found[0] if found else None

    lines = ["VAF (%) on the fresh open-loop experiment: the open-loop model's, and each closed-loop "
             "model's minus it (points)", "",
             "| seed | open | " + " | ".join(f"{c} {m}" for c, m in closed) + " |",
             "|---" * (2 + len(closed)) + "|"]
    diffs: dict[tuple[str, str], list[tuple[float, float]]] = {key: [] for key in closed}
    opens = []
    for seed in seeds:
        base = score(seed, None, "open")
        cells = []
        for key in closed:
            found = score(seed, *key)
            if found is None or base is None:
                cells.append("failed" if base is not None else "")
                continue
            diffs[key].append((found["vaf"] - base["vaf"], found["fit"] - base["fit"]))
            cells.append(f"{diffs[key][-1][0]:+.2f}")
        opens.append(base)
        lines.append(f"| {seed} | {base['vaf']:.2f} | " if base else f"| {seed} | failed | ")
        lines[-1] += " | ".join(cells) + " |"
    lines += ["", "| controller | method | fits | median VAF - open | worst | median fit - open | within 2 VAF points "
              "| order: median [range] | left envelope | s saturated (median, u1 u2) | s per fit |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    ok_open = [b for b in opens if b]
    if ok_open:
        orders = [b["order"] for b in ok_open]
        lines.append(f"| none | open | {len(ok_open)} | open VAF {np.median([b['vaf'] for b in ok_open]):.2f} | | "
                     f"open fit {np.median([b['fit'] for b in ok_open]):.2f} | | {order_span(orders)} | | | "
                     f"{np.median([b['seconds'] for b in ok_open]):.2f} |")
    for (controller, method), values in diffs.items():
        found = [r for r in fits(rows, controller=controller, method=method) if not r["error"]]
        if not values:
            lines.append(f"| {controller} | {method} | 0 | | | | | | | | |")
            continue
        vaf, fit = np.array(values).T
        orders = [r["order"] for r in found]
        saturated = np.median([r["saturated_s"] for r in found], axis=0)
        lines.append(
            f"| {controller} | {method} | {len(values)} | {np.median(vaf):+.2f} | {vaf.min():+.2f} | "
            f"{np.median(fit):+.2f} | {np.sum(vaf >= -2)}/{len(vaf)} | {order_span(orders)} | "
            f"{sum(r['left_envelope'] for r in found)} | "
            f"{saturated[0]:.1f} {saturated[1]:.1f} | {np.median([r['seconds'] for r in found]):.2f} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=50, help="records per noise type in part A")
    parser.add_argument("--rotor-seeds", type=int, default=10, help="seeds of part B")
    parser.add_argument("--first-seed", type=int, default=0,
                        help="seeds run from here on (records a choice was not made on)")
    parser.add_argument("--methods", default=",".join(cases.METHODS),
                        help="comma-separated, of " + ", ".join(cases.METHODS))
    parser.add_argument("--jobs", type=int, default=2, help="parallel workers")
    parser.add_argument("--out", type=Path, help="directory for closed_loop.json")
    parser.add_argument("--skip-a", action="store_true", help="no part A (the PI-loop plant)")
    parser.add_argument("--skip-b", action="store_true", help="no part B (the twin rotor)")
    parser.add_argument("--rotor-hold", default=",".join(map(str, cases.ROTOR_HOLD)),
                        help="part B: shortest and longest hold of a set-point, samples of 0.1 s")
    args = parser.parse_args()
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = sorted(set(methods) - set(cases.METHODS))
    if unknown or "open" not in methods:
        parser.error(f"--methods: unknown {unknown}" if unknown else "--methods needs open (the baseline)")
    from joblib import Parallel, delayed

    rows: list[dict] = []
    seconds = {}
    if not args.skip_a:
        started = time.perf_counter()
        for found in Parallel(n_jobs=args.jobs)(delayed(cases.quiet(cases.pi_seed))(seed, noise, methods)
                                                for noise in cases.NOISES for seed in range(args.first_seed, args.first_seed + args.seeds)):
            rows += found
        seconds["A"] = time.perf_counter() - started
        snr = np.array([r["snr_db"] for r in fits(rows, part="A", method="open")])
        print(f"## Part A: 2x2 PI loops, {cases.N} samples, {args.seeds} seeds per noise, "
              f"SNR median {np.median(snr, axis=0).round(1).tolist()} dB (outputs), {seconds['A']:.0f} s\n")
        for line in pi_table(fits(rows, part="A"), methods):
            print(line)
        print("\nThe feedback check on the estimation part (first 70 %) of each record:\n")
        for line in detection_table(fits(rows, part="A")):
            print(line)
        print(flush=True)
    if not args.skip_b:
        hold = tuple(int(value) for value in args.rotor_hold.split(","))
        started = time.perf_counter()
        for found in Parallel(n_jobs=args.jobs)(delayed(cases.quiet(cases.rotor_seed))(seed, methods, hold)
                                                for seed in range(args.first_seed, args.first_seed + args.rotor_seeds)):
            rows += found
        seconds["B"] = time.perf_counter() - started
        print(f"## Part B: twin rotor, {args.rotor_seeds} seeds, set-points held {hold[0]}-{hold[1]} samples, "
              f"{seconds['B']:.0f} s\n")
        for line in rotor_tables(fits(rows, part="B"), methods):
            print(line)
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        config = {"first_seed": args.first_seed, "seeds": args.seeds, "rotor_seeds": args.rotor_seeds, "methods": methods, "N": cases.N,
                  "noise_sd": cases.NOISE_SD, "noises": cases.NOISES, "omega": cases.OMEGA.tolist(),
                  "seconds": seconds, "rotor_hold": args.rotor_hold}
        (args.out / "closed_loop.json").write_text(json.dumps({"config": config, "rows": rows}, indent=1))
        print(f"\nrows written to {args.out / 'closed_loop.json'}")


if __name__ == "__main__":
    main()
