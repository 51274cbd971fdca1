"""Records, fits and scores of benchmarks/closed_loop.py (its module docstring says what they measure)."""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path
from typing import Callable

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent / "examples")]

import single_thread  # noqa: F401,E402  (before numpy: one BLAS thread)

import numpy as np  # noqa: E402

import moli  # noqa: E402
import twin_rotor as example  # noqa: E402  (the example's LQ design and identification settings)
import twin_rotor_seeds as rotor_seeds  # noqa: E402  (the rig with encoder and noise)
from generalization_cases import NOISE_POLE  # noqa: E402  (coloured noise as the other benchmarks')
from moli import control as mc  # noqa: E402
from moli.systems import (  # noqa: E402
    LinearPlant, RigLimitWarning, experiment, identification_experiment, pi_loop_gains, pi_loop_plant,
)
from uncertainty_coverage import gain  # noqa: E402  (true and identified |G| on a grid)

N = 3000
# Output noise of sd 0.1 against closed-loop outputs of sd 0.55-0.7 (references uniform in
# [-1, 1]): an SNR of 15-17 dB, which the report measures per record.
NOISE_SD = 0.1
NOISES = {"white": 0.0, "coloured": NOISE_POLE}
HOLD = (30, 150)   # samples each reference level is held
LEVEL = 1.0        # references uniform in [-LEVEL, LEVEL]
# Gain bands are scored from the static gain to the Nyquist frequency, denser where the
# loops (bandwidth about 0.2 rad/sample) and the set-point steps put the information.
OMEGA = np.concatenate([[0.0], np.geomspace(0.005, np.pi, 14)])
METHODS = {
    "open": "open-loop record, default identify",
    "closed_default": "closed-loop record, u only, default identify",
    "closed_open": "closed-loop record, u only, closed_loop=\"open\" (as if open loop)",
    "two_stage": "closed-loop record, reference=(\"r1\", \"r2\")",
    "direct": "closed-loop record, u only, closed_loop=\"direct\"",
}
REFERENCES = ("r1", "r2")
# Seeds of the noise realisations, apart from the references' seed
CLOSED_NOISE, OPEN_NOISE = 100_000, 200_000


def references(count: int, channels: int, hold: tuple[int, int], centre: object, level: object,
               rng: np.random.Generator) -> np.ndarray:
    """Piecewise-constant set-points: per channel, levels uniform in ``centre +- level`` held
    ``hold[0]``..``hold[1]`` samples, independent across channels."""
    r = np.empty((count, channels))
    centre, level = np.broadcast_to(centre, channels), np.broadcast_to(level, channels)
    for j in range(channels):
        k = 0
        while k < count:
            length = int(rng.integers(hold[0], hold[1] + 1))
            r[k:k + length, j] = centre[j] + rng.uniform(-level[j], level[j])
            k += length
    return r


def pi_loops() -> mc.DecentralizedPID:
    """The benchmark plant's two PI loops (moli.systems.pi_loop_gains), unbounded inputs."""
    gains = [mc.PIDGains(kp, ki, 0.0) for kp, ki in pi_loop_gains()]
    return mc.DecentralizedPID(gains, [(0, 0), (1, 1)], Ts=1.0, u0=np.zeros(2), u_limits=(-np.inf, np.inf))


def with_references(run: mc.ClosedLoopRun, Ts: float, output_names, input_names) -> moli.IOData:
    """A closed-loop run as a record whose inputs are the plant inputs, then the set-points."""
    return moli.IOData(run.y, np.hstack([run.u, run.r]), Ts, output_names,
                       tuple(input_names) + REFERENCES[:run.r.shape[1]])


def plant_inputs(record: moli.IOData) -> moli.IOData:
    """A raw record without its reference channels (what a method that ignores them sees)."""
    m = record.m - len(REFERENCES)
    return moli.IOData(record.y, record.u[:, :m], record.Ts, record.output_names, record.input_names[:m])


