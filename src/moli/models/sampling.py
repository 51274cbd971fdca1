"""Between sampled and continuous time: the matrices of each conversion (zero-order hold or Tustin).

:func:`discretize` samples a continuous model's matrices; :func:`continuous_matrices` is
its inverse on a sampled model, or a :class:`DataError` that names the poles no real
continuous model produces and the ways forward.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import scipy.linalg

from ..errors import DataError, OptionError

__all__ = ["CONVERSION_METHODS", "continuous_matrices", "discretize"]

CONVERSION_METHODS = ("zoh", "tustin")
# Poles closer than this (relative to the model's scale) to z = 0, or to the negative
# real axis in angle, have no real continuous-time counterpart worth trusting: the
# logarithm there is infinite or complex, and round-off of order sqrt(eps) in a
# computed eigenvalue can move it across the branch cut.
POLE_TOLERANCE = float(np.sqrt(np.finfo(float).eps))


def _method(method: object) -> str:
    if method not in CONVERSION_METHODS:
        raise OptionError(f"method must be one of {CONVERSION_METHODS}, got {method!r}")
    return str(method)


def continuous_matrices(model: Any, method: str = "zoh") -> tuple[np.ndarray, ...]:
    """``Ac, Bc, Cc, Dc`` whose sampling by ``method`` at ``model.Ts`` gives the sampled ``model``.

    "zoh": ``[[Ac, Bc], [0, 0]] = logm([[A, B], [0, I]]) / Ts`` (the inverse of the
    zero-order hold); "tustin": the inverse of the bilinear map ``s = (2/Ts)(z-1)/(z+1)``.
    """
    inverse = _zoh_inverse if _method(method) == "zoh" else _tustin_inverse
    return inverse(model)


def _scale(A: np.ndarray) -> float:
    return max(1.0, float(np.linalg.norm(A, 2))) if A.size else 1.0


def _pole(z: complex) -> str:
    return f"z = {z.real:.4g}" + (f"{z.imag:+.4g}j" if z.imag else "")


def _no_conversion(method: str, problem: str, poles: np.ndarray, tustin_works: bool) -> DataError:
    """The refusal of ``to_continuous(method)``, naming the poles and the ways forward."""
    options = ["method='tustin', the bilinear map, which converts these poles (exact at low "
               "frequency, warped near Nyquist)"] if tustin_works else []
    options += [
        "keep the discrete model: simulate, frequency_response, to_control() and the "
        "controller design all work in discrete time",
        "identify from data sampled faster (a higher sampling rate puts real modes near "
        "z = 1, away from z <= 0), or pick a lower order from result.path: a pole on the "
        "negative real axis is often a mode fitted to noise",
    ]
    listed = "; ".join(f"({k}) {option}" for k, option in enumerate(options, start=1))
    return DataError(
        f"to_continuous(method={method!r}) has no real solution: {problem}: "
        f"{', '.join(_pole(z) for z in poles)}. Options: {listed}"
    )


def _zoh_inverse(model: Any) -> tuple[np.ndarray, ...]:
    A, B, n, m = model.A, model.B, model.n, model.m
    poles = model.poles()
    near_zero = np.abs(poles) <= POLE_TOLERANCE * _scale(A)
    bad = near_zero | (np.abs(np.angle(poles)) >= np.pi - POLE_TOLERANCE)
    logarithm = None
    if not np.any(bad):
        block = np.zeros((n + m, n + m))
        block[:n, :n], block[:n, n:], block[n:, n:] = A, B, np.eye(m)
        with warnings.catch_warnings():
            # scipy notes any error estimate above 1000 eps; the imaginary part is checked below
            warnings.simplefilter("ignore", RuntimeWarning)
            logarithm = scipy.linalg.logm(block) / model.Ts
        size = max(1.0, float(np.max(np.abs(logarithm))))
        if np.max(np.abs(np.imag(logarithm))) > 1e-9 * size:
            # a negative real pole the tolerance let through: its logarithm is complex
            bad = np.abs(np.angle(poles)) == np.max(np.abs(np.angle(poles)))
            logarithm = None
    if logarithm is None:
        raise _no_conversion(
            "zoh", "the model has poles at z = 0 or on the negative real axis, which no "
            "zero-order hold of a continuous system produces", poles[bad],
            tustin_works=not np.any(np.abs(poles + 1.0) <= POLE_TOLERANCE * _scale(A)))
    real = np.real(logarithm)
    return real[:n, :n].copy(), real[:n, n:].copy(), model.C.copy(), model.D.copy()


def _tustin_inverse(model: Any) -> tuple[np.ndarray, ...]:
    A, B, C, D, Ts, n = model.A, model.B, model.C, model.D, model.Ts, model.n
    at_minus_one = np.abs(model.poles() + 1.0) <= POLE_TOLERANCE * _scale(A)
    if np.any(at_minus_one):
        # a pole at -1 is on the negative real axis: the zero-order hold fails as well
        raise _no_conversion(
            "tustin", "the model has poles at z = -1, which the bilinear map sends to "
            "infinity (and which no zero-order hold produces either)",
            model.poles()[at_minus_one], tustin_works=False)
    shifted = A + np.eye(n)
    # Ac = (2/Ts)(A - I)(A + I)^-1 (the factors commute), Bc = (2/Ts)(A + I)^-1 B,
    # Cc = 2 C (A + I)^-1, Dc = D - Cc B / 2: solves, no inverse formed
    Ac = (2.0 / Ts) * np.linalg.solve(shifted.T, (A - np.eye(n)).T).T
    Bc = (2.0 / Ts) * np.linalg.solve(shifted, B)
    Cc = 2.0 * np.linalg.solve(shifted.T, C.T).T
    return Ac, Bc, Cc, D - 0.5 * Cc @ B


def discretize(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, Ts: float, method: str = "zoh"
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sampled matrices of a continuous model: zero-order hold (``expm`` of the block
    matrix ``[[A, B], [0, 0]] Ts``) or Tustin (``s = (2/Ts)(z-1)/(z+1)``)."""
    kind = _method(method)
    n, m = B.shape
    if kind == "zoh":
        block = np.zeros((n + m, n + m))
        block[:n, :n], block[:n, n:] = A * Ts, B * Ts
        exponential = scipy.linalg.expm(block)
        return exponential[:n, :n], exponential[:n, n:], C.copy(), D.copy()
    half = np.eye(n) - 0.5 * Ts * A
    if n and np.linalg.cond(half) > 1.0 / np.finfo(float).eps:
        raise DataError(f"method='tustin' has no solution: A has an eigenvalue at 2/Ts = {2 / Ts:g}")
    Ad = np.linalg.solve(half, np.eye(n) + 0.5 * Ts * A)
    Bd = np.linalg.solve(half, Ts * B)
    Cd = np.linalg.solve(half.T, C.T).T
    return Ad, Bd, Cd, D + 0.5 * C @ Bd
