"""Confidence bands of a model's responses from the covariance of its matrices.

A model with a covariance carries ``cov_factor`` ``S``: ``vec = [A, B, C, D]``
(flattened) has covariance ``S S^T``, so ``vec = vec_0 + S z`` with ``z`` standard
normal describes the uncertainty to first order (docs/uncertainty.md). Each column of
``S`` is one independent direction ``(dA, dB, dC, dD)``.

- ``method="gauss"``: the response ``r`` is linearized, ``dr = sum_k (dr/dvec) S_k z_k``,
  so its standard deviation is the root sum of squares of the directional derivatives,
  and the band is ``r ± q sd`` with ``q`` the normal quantile of the confidence.
- ``method="monte_carlo"``: ``samples`` draws of ``vec`` from that normal
  distribution, each response computed exactly, the band between the empirical
  quantiles ``(1 - confidence) / 2`` and ``(1 + confidence) / 2``.

Bands are pointwise: each frequency, sample and channel has its own interval.
"""

from __future__ import annotations

from typing import Any  # the model: StateSpaceModel imports this module, so not the reverse

import numpy as np

from ..data.iodata import as_signal
from ..errors import DataError, OptionError
from .propagation import propagate
from .simulation import simulate_batch

__all__ = ["magnitude_bands", "step_bands", "output_bands"]

BAND_METHODS = ("gauss", "monte_carlo")
# Monte Carlo draws whose frequency responses are solved at once: bounds the memory
# of the batched (draws, frequencies, n, n) systems.
DRAW_CHUNK = 64
# Gauss directions simulated at once: bounds the (directions, N, p) tangent outputs.
DIRECTION_CHUNK = 32