def pi_records(seed: int, noise: str) -> tuple[moli.IOData, moli.IOData, np.ndarray]:
    """Closed-loop record (u1, u2, r1, r2), open-loop record (u1, u2) and the outputs' SNR in dB.

    The open-loop record's input is the plant input of the noise-free closed loop with the
    same references, so both records have comparable excitation; its noise has its own seed.
    """
    truth = pi_loop_plant()
    r = references(N, 2, HOLD, 0.0, LEVEL, np.random.default_rng(seed))
    noisy = LinearPlant(truth, NOISE_SD, NOISES[noise])
    closed = with_references(mc.closed_loop(noisy, pi_loops(), r, seed=CLOSED_NOISE + seed),
                             truth.Ts, truth.output_names, truth.input_names)
    clean = mc.closed_loop(LinearPlant(truth, 0.0), pi_loops(), r)
    opened = experiment(noisy, clean.u, seed=OPEN_NOISE + seed)
    return closed, opened, 20 * np.log10(clean.y.std(axis=0) / NOISE_SD)


def fit(method: str, opened: moli.IOData, closed: moli.IOData, closed_inputs: moli.IOData,
        **options: object) -> tuple[moli.StateSpaceModel | None, float, str]:
    """The model of ``method`` (key of METHODS) from the open-loop record, the closed-loop
    one with references or ``closed_inputs`` (its plant inputs only); the fit time; the error
    text if it failed."""
    started = time.perf_counter()
    try:
        if method == "open":
            result = moli.identify(opened, **options)
        elif method == "closed_default":
            result = moli.identify(closed_inputs, **options)
        elif method == "closed_open":
            result = moli.identify(closed_inputs, closed_loop="open", **options)
        elif method == "two_stage":
            result = moli.identify(closed, reference=REFERENCES, **options)
        else:
            result = moli.identify(closed_inputs, closed_loop="direct", **options)
    except moli.MoliError as exc:
        return None, time.perf_counter() - started, f"{type(exc).__name__}: {exc}"
    return result.model, time.perf_counter() - started, ""


def method_info(model: moli.StateSpaceModel) -> str | None:
    """What the model says of its closed-loop method (None: an open-loop fit)."""
    found = model.info.get("closed_loop")
    return found.get("method") if isinstance(found, dict) else None


def gain_scores(model: moli.StateSpaceModel, truth: moli.StateSpaceModel) -> dict[str, object]:
    """Relative static-gain error, order, and 95 % band coverage of the true gain on OMEGA."""
    true_static = truth.frequency_response([0.0])[0].real
    static = model.frequency_response([0.0])[0].real
    row: dict[str, object] = {
        "static_gain_error": float(np.linalg.norm(static - true_static) / np.linalg.norm(true_static)),
        "order": int(model.n), "stable": bool(model.is_stable()), "method_info": method_info(model),
    }
    if model.cov_factor is None:
        return {**row, "coverage": None, "coverage_static": None}
    lower, upper = model.magnitude_bands(OMEGA, confidence=0.95)
    true_gain = gain(truth, OMEGA)
    held = (lower <= true_gain) & (true_gain <= upper)
    return {**row, "coverage": float(np.mean(held)), "coverage_static": float(np.mean(held[0]))}


def quiet(task: Callable[..., list[dict[str, object]]]) -> Callable[..., list[dict[str, object]]]:
    """``task`` with its warnings silenced: a worker process does not inherit the parent's filters,
    and the closed-loop and order-rule warnings each fit raises are the benchmark's subject, not news."""
    def run(*args: object) -> list[dict[str, object]]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return task(*args)
    return run


def verdict(record: moli.IOData, prefix: str) -> dict[str, bool]:
    """``moli.feedback_check`` of the estimation part identify holds for itself (the first 70 %):
    flagged, reproduced exactly (a controller's output), cannot tell."""
    check = moli.feedback_check(record.split(0.7)[0])
    return {f"{prefix}_detected": check.detected, f"{prefix}_exact": bool(check.exact),
            f"{prefix}_undecided": bool(check.undecided)}


