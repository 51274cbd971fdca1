"""Twin rotor: identify the simulated rig with MOLI-ZOFT, then control it (CDC 2015, Sec. V-B).

Usage::

    python examples/twin_rotor.py [OUTDIR] [--seed SEED]

Writes to OUTDIR (default ``twin_rotor_figures/`` beside this script, wherever it is run
from):

- ``twin_rotor_identification.png``: measured vs simulated outputs over the 60 s
  record, like the paper's Fig. 7;
- ``twin_rotor_closed_loop.png``: set-point tracking on the nonlinear rig, LQ servo
  and PID baseline, like Fig. 8 (inputs stay within the +-2.5 V limits);
- ``twin_rotor_saturation.png``: an aggressive set-point sequence that holds the
  main rotor at its -2.5 V limit (a pitch set-point out of reach), then asks for
  large simultaneous moves; LQ servo with and without anti-windup, PID baseline.

and prints the path, the poles (Table I) and the step-response metrics of both
experiments. ``benchmarks/twin_rotor_docs.py`` turns the same results into the
figures and numbers of ``docs/twin_rotor.md``.
"""

from __future__ import annotations

import argparse
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import moli  # noqa: E402
from moli import control as mc  # noqa: E402
from moli.systems import RigLimitWarning, TwinRotor, identification_experiment  # noqa: E402

ESTIMATION = 150  # samples (15 s), as in the paper
# The paper's filter grid: zeta in {0.5, 0.625, 0.75}, wc in {0.8 ... 2.0} pi rad/s.
OMEGA = moli.method.tuning.barycenter.grid(np.array([0.8, 1.04, 1.28, 1.52, 1.76, 2.0]) * np.pi, [0.5, 0.625, 0.75])
NMAX = 8
# Bryson's rule: acceptable pitch/yaw errors 0.15/0.3 rad, integrated errors twice
# that (rad s), input moves 1.5 V (the smaller headroom of the main rotor is
# 2.5 - 0.57 = 1.93 V). Tuned in simulation: settling in about 5 s without saturating.
Y_MAX = (0.15, 0.3)
INTEGRAL_MAX = (0.3, 0.6)
U_MAX = (1.5, 1.5)
U_LIMITS = (-2.5, 2.5)  # the rig's rotor voltages, V
# Set-point changes, one channel at a time so the coupling into the other shows;
# ranges as in the paper's Fig. 8 (pitch 0.15-0.35 rad, yaw up to 0.5-0.8 rad).
SETPOINT_STEPS = [(50, 0, 0.32), (250, 1, 0.5), (450, 0, 0.15), (650, 1, 0.2)]
SETPOINT_SAMPLES = 850
# Observer poles at 6 rad/s: at the paper's 12-16 rad/s the observer turns the
# encoder's quantisation steps into +-0.3 V of input chatter; at 6 rad/s the chatter
# drops sevenfold and settling and coupling stay the same (checked in simulation).
OBSERVER_BANDWIDTH = 6.0
STEP_WINDOWS = [(0, 50, 250), (1, 250, 450), (0, 450, 650), (1, 650, 850)]
# Aggressive sequence. At 5 s the pitch set-point drops below the lowest pitch the
# main rotor can hold (-0.495 rad at -2.5 V, reversed thrust against gravity), so
# the main rotor stays saturated while the yaw must still follow its own step; at
# 35 s both set-points swing across most of the rig's angle envelope at once.
SATURATION_STEPS = [(50, 0, -0.7), (50, 1, 0.5), (350, 0, 0.8), (350, 1, -1.5)]
SATURATION_SAMPLES = 600
SATURATION_WINDOWS = [(0, 50, 350), (1, 50, 350), (0, 350, 600), (1, 350, 600)]


@dataclass
class Recorder:
    """Runs an LQ servo and keeps its integrator state after every sample."""

    servo: mc.ServoController
    trace: list[np.ndarray] = field(default_factory=list, init=False)

    def reset(self) -> None:
        self.servo.reset()
        self.trace = []

    def update(self, y: np.ndarray, r: np.ndarray) -> np.ndarray:
        u = self.servo.update(y, r)
        self.trace.append(self.servo.integrator)
        return u


@dataclass
class Study:
    """Everything the example computes: data, model, controllers and closed-loop runs.

    ``runs`` holds the set-point experiment, ``saturation`` the aggressive one (keys
    ``"LQ"``, ``"LQ without anti-windup"``, ``"PID"``), ``integrators`` the LQ servos'
    integrator states during it and ``left_envelope`` whether each run left the
    rig's angle envelope.
    """

    rig: TwinRotor
    data: moli.IOData
    result: moli.IdentificationResult
    lq: mc.ServoController
    pid: mc.DecentralizedPID
    runs: dict[str, mc.ClosedLoopRun]
    saturation: dict[str, mc.ClosedLoopRun]
    integrators: dict[str, np.ndarray]
    left_envelope: dict[str, bool]

    @property
    def model(self) -> moli.StateSpaceModel:
        return self.result.model


