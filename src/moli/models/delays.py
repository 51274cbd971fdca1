"""Input delays (dead times) of a model: checking, shifting the inputs, delay states.

A model with input delays ``d = (d_1, ..., d_m)`` is the delay-free model driven by
the shifted inputs ``u_j[k - d_j]``, zero before the record starts (docs/diagnostics.md
§3). The delays are not states of the model: simulation shifts the input columns.
:func:`delay_states` builds the equivalent delay-free model with one shift register
per input for tools that cannot represent dead time (python-control, controller design).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import DataError

__all__ = ["check_delays", "shift_inputs", "delay_states"]


def check_delays(delays: object, m: int, name: str = "input_delays") -> tuple[int, ...]:
    """``delays`` as a tuple of ``m`` non-negative ints; a single int applies to every input.

    Raises :class:`DataError` naming ``name`` and the accepted values otherwise.

    Examples
    --------
    >>> check_delays(2, 3), check_delays([0, 4], 2)
    ((2, 2, 2), (0, 4))
    """
    accepted = f"a non-negative integer or a sequence of {m} non-negative integers (one per input)"
    values = [delays] * m if _is_integer(delays) else delays
    try:
        items = list(values)  # type: ignore[call-overload]
    except TypeError:
        raise DataError(f"{name} must be {accepted}, got {delays!r}") from None
    if len(items) != m or not all(_is_integer(v) and int(v) >= 0 for v in items):
        raise DataError(f"{name} must be {accepted}, got {delays!r}")
    return tuple(int(v) for v in items)


def _is_integer(value: object) -> bool:
    # numpy integers count, booleans do not (True is not a delay of one sample)
    return not isinstance(value, (bool, np.bool_)) and isinstance(value, (int, np.integer))


def shift_inputs(u: np.ndarray, delays: Sequence[int]) -> np.ndarray:
    """A copy of ``u`` (N, m) with column ``j`` delayed by ``delays[j]`` samples, zero before.

    Examples
    --------
    >>> shift_inputs(np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]]), (0, 1))
    array([[1., 0.],
           [2., 1.],
           [3., 2.]])
    """
    shifted = np.zeros_like(u)
    N = u.shape[0]
    for j, d in enumerate(delays):
        if d < N:
            shifted[d:, j] = u[: N - d, j]
    return shifted


def delay_states(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, delays: Sequence[int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The delay-free realization of ``(A, B, C, D)`` with input delays: ``sum(delays)`` more states.

    Input ``j`` passes through a chain of ``d_j`` unit delays (states ``w``,
    ``w_1[k+1] = u_j[k]``, ``w_i[k+1] = w_{i-1}[k]``) whose last state drives the
    model where ``u_j`` did: column ``j`` of ``B`` and ``D`` moves to that state.
    The original states come first, so ``x[:n]`` keeps its meaning.

    Examples
    --------
    >>> A, B, C, D = delay_states(np.eye(1), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)), [2])
    >>> A
    array([[1., 0., 1.],
           [0., 0., 0.],
           [0., 1., 0.]])
    >>> B.ravel(), C.ravel(), D.ravel()
    (array([0., 1., 0.]), array([1., 0., 0.]), array([0.]))
    """
    n, m = B.shape
    p = C.shape[0]
    total = n + int(sum(delays))
    Aa = np.zeros((total, total))
    Aa[:n, :n] = A
    Ba = np.zeros((total, m))
    Ca = np.zeros((p, total))
    Ca[:, :n] = C
    Da = D.copy()
    first = n
    for j, d in enumerate(delays):
        if d == 0:
            Ba[:n, j] = B[:, j]
            continue
        last = first + d - 1
        Ba[first, j] = 1.0
        for i in range(first, last):
            Aa[i + 1, i] = 1.0                    # the chain: each state takes the previous one
        Aa[:n, last] = B[:, j]                    # the chain's end drives the model...
        Ca[:, last] = D[:, j]                     # ...and its feedthrough
        Da[:, j] = 0.0
        first = last + 1
    return Aa, Ba, Ca, Da