def pi_seed(seed: int, noise: str, methods: list[str]) -> list[dict[str, object]]:
    """Part A, one seed and noise type: a row per method, each with the feedback check's
    verdicts on the closed-loop record (plant inputs only) and the open-loop one."""
    closed, opened, snr = pi_records(seed, noise)
    checks = verdict(plant_inputs(closed), "closed") | verdict(opened, "open")
    rows = []
    for method in methods:
        model, seconds, error = fit(method, opened, closed, plant_inputs(closed))
        row = {"part": "A", "noise": noise, "seed": seed, "method": method, "seconds": seconds,
               "snr_db": snr.tolist(), "error": error, **checks}
        rows.append(row if model is None else {**row, **gain_scores(model, pi_loop_plant())})
    return rows


# -- part B: the twin rotor ---------------------------------------------------------------

DESIGN_SEED, VALIDATION_SEED = 1000, 2000
ROTOR_METHODS = ("open", "closed_default", "closed_open", "two_stage", "direct")
# Set-points around the trim: pitch +-0.15 rad, yaw +-0.45 rad (the open-loop experiment
# swings pitch and yaw by about 0.1 and 0.27 rad sd), inside the rig's envelope (pitch
# -0.5..1.0, yaw -1.7..1.2 rad) with room for overshoot, held 0.5-2 s: the closed loop
# settles in a few seconds, and steps held 4-12 s (the open-loop experiment's pace) left
# too little of its dynamics in 60 s (docs/closed_loop.md §6 gives both).
ROTOR_LEVEL = (0.15, 0.45)
ROTOR_HOLD = (5, 20)


def rotor_options(seed: int) -> dict[str, object]:
    """The identification settings of the twin rotor example, on the whole record
    (its last 30 % held out for the order rule)."""
    return {"omega": example.OMEGA, "nmax": example.NMAX, "seed": seed, "center": False, "feedthrough": False}


def rotor_seed(seed: int, methods: list[str], hold: tuple[int, int] = ROTOR_HOLD) -> list[dict[str, object]]:
    """Part B, one seed: controllers from another seed's model, a closed-loop record under
    each, every method's model scored on a third seed's open-loop experiment."""
    rig = rotor_seeds.make_rig("default")
    _, designed = example.identify_rig(rig, DESIGN_SEED + seed)
    controllers = {"LQ": example.design(designed.model),
                   "PID": mc.pid_baseline(designed.model, u_limits=example.U_LIMITS)}
    opened = identification_experiment(rig, seed=seed)
    fresh = identification_experiment(rig, seed=VALIDATION_SEED + seed)
    r = references(opened.N, 2, hold, rig.y_trim, ROTOR_LEVEL, np.random.default_rng(seed))
    rows = []
    for name, controller in controllers.items():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RigLimitWarning)
            run = mc.closed_loop(rig, controller, r, seed=seed)
        raw = with_references(run, rig.Ts, rig.output_names, rig.input_names)
        closed = raw.remove_means(rig.y_trim, np.concatenate([rig.u_trim, rig.y_trim]))
        closed_inputs = plant_inputs(raw).remove_means(rig.y_trim, rig.u_trim)
        loop = {"left_envelope": any(issubclass(w.category, RigLimitWarning) for w in caught),
                "saturated_s": mc.time_saturated(run, example.U_LIMITS).tolist()}
        for method in methods:
            if method == "open" and name != "LQ":
                continue  # one open-loop model per seed, whatever the controller
            model, seconds, error = fit(method, opened, closed, closed_inputs, **rotor_options(seed))
            row = {"part": "B", "seed": seed, "controller": None if method == "open" else name,
                   "method": method, "seconds": seconds, "error": error, **({} if method == "open" else loop)}
            if model is not None:
                scored = moli.compare(model, fresh)
                row |= {"vaf": scored.mean_vaf, "fit": float(np.mean(scored.fit)), "order": int(model.n),
                        "method_info": method_info(model)}
            rows.append(row)
    return rows