def identify_rig(rig: TwinRotor, seed: int) -> tuple[moli.IOData, moli.IdentificationResult]:
    """Run the 60 s experiment and identify on its first 15 s (validation: whole record)."""
    data = identification_experiment(rig, seed=seed)
    # strictly proper model (feedthrough=False): the servo design needs D = 0
    result = moli.identify(
        data[:ESTIMATION], validation=data, omega=OMEGA, nmax=NMAX, seed=seed, center=False,
        feedthrough=False,
    )
    return data, result


def unseen_vaf(model: moli.StateSpaceModel, data: moli.IOData) -> np.ndarray:
    """VAF (%) per output on the samples after the estimation window, simulated from rest."""
    yhat = model.simulate(data.u)
    return moli.vaf(data.y[ESTIMATION:], yhat[ESTIMATION:])


def design(model: moli.StateSpaceModel, u_limits: object = U_LIMITS) -> mc.ServoController:
    """LQ servo with Bryson weights and observer poles at ``OBSERVER_BANDWIDTH``."""
    Q, R = mc.servo_weights(model, Y_MAX, INTEGRAL_MAX, U_MAX)
    return mc.lq_servo(model, Q, R, observer_bandwidth=OBSERVER_BANDWIDTH, u_limits=u_limits)


def run_study(seed: int = 0) -> Study:
    """Identify the rig, design both controllers and run both closed-loop experiments."""
    rig = TwinRotor()
    data, result = identify_rig(rig, seed)
    lq = design(result.model)
    pid = mc.pid_baseline(result.model, u_limits=U_LIMITS)
    r = mc.setpoint_steps(SETPOINT_SAMPLES, rig.y_trim, SETPOINT_STEPS)
    runs = {"LQ": mc.closed_loop(rig, lq, r, seed=seed), "PID": mc.closed_loop(rig, pid, r, seed=seed)}
    # Without anti-windup: the same gains, and a controller that never sees the rig's limits.
    recorders = {"LQ": Recorder(lq), "LQ without anti-windup": Recorder(design(result.model, (-np.inf, np.inf)))}
    r = mc.setpoint_steps(SATURATION_SAMPLES, rig.y_trim, SATURATION_STEPS)
    saturation, left = {}, {}
    for name, controller in {**recorders, "PID": pid}.items():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RigLimitWarning)
            saturation[name] = mc.closed_loop(rig, controller, r, seed=seed)
        left[name] = any(issubclass(w.category, RigLimitWarning) for w in caught)
    integrators = {name: np.array(rec.trace) for name, rec in recorders.items()}
    return Study(rig, data, result, lq, pid, runs, saturation, integrators, left)


def step_label(run: mc.ClosedLoopRun, channel: int, start: int, names: tuple[str, ...]) -> str:
    """``"pitch 0.2 -> -0.7 at 5 s"``: the channel, its set-point before and after, the time."""
    before, after = run.r[start - 1, channel], run.r[start, channel]
    return f"{names[channel]} {before:g} -> {after:g} at {run.t[start]:g} s"


