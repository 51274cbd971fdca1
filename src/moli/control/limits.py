"""Actuator limits of the LQ servo and its per-channel anti-windup.

A servo with one integrator per output can hold every output at its set-point
only while every input is free. When input ``i`` sits at a bound, the remaining
inputs can still hold all outputs but one: the integrator paired with input ``i``
must stop, and every other integrator must keep running, or its output stays off
its set-point for as long as input ``i`` is saturated. This module validates the
limits, pairs integrators with inputs and applies both.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import ControlDesignError

__all__ = ["input_bounds", "rate_bounds", "integrator_pairing", "integrating"]


def input_bounds(u_limits: object, m: int) -> np.ndarray:
    """Absolute input bounds as an ``(m, 2)`` array of ``(low, high)`` rows.

    Parameters
    ----------
    u_limits : array_like, shape (2,) or (m, 2)
        One ``(low, high)`` pair for every input, or one row per input;
        ``-inf``/``inf`` leave a side open.
    m : int
        Number of inputs.

    Returns
    -------
    ndarray, shape (m, 2)
        A new array; ``u_limits`` is not modified.

    Examples
    --------
    >>> input_bounds((-2.5, 2.5), 2)
    array([[-2.5,  2.5],
           [-2.5,  2.5]])
    """
    try:
        limits = np.array(u_limits, dtype=float)
    except (TypeError, ValueError):
        limits = np.empty(0)
    if limits.shape == (2,):
        limits = np.tile(limits, (m, 1))
    if limits.shape != (m, 2) or np.any(np.isnan(limits)) or np.any(limits[:, 0] >= limits[:, 1]):
        raise ControlDesignError(
            f"u_limits must be (low, high) with low < high, once or once per input ({m} rows); "
            f"got {u_limits!r}"
        )
    return limits


def rate_bounds(rate_limits: object, m: int) -> np.ndarray:
    """Largest input change per second of each input, ``inf`` where there is none.

    Parameters
    ----------
    rate_limits : None, float or array_like, shape (m,)
        Positive rates (input units per second); ``None`` for no rate limit.
    m : int
        Number of inputs.

    Returns
    -------
    ndarray, shape (m,)

    Examples
    --------
    >>> rate_bounds(None, 2)
    array([inf, inf])
    >>> rate_bounds(5.0, 2)
    array([5., 5.])
    """
    if rate_limits is None:
        return np.full(m, np.inf)
    try:
        rates = np.array(rate_limits, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        rates = np.empty(0)
    if rates.size == 1:
        rates = np.full(m, rates[0])
    if rates.shape != (m,) or np.any(np.isnan(rates)) or np.any(rates <= 0):
        raise ControlDesignError(
            f"rate_limits must be None, or {m} positive rates (inf for none) per second; got {rate_limits!r}"
        )
    return rates


def integrator_pairing(Ki: np.ndarray, pairing: Sequence[int] | None = None) -> np.ndarray:
    """Input paired with each output integrator, for the anti-windup.

    By default from the relative gain array ``Ki * pinv(Ki).T`` of the integral
    gain ``Ki`` (inputs x integrators): each integrator gets a different input,
    maximising the sum of the chosen relative gains. The relative gains do not
    depend on the units of inputs and outputs, unlike ``Ki`` itself.

    Parameters
    ----------
    Ki : ndarray, shape (m, p)
        Integral gain, ``u = ... - Ki xi``; needs ``m >= p``.
    pairing : sequence of int, shape (p,), optional
        Input index for each integrator, all different; replaces the default.

    Returns
    -------
    ndarray of int, shape (p,)

    Examples
    --------
    >>> integrator_pairing(np.array([[0.1, 2.0], [1.0, 0.3]]))
    array([1, 0])
    """
    from scipy.optimize import linear_sum_assignment

    m, p = Ki.shape
    if pairing is None:
        if m < p:
            raise ControlDesignError(f"need at least as many inputs as integrators, got {m} < {p}")
        gains = Ki * np.linalg.pinv(Ki).T
        integrators, inputs = linear_sum_assignment(gains.T, maximize=True)
        chosen = np.empty(p, dtype=int)
        chosen[integrators] = inputs
    else:
        chosen = np.array(pairing).reshape(-1)
        valid = (
            chosen.shape == (p,) and np.issubdtype(chosen.dtype, np.integer)
            and np.all((chosen >= 0) & (chosen < m)) and np.unique(chosen).size == p
        )
        if not valid:
            raise ControlDesignError(
                f"pairing must give {p} different input indices in 0..{m - 1}, one per output; got {pairing!r}"
            )
    weak = [j for j in range(p) if Ki[chosen[j], j] == 0]
    if weak:
        raise ControlDesignError(
            f"integrators {weak} do not drive their paired inputs {chosen[weak].tolist()} (zero gain); "
            f"pass another pairing"
        )
    return chosen


def integrating(Ki: np.ndarray, pairing: np.ndarray, error: np.ndarray, excess: np.ndarray) -> np.ndarray:
    """Which integrators run this sample (conditional integration per channel).

    Integrator ``j`` stops only when its paired input ``i`` is limited
    (``excess[i] = u_free[i] - u[i] != 0``) and integrating ``error[j]`` would push
    ``u_free[i]`` further past the limit; integrating in the other direction
    brings the input back, so it goes on.

    Parameters
    ----------
    Ki : ndarray, shape (m, p)
    pairing : ndarray of int, shape (p,)
    error : ndarray, shape (p,)
        Output minus set-point, the integrand.
    excess : ndarray, shape (m,)
        Unlimited minus applied input.

    Returns
    -------
    ndarray of bool, shape (p,)

    Examples
    --------
    >>> Ki = np.eye(2)
    >>> integrating(Ki, np.array([0, 1]), np.array([1.0, 1.0]), np.array([-0.5, 0.0]))
    array([False,  True])
    """
    cols = np.arange(pairing.size)
    push = -Ki[pairing, cols] * error  # change of u_free[pairing[j]] per unit of integration
    return ~((excess[pairing] != 0) & (np.sign(push) == np.sign(excess[pairing])))
