"""moli against a vector-fitting peer and a frequency-domain subspace peer on the same FRFs (docs/frequency.md §8).

The systems and the noise are benchmarks/frequency.py's (``system``, ``lines``, ``noisy``):
per seed a continuous-time system of 2 inputs, 3 outputs and ``--modes`` lightly damped
modes (damping 0.5-5 %), its FRF on 2000 log-spaced lines, 1-3 % circular complex noise,
and, for the discrete variant, the zero-order-hold twin at Ts = 0.01. Every method fits the
same noisy FRF; the figures are, per true mode, the relative error of its natural frequency
and damping ratio (each true mode paired with a distinct fitted mode, nearest in the complex
plane; a true mode left without one counts as missed), the relative FRF error against the
noise-free truth on all lines, ``||G_model - G_true||_F / ||G_true||_F``, and the CPU time
of the fit alone (``time.process_time``, one BLAS thread).

Methods (the peers get the true number of states; moli chooses its order or is given it):

- ``moli``: ``moli.identify(data, nmax=2 modes + 2)`` (the default nmax at 4 modes), the
  data's variance given, as a user would call it; ``moli (order given)``: ``order=2 modes``;
  ``moli refine=selected``: the orders judged by their subspace fits, only the selected one
  refined (an option of moli's, docs/frequency.md §7).
- ``VF``: scikit-rf's ``VectorFitting.vector_fit`` (Gustavsen and Semlyen's vector fitting,
  relaxed, all responses on one pole set), ``modes`` complex pole pairs, no real pole,
  log-spaced starting poles (the lines are log-spaced), constant term fitted. A scikit-rf
  ``Network`` is square, so the 3 x 2 FRF is embedded as the first two columns of a 3 x 3
  one whose third column is zero: vector fitting weighs each response by its norm, so the
  zero responses take no part in placing the poles, and their residues come out zero. The
  frequencies go in as Hz (``omega / 2 pi``); its poles are in rad/s. Continuous time only
  (its model is a pole-residue sum in ``s``).
- ``VF auto``: ``VectorFitting.auto_fit`` with its defaults (vector fitting with adding and
  skimming of poles, Grivet-Talocia): the order is its own.
- ``FSID``: McKelvey's FSID toolbox (McKelvey, Akcay and Ljung 1996; the Python version
  1.3 by T. McKelvey, which the PyPI package ``freq-statespace`` ships as
  ``freq_statespace.dep.fsid``; FSID itself is not on PyPI), ``gfdsid`` on the FRF in its
  input/output form (each line and input a sample with a unit input vector, as
  ``freq-statespace`` calls it), each sample weighted by ``1 / sd`` of the data, ``q = nmax + 1``
  block rows as moli's start, real matrices, D estimated. Continuous data go through the
  toolbox's bilinear map (``T = 2 / omega_c``, ``omega_c`` the lines' geometric mean, the
  map moli uses) and back with its ``bilinear_d2c``; discrete data on ``z = exp(j omega Ts)``.
- ``FSID ffsid``: the toolbox's plain FRF routine ``ffsid`` (no weights, ``CT=True`` with the
  same ``T`` for continuous data).

    OPENBLAS_NUM_THREADS=1 python benchmarks/frequency_peers.py --seeds 20 [--modes 4] [--out peers.json]
    python benchmarks/frequency_peers.py --table peers.json more.json      # one table of several runs

Needs the ``bench`` extra (``pip install -e '.[bench]'``: scikit-rf, freq-statespace).
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import json  # noqa: E402
import logging  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import linear_sum_assignment  # noqa: E402

import moli  # noqa: E402
from frequency import lines, noisy, system  # noqa: E402

METHODS = ("moli", "moli (order given)", "moli refine=selected", "VF", "VF auto", "FSID", "FSID ffsid")


def response(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``C (x I - A)^-1 B + D`` at each point, shape (F, p, m)."""
    pencil = points[:, None, None] * np.eye(A.shape[0]) - A
    return C @ np.linalg.solve(pencil, np.broadcast_to(B, (points.size, *B.shape))) + D


def fit_moli(data: moli.FrequencyData, modes: int, given: bool, refine: str = "guarded") -> tuple[np.ndarray, callable]:
    options = {"order": 2 * modes} if given else {"nmax": 2 * modes + 2, "refine": refine}
    model = moli.identify(data, **options).model
    poles = model.poles() if data.Ts is None else np.log(model.poles().astype(complex)) / data.Ts
    return poles, lambda omega: model.frequency_response(omega)


