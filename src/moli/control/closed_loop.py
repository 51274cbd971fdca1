"""Closed-loop runs of a controller on a sampled plant, and step-response metrics."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, Sequence

import numpy as np

from ..systems.experiment import SampledPlant
from ..errors import ControlDesignError
from .limits import input_bounds

__all__ = [
    "Controller", "setpoint_steps", "ClosedLoopRun", "closed_loop", "StepMetrics",
    "step_metrics",
]


class Controller(Protocol):
    """What :func:`closed_loop` needs: ``reset()`` and ``update(y, r) -> u`` (absolute)."""

    def reset(self) -> None: ...

    def update(self, y: np.ndarray, r: np.ndarray) -> np.ndarray: ...



def setpoint_steps(N: int, initial: object, steps: Sequence[tuple[int, int, float]]) -> np.ndarray:
    """Piecewise-constant set-points: ``initial``, then ``(sample, output, value)`` steps.

    Examples
    --------
    >>> setpoint_steps(4, [0.0, 1.0], [(2, 0, 0.5)])
    array([[0. , 1. ],
           [0. , 1. ],
           [0.5, 1. ],
           [0.5, 1. ]])
    """
    r = np.tile(np.asarray(initial, dtype=float), (int(N), 1))
    for k, channel, value in steps:
        if not (0 <= k < N and 0 <= channel < r.shape[1]):
            raise ControlDesignError(f"step ({k}, {channel}) is outside {N} samples x {r.shape[1]} outputs")
        r[k:, channel] = value
    return r



@dataclass(frozen=True)
class ClosedLoopRun:
    """Record of a closed-loop simulation: time (N,), outputs and set-points (N, p), inputs (N, m)."""

    t: np.ndarray
    y: np.ndarray
    u: np.ndarray
    r: np.ndarray



def closed_loop(
    plant: SampledPlant, controller: Controller, setpoints: object, seed: int | None = None
) -> ClosedLoopRun:
    """Run ``controller`` on ``plant`` tracking ``setpoints`` (absolute, shape (N, p)).

    At each sample the plant is measured, the controller computes the input from
    that measurement and the set-point, and the plant is advanced one period.

    Parameters
    ----------
    plant : SampledPlant
        E.g. :class:`moli.systems.TwinRotor`; started from its own initial state.
    controller : Controller
        :class:`ServoController` or :class:`DecentralizedPID`.
    setpoints : array_like, shape (N, p)
    seed : int, optional
        Measurement-noise seed passed to ``plant.reset``.

    Returns
    -------
    ClosedLoopRun
    """
    r = np.array(setpoints, dtype=float, ndmin=2)
    p = len(plant.output_names)
    if r.ndim != 2 or r.shape[1] != p or not np.all(np.isfinite(r)):
        raise ControlDesignError(f"setpoints must be finite with shape (N, {p}), got {np.shape(setpoints)}")
    plant.reset(seed=seed)
    controller.reset()
    y = np.empty_like(r)
    u = np.empty((r.shape[0], len(plant.input_names)))
    for k in range(r.shape[0]):
        y[k] = plant.measure()
        u[k] = controller.update(y[k], r[k])
        plant.step(u[k])
    return ClosedLoopRun(t=np.arange(r.shape[0]) * plant.Ts, y=y, u=u, r=r)



@dataclass(frozen=True)
class StepMetrics:
    """Response to one set-point step of one channel.

    Attributes
    ----------
    settling_time : float
        Seconds from the step until the output stays within ``band`` of the step size
        around the new set-point (inf if it never does).
    overshoot : float
        Largest excursion beyond the new set-point, percent of the step size.
    steady_state_error : float
        Mean output minus set-point over the last ``tail`` seconds of the window.
    coupling : float
        Largest deviation of each other output from its value at the step, percent of
        the step size (the largest over the other outputs).
    iae : float
        Integral of the absolute error of the channel over the window (output units
        times seconds).
    """

    settling_time: float
    overshoot: float
    steady_state_error: float
    coupling: float
    iae: float



def step_metrics(
    run: ClosedLoopRun, channel: int, start: int, stop: int, band: float = 0.05, tail: float = 2.0
) -> StepMetrics:
    """Score the set-point step of ``channel`` at sample ``start`` over samples ``start:stop``.

    Parameters
    ----------
    run : ClosedLoopRun
    channel : int
        Output whose set-point steps at ``start``.
    start, stop : int
        Window of samples; the other set-points must be constant in it.
    band : float, default 0.05
        Settling band, fraction of the step size.
    tail : float, default 2.0
        Seconds at the end of the window averaged for the steady-state error.

    Returns
    -------
    StepMetrics
    """
    r, y = run.r, run.y
    if not 0 < start < stop <= len(r):
        raise ControlDesignError(f"need 0 < start < stop <= {len(r)}, got {start}, {stop}")
    size = r[start, channel] - r[start - 1, channel]
    if size == 0:
        raise ControlDesignError(f"set-point of output {channel} does not step at sample {start}")
    Ts = run.t[1] - run.t[0]
    target = r[start, channel]
    err = (y[start:stop, channel] - target) / size  # normalised: 0 at the target, -1 before
    outside = np.flatnonzero(np.abs(err) > band)
    if outside.size and outside[-1] == stop - start - 1:
        settling = np.inf
    else:
        settling = 0.0 if outside.size == 0 else (outside[-1] + 1) * Ts
    last = max(1, int(round(tail / Ts)))
    others = [j for j in range(r.shape[1]) if j != channel]
    coupling = max(
        (np.max(np.abs(y[start:stop, j] - y[start - 1, j])) / abs(size) for j in others), default=0.0
    )
    return StepMetrics(
        settling_time=float(settling),
        overshoot=float(max(0.0, np.max(err)) * 100),
        steady_state_error=float(np.mean(y[stop - last : stop, channel] - r[stop - last : stop, channel])),
        coupling=float(coupling * 100),
        iae=float(np.sum(np.abs(y[start:stop, channel] - r[start:stop, channel])) * Ts),
    )



def time_saturated(run: ClosedLoopRun, u_limits: object, start: int = 0, stop: int | None = None) -> np.ndarray:
    """Seconds each input spends at one of its bounds over samples ``start:stop``.

    Parameters
    ----------
    run : ClosedLoopRun
    u_limits : array_like, shape (2,) or (m, 2)
        The actuator's bounds ``(low, high)``, e.g. the rig's +-2.5 V.
    start, stop : int, optional
        Window of samples; the whole run by default.

    Returns
    -------
    ndarray, shape (m,)

    Examples
    --------
    >>> run = ClosedLoopRun(t=np.arange(4) * 0.1, y=np.zeros((4, 1)), r=np.zeros((4, 1)),
    ...                     u=np.array([[0.0], [2.5], [3.0], [-2.5]]))
    >>> time_saturated(run, (-2.5, 2.5)).round(6)
    array([0.3])
    """
    u = run.u
    limits = input_bounds(u_limits, u.shape[1])
    stop = len(u) if stop is None else stop
    if not 0 <= start < stop <= len(u):
        raise ControlDesignError(f"need 0 <= start < stop <= {len(u)}, got start={start}, stop={stop}")
    window = u[start:stop]
    # An input counts as saturated at or beyond its bound: a controller may command
    # more than the actuator delivers.
    held = (window <= limits[:, 0]) | (window >= limits[:, 1])
    return held.sum(axis=0) * float(run.t[1] - run.t[0])