def plot_identification(data: moli.IOData, model: moli.StateSpaceModel, path: Path) -> None:
    t = data.time()
    yhat = model.simulate(data.u) + data.y_offset
    y = data.y + data.y_offset
    fig, axes = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for i, ax in enumerate(axes):
        ax.plot(t, y[:, i], color="0.3", lw=1.2, label="measured (simulated rig)")
        ax.plot(t, yhat[:, i], "--", color="C1", lw=1.2, label=f"model {list(model.indices)}")
        ax.axvspan(0, ESTIMATION * data.Ts, color="C0", alpha=0.08, label="estimation data")
        ax.set_ylabel(f"{data.output_names[i]} (rad)")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8, ncol=3)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle("Twin rotor: measured and simulated outputs (model from the first 15 s)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


STYLES = {"LQ": dict(color="C0", lw=1.2), "LQ without anti-windup": dict(color="C2", lw=1.0, ls="--"),
          "PID": dict(color="C3", lw=1.0, alpha=0.8)}
LABELS = {"LQ": "LQ servo + observer", "LQ without anti-windup": "LQ servo without anti-windup",
          "PID": "two PID loops"}


def plot_runs(runs: dict[str, mc.ClosedLoopRun], title: str, path: Path,
              integrators: dict[str, np.ndarray] | None = None) -> None:
    """Outputs against set-points, inputs (and integrator states when given) of each run."""
    rows = 3 if integrators is None else 4
    fig, axes = plt.subplots(rows, 1, figsize=(8, 2.2 * rows + 0.5), sharex=True)
    first = next(iter(runs.values()))
    for i, name in enumerate(("pitch (rad)", "yaw (rad)")):
        ax = axes[i]
        ax.plot(first.t, first.r[:, i], color="k", lw=0.8, label="set-point")
        for key, run in runs.items():
            ax.plot(run.t, run.y[:, i], **STYLES[key], label=LABELS[key])
        ax.set_ylabel(name)
    axes[0].legend(loc="upper right", fontsize=8, ncol=2)
    for key, run in runs.items():
        for j, style in enumerate(("-", ":")):
            axes[2].plot(run.t, run.u[:, j], **{**STYLES[key], "ls": style}, label=f"{key} u{j + 1}")
    for bound in U_LIMITS:
        axes[2].axhline(bound, color="k", lw=0.6, ls="--")
    axes[2].set_ylim(U_LIMITS[0] - 0.5, U_LIMITS[1] + 0.5)
    axes[2].set_ylabel("input (V)")
    axes[2].legend(loc="best", fontsize=7, ncol=3)  # clear of the curves in both experiments
    if integrators is not None:
        for key, xi in integrators.items():
            for j, style in enumerate(("-", ":")):
                axes[3].plot(first.t, xi[:, j], **{**STYLES[key], "ls": style}, label=f"{key}, {('pitch', 'yaw')[j]}")
        axes[3].set_ylabel("integrator (rad s)")
        axes[3].legend(loc="upper right", fontsize=7, ncol=2)
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_figures(study: Study, outdir: Path) -> None:
    """The three figures of the example, into ``outdir``."""
    outdir.mkdir(parents=True, exist_ok=True)
    plot_identification(study.data, study.model, outdir / "twin_rotor_identification.png")
    plot_runs(study.runs, "Twin rotor (nonlinear simulation) in closed loop: set-point changes",
              outdir / "twin_rotor_closed_loop.png")
    plot_runs(study.saturation, "Twin rotor: aggressive set-points, main rotor at its -2.5 V limit",
              outdir / "twin_rotor_saturation.png", study.integrators)


def print_steps(runs: dict[str, mc.ClosedLoopRun], windows: list[tuple[int, int, int]], names: tuple[str, ...]) -> None:
    print(f"{'':20s} {'step':>24s} {'IAE rad s':>9s} {'settling s':>10s} {'overshoot %':>11s} "
          f"{'ss error rad':>12s} {'coupling %':>10s} {'saturated s':>12s}")
    for name, run in runs.items():
        for channel, start, stop in windows:
            m = mc.step_metrics(run, channel, start, stop)
            sat = mc.time_saturated(run, U_LIMITS, start, stop)
            print(f"{name:20s} {step_label(run, channel, start, names):>24s} {m.iae:9.3f} {m.settling_time:10.1f} "
                  f"{m.overshoot:11.1f} {m.steady_state_error:12.1e} {m.coupling:10.1f} {sat[0]:6.1f}{sat[1]:6.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("outdir", nargs="?", type=Path, default=Path(__file__).resolve().parent / "twin_rotor_figures",
                        help="directory for the PNG files [default: %(default)s]")
    parser.add_argument("--seed", type=int, default=0, help="seed of excitation, noise and filter search")
    args = parser.parse_args()
    study = run_study(args.seed)
    model, names = study.model, study.rig.output_names
    print(study.result.summary())
    vaf = unseen_vaf(model, study.data)
    print(f"selected {list(model.indices)}: VAF on samples {ESTIMATION}-{study.data.N - 1} "
          f"(never used for estimation): pitch {vaf[0]:.1f} %, yaw {vaf[1]:.1f} %")
    print("poles in continuous time (rad/s), as in the paper's Table I:")
    for name, poles in study.lq.pole_table().items():
        print(f"  {name:12s}", np.array2string(poles, precision=3, max_line_width=200))
    print("PID gains:", *(f"({g.kp:.3f}, {g.ki:.3f}, {g.kd:.3f})" for g in study.pid.gains))
    print("set-point steps (saturated: seconds at the +-2.5 V limits, main and tail):")
    print_steps(study.runs, STEP_WINDOWS, names)
    print("aggressive sequence:")
    print_steps(study.saturation, SATURATION_WINDOWS, names)
    for name, left in study.left_envelope.items():
        print(f"{name} left the rig's angle envelope: {'yes' if left else 'no'}")
    write_figures(study, args.outdir)
    print(f"figures written to {args.outdir}/")


if __name__ == "__main__":
    main()
