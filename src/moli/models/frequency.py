"""Frequency response of a state-space model, discrete or continuous time."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import DataError

__all__ = ["check_omega", "frequency_response"]

# Frequencies solved together: bounds the (chunk, n, n) complex temporaries to a few
# megabytes for models of up to about a hundred states.
CHUNK = 64


def check_omega(omega: object) -> np.ndarray:
    """``omega`` as a 1-D float array of finite frequencies (a scalar is one frequency)."""
    try:
        values = np.array(omega, dtype=float, ndmin=1)
    except (TypeError, ValueError):
        raise DataError(f"omega must be a 1-D array of finite frequencies, got {omega!r}") from None
    if values.ndim != 1 or values.size == 0 or not np.all(np.isfinite(values)):
        raise DataError(
            f"omega must be a non-empty 1-D array of finite frequencies (rad per time unit), "
            f"got shape {values.shape}"
        )
    return values


def frequency_response(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, points: np.ndarray,
    omega: np.ndarray, *, delays: Sequence[float] | None = None,
) -> np.ndarray:
    """``C (s I - A)^-1 B + D`` at the complex points ``s`` (``points``), one per ``omega``.

    ``points`` is ``exp(1j omega Ts)`` for a discrete model, ``1j omega`` for a
    continuous one. ``delays[j]`` (time units) multiplies column ``j`` by
    ``exp(-1j omega delays[j])``. Returns shape (F, p, m); raises :class:`DataError`
    when a point is a pole of the model (the response is infinite there).
    """
    n = A.shape[0]
    F = points.shape[0]
    out = np.empty((F, C.shape[0], B.shape[1]), dtype=complex)
    out[:] = D
    if n:
        for start in range(0, F, CHUNK):
            s = points[start : start + CHUNK]
            pencil = s[:, None, None] * np.eye(n) - A
            try:
                # one solve per frequency, batched: no inverse of s I - A is formed
                solved = np.linalg.solve(pencil, np.broadcast_to(B, (s.size,) + B.shape))
            except np.linalg.LinAlgError:
                bad = omega[start : start + CHUNK][np.argmin(np.abs(np.linalg.det(pencil)))]
                raise DataError(
                    f"omega = {bad:g} is at a pole of the model: its frequency response is infinite there"
                ) from None
            out[start : start + CHUNK] += C @ solved
    if delays is not None:
        out *= np.exp(-1j * np.outer(omega, np.asarray(delays, dtype=float)))[:, None, :]
    return out