def fit_vf(data: moli.FrequencyData, modes: int, auto: bool) -> tuple[np.ndarray, callable]:
    import skrf
    from skrf.vectorFitting import VectorFitting

    p, m = data.G.shape[1:]
    square = np.zeros((data.F, p, p), complex)        # the 3 x 2 FRF as two columns of a 3-port
    square[:, :, :m] = data.G
    network = skrf.Network(frequency=skrf.Frequency.from_f(data.omega / (2 * np.pi), unit="hz"), s=square)
    fit = VectorFitting(network)
    if auto:
        fit.auto_fit()
    else:
        fit.vector_fit(n_poles_real=0, n_poles_cmplx=modes, init_pole_spacing="log")
    poles = np.concatenate([fit.poles, np.conj(fit.poles[fit.poles.imag != 0])])

    def frf(omega: np.ndarray) -> np.ndarray:
        hz = omega / (2 * np.pi)
        return np.stack([np.stack([fit.get_model_response(i, j, hz) for j in range(m)], axis=-1)
                         for i in range(p)], axis=1)
    return poles, frf


def fit_fsid(data: moli.FrequencyData, modes: int, weighted: bool) -> tuple[np.ndarray, callable]:
    from freq_statespace.dep import fsid

    F, p, m = data.G.shape
    n, q = 2 * modes, 2 * modes + 3
    continuous = data.Ts is None
    T = 2 / np.exp(np.mean(np.log(data.omega))) if continuous else None
    if weighted:
        points = (1 + 1j * data.omega * T / 2) / (1 - 1j * data.omega * T / 2) if continuous \
            else np.exp(1j * data.omega * data.Ts)
        outputs = data.G.transpose(0, 2, 1).reshape(F * m, p)         # line k, input j: y = G[k, :, j]
        inputs = np.tile(np.eye(m), (F, 1))
        scale = 1 / np.sqrt(data.variance.transpose(0, 2, 1).reshape(F * m, p))
        weights = scale[:, :, None] * np.eye(p)
        A, B, C, D = fsid.gfdsid((np.repeat(points, m), outputs, inputs), n, q, estTrans=False, w=weights)[:4]
        if continuous:
            A, B, C, D = fsid.bilinear_d2c((A, B, C, D), T)
    elif continuous:
        A, B, C, D = fsid.ffsid(data.omega, data.G, n, q, CT=True, T=T)[:4]
    else:
        A, B, C, D = fsid.ffsid(data.omega * data.Ts, data.G, n, q)[:4]
    if continuous:
        return np.linalg.eigvals(A), lambda omega: response(A, B, C, D, 1j * omega)
    return np.log(np.linalg.eigvals(A).astype(complex)) / data.Ts, \
        lambda omega: response(A, B, C, D, np.exp(1j * omega * data.Ts))