def _check_options(confidence: object, method: object, samples: object, seed: object) -> float:
    if isinstance(confidence, bool) or not isinstance(confidence, (int, float, np.floating)) \
            or not 0 < float(confidence) < 1:
        raise OptionError(f"confidence must be a number strictly between 0 and 1, got {confidence!r}")
    if method not in BAND_METHODS:
        raise OptionError(f"method must be one of {BAND_METHODS}, got {method!r}")
    for name, value, low in (("samples", samples, 2), ("seed", seed, 0)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise OptionError(f"{name} must be an integer >= {low}, got {value!r}")
    return float(confidence)


def _factor(model: Any) -> np.ndarray:
    if model.cov_factor is None:
        raise DataError(
            "this model carries no covariance (model.cov_factor is None): bands need a model from "
            "moli.identify or moli.estimate, or moli.estimate_covariance(model, data)"
        )
    return model.cov_factor


def _split(model: Any, vectors: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rows of ``vectors`` (flattened ``[A, B, C, D]``) as batches of matrices."""
    n, p, m = model.n, model.p, model.m
    ends = np.cumsum([n * n, n * m, p * n])
    count = vectors.shape[0]
    shapes = ((n, n), (n, m), (p, n), (p, m))
    return tuple(part.reshape((count,) + shape) for part, shape in zip(np.split(vectors, ends, axis=1), shapes))


def _draws(model: Any, samples: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``samples`` draws of the matrices from their first-order normal distribution."""
    factor = _factor(model)
    nominal = np.concatenate([model.A.ravel(), model.B.ravel(), model.C.ravel(), model.D.ravel()])
    normal = np.random.default_rng(seed).standard_normal((samples, factor.shape[1]))
    return _split(model, nominal + normal @ factor.T)


def _frequencies(omega: object) -> np.ndarray:
    try:
        values = np.array(omega, dtype=float, ndmin=1)
    except (TypeError, ValueError):
        values = None
    if values is None or values.ndim != 1 or values.size == 0 or not np.all(np.isfinite(values)):
        raise OptionError(f"omega must be a non-empty 1-D sequence of finite frequencies (rad per time unit), got {omega!r}")
    return values


def _resolvent(A: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``z I - A`` for every ``z``: shape (..., len(z), n, n) for ``A`` of shape (..., n, n)."""
    n = A.shape[-1]
    return z[:, None, None] * np.eye(n) - A[..., None, :, :]


def _interval(values: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """Empirical quantiles of the draws (axis 0) that hold ``confidence`` in the middle."""
    lower, upper = np.quantile(values, [(1 - confidence) / 2, (1 + confidence) / 2], axis=0)
    return lower, upper


def _simulated(model: Any, A: np.ndarray, B: np.ndarray, C: np.ndarray, u: np.ndarray,
               t: np.ndarray | None) -> np.ndarray:
    """Outputs (R, N, p) of the R systems ``(A, B, C)`` in the model's time domain, zero initial state.

    Sampled: ``x[k+1] = A x[k] + B u[k]``; continuous: ``x' = A x + B u`` exact between
    the stamps ``t`` for the model's ``input_hold``.
    """
    if not model.is_continuous:
        return simulate_batch(A, B, C, u)
    linear = np.full((u.shape[1], 1), model.input_hold == "foh")
    with np.errstate(all="ignore"):     # an unstable draw's overflow stays inf, as a sampled one's does
        return np.stack([propagate(a, b, t - t[0], u[:, :, None], linear)[:, :, 0] @ c.T
                         for a, b, c in zip(A, B, C)])


def _stamps(model: Any, t: object, count: int) -> np.ndarray | None:
    """A continuous model's stamps, one per sample and increasing; None for a sampled model."""
    if not model.is_continuous:
        return None
    if t is None:
        raise DataError("a continuous model's bands need the time stamps t of the samples")
    stamps = np.array(t, dtype=float, ndmin=1)
    if stamps.shape != (count,) or not np.all(np.isfinite(stamps)) or np.any(np.diff(stamps) <= 0):
        raise DataError(f"t must be {count} finite increasing time stamps (one per sample), got shape {np.shape(t)}")
    return stamps


def _normal_quantile(confidence: float) -> float:
    import scipy.special  # only when a band is drawn

    # the normal quantile (scipy.stats.norm.ppf is this function; scipy.stats is slow to import)
    return float(scipy.special.ndtri(0.5 + confidence / 2))


def magnitude_bands(
    model: Any, omega: object, confidence: float = 0.95, *, method: str = "gauss", samples: int = 1000,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Pointwise confidence bands of the gain ``|H(exp(1j omega Ts))|`` of every channel.

    ``H(z) = C (z I - A)^-1 B + D`` is the model's frequency response.

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel
        With a covariance (``cov_factor``).
    omega : array_like, shape (W,)
        Frequencies in rad per time unit (the Nyquist frequency of a sampled model is ``pi / Ts``;
        a continuous model's gain is ``|H(1j omega)|``).
    confidence : float, default 0.95
        Probability held by each pointwise interval, in (0, 1).
    method : {"gauss", "monte_carlo"}, default "gauss"
        First-order propagation (the lower edge is clipped at 0), or quantiles of
        ``samples`` draws of the matrices.
    samples : int, default 1000
        Monte Carlo draws (ignored by "gauss").
    seed : int, default 0
        Seed of the Monte Carlo draws.

    Returns
    -------
    lower, upper : ndarray, shape (W, p, m)

    Raises
    ------
    OptionError
        An invalid ``omega``, ``confidence``, ``method``, ``samples`` or ``seed``.
    DataError
        The model carries no covariance.

    Examples
    --------
    >>> import moli
    >>> model = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]], cov_factor=[[0.0], [0.1], [0.0], [0.0]])
    >>> lower, upper = magnitude_bands(model, [0.0], method="monte_carlo", samples=4000)
    >>> bool(1.55 < lower[0, 0, 0] < 1.65 and 2.35 < upper[0, 0, 0] < 2.45)     # 2 -+ 1.96 x 0.2
    True
    """
    confidence = _check_options(confidence, method, samples, seed)
    w = _frequencies(omega)
    # a continuous model is evaluated on the imaginary axis
    z = 1j * w if model.is_continuous else np.exp(1j * w * model.Ts)
    factor = _factor(model)
    if method == "monte_carlo":
        A, B, C, D = _draws(model, samples, seed)
        gains = np.empty((samples, z.size, model.p, model.m))
        for start in range(0, samples, DRAW_CHUNK):
            part = slice(start, start + DRAW_CHUNK)
            solved = np.linalg.solve(_resolvent(A[part], z), B[part, None].astype(complex))
            gains[part] = np.abs(C[part, None] @ solved + D[part, None])
        return _interval(gains, confidence)
    dA, dB, dC, dD = _split(model, factor.T)
    shifted = _resolvent(model.A, z)                                                  # (W, n, n)
    to_output = np.linalg.solve(shifted, model.B.astype(complex))                     # (zI - A)^-1 B
    from_state = np.linalg.solve(shifted.transpose(0, 2, 1), model.C.T.astype(complex)).transpose(0, 2, 1)
    H = model.C @ to_output + model.D                                                 # (W, p, m)
    dH = (dC[None] @ to_output[:, None] + (from_state[:, None] @ dA[None]) @ to_output[:, None]
          + from_state[:, None] @ dB[None] + dD[None])                                # (W, r, p, m)
    gain = np.abs(H)
    # d|H| = Re(conj(H) dH) / |H|; at H = 0 the gain grows like |dH| in every direction
    safe = np.where(gain > 0, gain, 1.0)
    slope = np.where(gain[:, None] > 0, np.real(np.conj(H)[:, None] * dH) / safe[:, None], np.abs(dH))
    spread = _normal_quantile(confidence) * np.sqrt(np.sum(slope**2, axis=1))
    return np.maximum(gain - spread, 0.0), gain + spread


def output_bands(
    model: Any, u: object, confidence: float = 0.95, *, method: str = "gauss", samples: int = 1000,
    seed: int = 0, t: object = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Pointwise confidence bands of the simulated output for the input ``u`` (deviations, zero state).

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel
        With a covariance (``cov_factor``).
    u : array_like, shape (N, m)
        Input deviations (1-D accepted when m = 1).
    t : array_like, shape (N,), optional
        The samples' time stamps: needed by a continuous model, unused by a sampled one.
    confidence, method, samples, seed
        As in :func:`magnitude_bands`. Monte Carlo keeps ``samples x N x p`` outputs.

    Returns
    -------
    lower, upper : ndarray, shape (N, p)

    Examples
    --------
    >>> import moli
    >>> model = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]], cov_factor=[[0.0], [0.1], [0.0], [0.0]])
    >>> lower, upper = output_bands(model, [1.0, 0.0, 0.0])     # outputs 0, b, 0.5 b; b = 1 +- 0.1
    >>> (upper[:, 0] - lower[:, 0]).round(4)                  # 2 x 1.96 x 0.1 (0, 1, 0.5)
    array([0.   , 0.392, 0.196])
    """
    confidence = _check_options(confidence, method, samples, seed)
    inputs = as_signal("u", u, model.m)
    stamps = _stamps(model, t, inputs.shape[0])
    factor = _factor(model)
    if method == "monte_carlo":
        A, B, C, D = _draws(model, samples, seed)
        outputs = _simulated(model, A, B, C, inputs, stamps) + np.einsum("spm,tm->stp", D, inputs)
        return _interval(outputs, confidence)
    n = model.n
    nominal = model.simulate_at(inputs, stamps)
    variance = np.zeros_like(nominal)
    for start in range(0, factor.shape[1], DIRECTION_CHUNK):
        dA, dB, dC, dD = _split(model, factor[:, start : start + DIRECTION_CHUNK].T)
        r = dA.shape[0]
        # tangent system: x+ = A x + B u, dx+ = A dx + dA x + dB u, dy = C dx + dC x + dD u
        # (the same in continuous time with x' for x+)
        tangent = np.zeros((r, 2 * n, 2 * n))
        tangent[:, :n, :n] = tangent[:, n:, n:] = model.A
        tangent[:, n:, :n] = dA
        drive = np.concatenate([np.broadcast_to(model.B, dB.shape), dB], axis=1)
        read = np.concatenate([dC, np.broadcast_to(model.C, dC.shape)], axis=2)
        change = _simulated(model, tangent, drive, read, inputs, stamps) + np.einsum("rpm,tm->rtp", dD, inputs)
        variance += np.sum(change**2, axis=0)
    spread = _normal_quantile(confidence) * np.sqrt(variance)
    return nominal - spread, nominal + spread


def step_bands(
    model: Any, n_steps: int | object, confidence: float = 0.95, *, method: str = "gauss", samples: int = 1000,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Pointwise confidence bands of the unit-step responses from every input.

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel
        With a covariance (``cov_factor``).
    n_steps : int, or array_like of shape (N,) for a continuous model
        Samples of each response, from the step at sample 0 (zero initial state); for a
        continuous model, the increasing times of the samples, the step at the first.
    confidence, method, samples, seed
        As in :func:`magnitude_bands`; every input's responses use the same draws.

    Returns
    -------
    lower, upper : ndarray, shape (n_steps, p, m)
        Entry ``[k, i, j]``: output ``i`` at sample ``k`` after a unit step on input ``j``.

    Examples
    --------
    >>> import moli
    >>> model = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]], cov_factor=[[0.0], [0.1], [0.0], [0.0]])
    >>> lower, upper = step_bands(model, 30)
    >>> lower.shape, bool(lower[-1, 0, 0] < 2.0 < upper[-1, 0, 0])     # the static gain 1 / (1 - 0.5)
    ((30, 1, 1), True)
    """
    if model.is_continuous:
        stamps = np.array(n_steps, dtype=float, ndmin=1) if isinstance(n_steps, (list, tuple, np.ndarray)) else None
        if stamps is None or stamps.ndim != 1:
            raise OptionError(f"a continuous model's step bands need the times after the step (a 1-D array, "
                              f"the step at the first), got {n_steps!r}")
        count = _stamps(model, stamps, stamps.size).size
    elif isinstance(n_steps, bool) or not isinstance(n_steps, (int, np.integer)) or n_steps < 1:
        raise OptionError(f"n_steps must be an integer >= 1, got {n_steps!r}")
    else:
        stamps, count = None, int(n_steps)
    _check_options(confidence, method, samples, seed)
    _factor(model)
    lower, upper = np.empty((2, count, model.p, model.m))
    for j in range(model.m):
        step = np.zeros((count, model.m))
        step[:, j] = 1.0
        lower[:, :, j], upper[:, :, j] = output_bands(
            model, step, confidence, method=method, samples=samples, seed=seed, t=stamps)
    return lower, upper
