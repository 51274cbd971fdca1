"""Decentralized PID baseline: one loop per output-input pair, tuned on the model."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..models.statespace import StateSpaceModel
from .lq import ControlDesignError

__all__ = ["PIDGains", "DecentralizedPID", "tune_pid", "pid_baseline"]


@dataclass(frozen=True)
class PIDGains:
    """Gains of one discrete PID loop ``u = kp e + ki sum(e) Ts - kd dy/dt (filtered)``.

    The derivative acts on the measurement (no kick at set-point steps) through
    a first-order filter of time constant ``tf`` seconds.
    """

    kp: float
    ki: float
    kd: float
    tf: float = 0.2



@dataclass
class DecentralizedPID:
    """One PID loop per output, each driving one input; no coupling compensation.

    Parameters
    ----------
    gains : sequence of PIDGains
        One per loop.
    pairing : sequence of (output, input) index pairs
        Loop ``i`` reads output ``pairing[i][0]`` and drives input ``pairing[i][1]``.
    Ts : float
    u0 : array_like, shape (m,)
        Input around which the loops act (the trim).
    u_limits : array_like, shape (m, 2)
        Absolute input bounds; while its input is at a bound, a loop's integrator
        stops if integrating would push the input further past it.
    """

    gains: Sequence[PIDGains]
    pairing: Sequence[tuple[int, int]]
    Ts: float
    u0: np.ndarray
    u_limits: np.ndarray
    _integral: np.ndarray = field(init=False, repr=False)
    _deriv: np.ndarray = field(init=False, repr=False)
    _last_y: np.ndarray | None = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if len(self.gains) != len(self.pairing):
            raise ControlDesignError("need one PIDGains per (output, input) pair")
        self.u0 = np.asarray(self.u0, dtype=float)
        self.u_limits = np.broadcast_to(np.asarray(self.u_limits, dtype=float), (self.u0.size, 2)).copy()
        self.reset()

    def reset(self) -> None:
        """Zero the integrators and derivative filters."""
        self._integral = np.zeros(len(self.gains))
        self._deriv = np.zeros(len(self.gains))
        self._last_y = None

    def update(self, y: np.ndarray, r: np.ndarray) -> np.ndarray:
        """Absolute input for measured outputs ``y`` and set-points ``r``."""
        y = np.asarray(y, float)
        r = np.asarray(r, float)
        last = y if self._last_y is None else self._last_y
        u = self.u0.copy()
        for i, (g, (out, inp)) in enumerate(zip(self.gains, self.pairing)):
            e = r[out] - y[out]
            # Backward-Euler discretisation of kd s / (tf s + 1) acting on -y.
            self._deriv[i] = (g.tf * self._deriv[i] - g.kd * (y[out] - last[out])) / (g.tf + self.Ts)
            free = u[inp] + g.kp * e + self._integral[i] + self._deriv[i]
            u[inp] = np.clip(free, *self.u_limits[inp])
            push = g.ki * e  # change of the free input per unit of integration
            # Integrate unless the input is limited and integrating would push it further
            # past the limit; freezing in both directions locks a loop without
            # proportional action (such as the pitch loop, pure integral) at its limit.
            if u[inp] == free or np.sign(push) != np.sign(free - u[inp]):
                self._integral[i] += push * self.Ts
        self._last_y = y
        return u



def _siso_cost(
    params: np.ndarray, A: np.ndarray, b: np.ndarray, c: np.ndarray, gain: float, Ts: float, *, N: int
) -> float:
    """ITAE of a unit set-point step of one loop on a linear channel, plus a move penalty.

    Input moves are weighted in output units (times the static ``gain``), so the
    trade-off does not depend on the channel's units.
    """
    kp, ki, kd = params
    g = PIDGains(kp, ki, kd)
    x = np.zeros(A.shape[0])
    integral = deriv = y_last = 0.0
    cost = 0.0
    u_last = 0.0
    for k in range(N):
        y = float(c @ x)
        e = 1.0 - y
        deriv = (g.tf * deriv - g.kd * (y - y_last)) / (g.tf + Ts)
        integral += g.ki * Ts * e
        u = g.kp * e + integral + deriv
        # The move penalty keeps the derivative action from amplifying the
        # encoder's quantisation steps into a chattering input.
        cost += k * Ts * abs(e) * Ts + 0.01 * (gain * (u - u_last)) ** 2
        if not np.isfinite(cost) or abs(y) > 1e3:
            return 1e9
        x = A @ x + b * u
        y_last, u_last = y, u
    return cost



def tune_pid(model: StateSpaceModel, output: int, input: int, horizon: float = 30.0) -> PIDGains:
    """Tune one decentralised loop on the diagonal channel ``input -> output`` of ``model``.

    Minimises the integral of time times absolute error of a unit set-point step
    (plus a small penalty on input moves) over ``horizon`` seconds with
    ``scipy.optimize.minimize`` (Nelder-Mead, gains bounded to [0, 20]),
    ignoring the other channels, as a decentralised design does.

    Parameters
    ----------
    model : StateSpaceModel
        Discrete-time model in deviation variables.
    output, input : int
        Channel indices.
    horizon : float, default 30.0
        Length of the simulated step, seconds.

    Returns
    -------
    PIDGains
    """
    from scipy.optimize import minimize

    if not (0 <= output < model.p and 0 <= input < model.m):
        raise ControlDesignError(f"no channel {input} -> {output} in a {model.p}x{model.m} model")
    b, c = model.B[:, input], model.C[output]
    gain = float(c @ np.linalg.solve(np.eye(model.n) - model.A, b))
    if not np.isfinite(gain) or gain == 0:
        raise ControlDesignError(f"channel {input} -> {output} has no usable static gain")
    # Start from a gentle integral controller of the right sign.
    start = np.array([0.5, 0.2, 0.2]) / gain
    sign = np.sign(gain)
    N = int(round(horizon / model.Ts))
    res = minimize(
        lambda v: _siso_cost(sign * v, model.A, b, c, gain, model.Ts, N=N), sign * start,
        method="Nelder-Mead", bounds=[(0.0, 20.0)] * 3, options={"xatol": 1e-3, "fatol": 1e-4},
    )
    kp, ki, kd = sign * res.x
    return PIDGains(float(kp), float(ki), float(kd))



def pid_baseline(model: StateSpaceModel, u_limits: object = (-2.5, 2.5)) -> DecentralizedPID:
    """Two decentralised PID loops (output i from input i), each tuned by :func:`tune_pid`.

    Parameters
    ----------
    model : StateSpaceModel
        Square model; its ``u_offset`` is the input the loops act around.
    u_limits : array_like, shape (2,) or (m, 2)

    Returns
    -------
    DecentralizedPID
    """
    if model.p != model.m:
        raise ControlDesignError(f"a diagonal pairing needs a square model, got {model.p}x{model.m}")
    gains = [tune_pid(model, i, i) for i in range(model.p)]
    return DecentralizedPID(
        gains=gains, pairing=[(i, i) for i in range(model.p)], Ts=model.Ts,
        u0=model.u_offset, u_limits=np.asarray(u_limits, dtype=float),
    )