def mode_errors(poles: np.ndarray, natural: np.ndarray, damping: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Relative natural-frequency and damping errors per true mode (inf where no fitted mode is left for it).

    ``poles`` are continuous-time; each true pole ``-zeta wn + j wn sqrt(1 - zeta^2)`` is paired
    with a distinct fitted pole of positive imaginary part, minimizing the summed relative distances.
    """
    truth = -damping * natural + 1j * natural * np.sqrt(1 - damping**2)
    fitted = poles[poles.imag > 0]
    frequency_error, damping_error = np.full(natural.size, np.inf), np.full(natural.size, np.inf)
    if fitted.size:
        rows, cols = linear_sum_assignment(np.abs(truth[:, None] - fitted[None, :]) / np.abs(truth)[:, None])
        wn = np.abs(fitted[cols])
        frequency_error[rows] = np.abs(wn / natural[rows] - 1)
        damping_error[rows] = np.abs((-fitted[cols].real / wn) / damping[rows] - 1)
    return frequency_error, damping_error


FITS = {"moli": lambda d, k: fit_moli(d, k, False), "moli (order given)": lambda d, k: fit_moli(d, k, True),
        "moli refine=selected": lambda d, k: fit_moli(d, k, False, "selected"),
        "VF": lambda d, k: fit_vf(d, k, False), "VF auto": lambda d, k: fit_vf(d, k, True),
        "FSID": lambda d, k: fit_fsid(d, k, True), "FSID ffsid": lambda d, k: fit_fsid(d, k, False)}


def one_seed(seed: int, modes: int, kinds: tuple[str, ...], methods: tuple[str, ...]) -> list[dict]:
    truth, natural, damping = system(seed, modes)
    rows = []
    for kind in kinds:
        Ts, omega = lines(kind)
        plant = truth if Ts is None else truth.to_discrete(Ts)
        G = plant.frequency_response(omega)
        data = noisy(G, omega, seed, Ts)
        for method in methods:
            if kind == "discrete" and method.startswith("VF"):
                continue                                   # vector fitting's model is continuous-time
            start = time.process_time()
            try:
                poles, frf = FITS[method](data, modes)
                failure = None
            except Exception as error:                     # a peer's failure is a figure, not the end of the run
                poles, frf, failure = np.zeros(0), None, f"{type(error).__name__}: {error}"
            cpu = time.process_time() - start
            frequency_error, damping_error = mode_errors(poles, natural, damping)
            fit_error = np.inf if frf is None else float(np.linalg.norm(frf(omega) - G) / np.linalg.norm(G))
            rows.append({"seed": seed, "kind": kind, "method": method, "states": int(poles.size), "cpu": cpu,
                         "frequency_errors": frequency_error.tolist(), "damping_errors": damping_error.tolist(),
                         "frf_error": fit_error, "failure": failure})
    return rows


def table(rows: list[dict], modes: int) -> str:
    lines_ = ["| method | time base | states: true / median (range) | missed modes | natural-frequency error: median, "
              "worst | damping error: median, worst | FRF error: median, worst | CPU s: median, max |",
              "|---|---|---|---|---|---|---|---|"]
    for kind in ("continuous", "discrete"):
        for method in METHODS:
            chosen = [r for r in rows if r["kind"] == kind and r["method"] == method]
            if not chosen:
                continue
            wn = np.concatenate([r["frequency_errors"] for r in chosen])
            zeta = np.concatenate([r["damping_errors"] for r in chosen])
            frf = np.array([r["frf_error"] for r in chosen])
            cpu = np.array([r["cpu"] for r in chosen])
            states = np.array([r["states"] for r in chosen])
            found = np.isfinite(wn)
            lines_.append(
                f"| {method} | {kind} | {2 * modes} / {np.median(states):.0f} ({states.min()}-{states.max()}) | "
                f"{np.sum(~found)} of {wn.size} | {np.median(wn):.1e}, {np.max(wn):.1e} | "
                f"{np.median(zeta):.1e}, {np.max(zeta):.1e} | {np.median(frf):.1e}, {np.max(frf):.1e} | "
                f"{np.median(cpu):.2f}, {np.max(cpu):.2f} |")
    return "\n".join(lines_)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=0, help="seeds first-seed .. first-seed + seeds - 1")
    parser.add_argument("--modes", type=int, default=4, help="modes per system (the issue's range is 4-8)")
    parser.add_argument("--continuous-only", action="store_true", help="leave out the discrete-time variant")
    parser.add_argument("--methods", default=",".join(METHODS), help="comma-separated subset of: " + ", ".join(METHODS))
    parser.add_argument("--out", help="write every seed's figures to this JSON file")
    parser.add_argument("--table", nargs="+", metavar="JSON", help="fit nothing: print the table of these --out files "
                        "(runs of other methods on the same seeds and modes)")
    args = parser.parse_args()
    if args.table:
        saved = [json.loads(Path(name).read_text()) for name in args.table]
        print(table([row for each in saved for row in each["rows"]], saved[0]["modes"]))
        return
    methods = tuple(args.methods.split(","))
    unknown = set(methods) - set(METHODS)
    if unknown:
        parser.error(f"--methods: unknown {sorted(unknown)}; choose among {', '.join(METHODS)}")
    logging.getLogger("skrf").setLevel(logging.ERROR)
    kinds = ("continuous",) if args.continuous_only else ("continuous", "discrete")
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                   # the peers' convergence chatter
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            rows += one_seed(seed, args.modes, kinds, methods)
            print(f"seed {seed} done", flush=True)
            if args.out:                                  # after every seed: a stopped run keeps its seeds
                with open(args.out, "w") as handle:
                    json.dump({"seeds": seed + 1 - args.first_seed, "modes": args.modes, "rows": rows}, handle,
                              indent=1)
    for row in rows:
        if row["failure"]:
            print(f"seed {row['seed']} {row['kind']} {row['method']} failed: {row['failure']}")
    print(f"\n{args.seeds} seeds, {args.modes} modes (2 inputs, 3 outputs, 2000 lines, 1-3 % noise)\n")
    print(table(rows, args.modes))


if __name__ == "__main__":
    main()
