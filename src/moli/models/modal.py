"""modes(model): natural frequency, damping ratio and output shape of each pole of a model.

A continuous-time pole ``lambda = -zeta omega_n ± j omega_n sqrt(1 - zeta^2)`` has natural
frequency ``omega_n = |lambda|`` and damping ratio ``zeta = -Re(lambda) / |lambda|``; a
sampled model's pole ``z`` is read through its continuous equivalent ``lambda = ln(z) / Ts``
(the principal logarithm: a pole on the negative real axis is a mode at the Nyquist
frequency). The mode's shape is ``C v`` for its right eigenvector ``v``, the output
pattern in which the mode appears in every response, scaled so that its largest entry is
1 (a complex shape: the phases of the outputs relative to that one).

A model with a covariance (``cov_factor``) also gives each mode's standard deviations, to
first order: a simple eigenvalue moves by ``d lambda = w^H dA v / (w^H v)`` (``w`` its left
eigenvector), a sampled pole's continuous equivalent by ``dz / (z Ts)``, and
``d omega_n = Re(conj(lambda) d lambda) / |lambda|``,
``d zeta = -Re(d lambda) / |lambda| - Re(lambda) d omega_n / |lambda|^2``, summed in squares over
the factor's independent directions. The shape ``phi = C v / (C v)_r`` (``r`` its largest entry)
moves with ``C`` and with the eigenvector, ``dv = sum_(j != i) v_j (w_j^H dA v) / (lambda_i - lambda_j)``
(the part along ``v`` itself only rescales ``C v``, which the division by ``(C v)_r`` takes out):
``d phi = (d(C v) - phi d(C v)_r) / (C v)_r``, and each output's magnitude moves by
``Re(conj(phi) d phi) / |phi|`` and its phase by ``Im(d phi / phi)``. The reference output's
entry is 1 by construction: its standard deviations are 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import DataError

__all__ = ["Mode", "modes", "REAL_POLE"]

# A pole whose imaginary part is below this fraction of its modulus is real, one mode and not a
# pair (eig's round-off leaves ~1e-16 on a real pole; an oscillatory pole with that little is none).
REAL_POLE = 1e-9


@dataclass(frozen=True)
class Mode:
    """One mode of a model: a real pole or a complex pair (taken with its positive imaginary part).

    Attributes
    ----------
    pole : complex
        The continuous-time pole ``lambda`` (for a sampled model ``ln(z) / Ts``).
    natural_frequency : float
        ``|lambda|`` in rad per time unit.
    frequency_hz : float
        ``natural_frequency / (2 pi)``, cycles per time unit.
    damping : float
        ``-Re(lambda) / |lambda|``: 0 undamped, 1 critically damped or a real pole; negative
        for an unstable mode; NaN for a pole at the origin.
    shape : ndarray, shape (p,), complex
        The outputs' share of the mode, largest entry 1.
    oscillatory : bool
        A complex pair (True) or a real pole.
    natural_frequency_std, damping_std : float or None
        First-order standard deviations from the model's covariance; None without one.
    shape_magnitude_std, shape_phase_std : ndarray, shape (p,), or None
        First-order standard deviations of each output's ``|shape|`` and of its phase (radians)
        from the model's covariance; None without one, not finite where another pole coincides
        with this one (the eigenvector is then not a smooth function of ``A``).
    """

    pole: complex
    natural_frequency: float
    frequency_hz: float
    damping: float
    shape: np.ndarray
    oscillatory: bool
    natural_frequency_std: float | None = None
    damping_std: float | None = None
    shape_magnitude_std: np.ndarray | None = None
    shape_phase_std: np.ndarray | None = None


def _spreads(model: Any, value: complex, vector: np.ndarray, left: np.ndarray,
             Ts: float | None) -> tuple[float, float] | tuple[None, None]:
    """Standard deviations of the natural frequency and damping of the pole ``value`` (continuous equivalent)."""
    factor = getattr(model, "cov_factor", None)
    if factor is None:
        return None, None
    n = vector.size
    directions = np.asarray(factor)[: n * n].T.reshape(-1, n, n)                        # dA per direction
    moved = np.einsum("i,kij,j->k", left.conj(), directions, vector) / (left.conj() @ vector)
    pole = value
    if Ts is not None:
        z = np.exp(value * Ts)
        moved = moved / (z * Ts)
    scale = abs(pole)
    if scale == 0:
        return None, None
    natural = np.real(np.conj(pole) * moved) / scale
    damping = -np.real(moved) / scale - pole.real * natural / scale**2
    return float(np.sqrt(np.sum(natural**2))), float(np.sqrt(np.sum(damping**2)))


def _shape_spreads(model: Any, index: int, eigenvalues: np.ndarray, vectors: np.ndarray, lefts: np.ndarray, *,
                   shape: np.ndarray, reference: int) -> tuple[np.ndarray, np.ndarray] | tuple[None, None]:
    """Standard deviations of each output's shape magnitude and phase for the eigenvalue ``index``."""
    factor = getattr(model, "cov_factor", None)
    if factor is None:
        return None, None
    factor = np.asarray(factor)
    n, p, m = vectors.shape[0], shape.size, np.asarray(model.B).shape[1]
    dA = factor[: n * n].T.reshape(-1, n, n)
    dC = factor[n * n + n * m: n * n + n * m + p * n].T.reshape(-1, p, n)
    vector, C = vectors[:, index], np.asarray(model.C, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse_gaps = 1.0 / (eigenvalues[index] - eigenvalues)
    inverse_gaps[index] = 0.0
    coupling = np.einsum("rj,krs,s->kj", lefts.conj(), dA, vector) * inverse_gaps              # (K, n)
    with np.errstate(invalid="ignore"):
        moved = np.einsum("kpn,n->kp", dC, vector) + (coupling @ vectors.T) @ C.T               # d(C v), (K, p)
    normalized = shape / shape[reference]
    d_shape = (moved - np.outer(moved[:, reference], normalized)) / shape[reference]
    d_shape[:, reference] = 0.0                                 # 1 by construction; round-off apart
    present = np.abs(normalized) > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        magnitude = np.where(present, np.real(np.conj(normalized) * d_shape) / np.abs(normalized), 0.0)
        phase = np.where(present, np.imag(d_shape / normalized), 0.0)
    return np.sqrt(np.sum(magnitude**2, axis=0)), np.sqrt(np.sum(phase**2, axis=0))


def modes(model: Any) -> tuple[Mode, ...]:
    """The modes of a model, by increasing natural frequency.

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel
        Any model with ``A`` and ``C`` (and ``Ts`` for a sampled one).

    Returns
    -------
    tuple of Mode

    Raises
    ------
    DataError
        A model without states, or a sampled model with a pole at z = 0 (it has no
        continuous equivalent: a pure delay, not a mode).

    Examples
    --------
    >>> import numpy as np, moli
    >>> A = np.array([[-0.1, 10.0], [-10.0, -0.1]])
    >>> model = moli.ContinuousModel(A, np.eye(2)[:, :1], np.eye(2), np.zeros((2, 1)), ("y1", "y2"), ("u1",),
    ...                              np.zeros(2), np.zeros(1), (0.0,))
    >>> (mode,) = moli.modes(model)
    >>> round(mode.natural_frequency, 6), round(mode.damping, 6)      # |-0.1 + 10j|, 0.1 / |.|
    (10.0005, 0.01)
    """
    if not all(hasattr(model, name) for name in ("A", "B", "C")):
        raise DataError(f"modes takes a model (StateSpaceModel or ContinuousModel), got {type(model).__name__}"
                        + ("; pass its .model" if hasattr(model, "model") else ""))
    A, C = np.asarray(model.A, float), np.asarray(model.C, float)
    if A.shape[0] == 0:
        raise DataError("the model has no states, hence no modes")
    eigenvalues, vectors = np.linalg.eig(A)
    lefts = np.linalg.inv(vectors).conj().T            # w_i^H A = lambda_i w_i^H, w_i^H v_i = 1
    values = eigenvalues                               # continuous-time equivalents, below for a sampled model
    Ts = getattr(model, "Ts", None)
    if Ts is not None:
        if np.any(np.abs(eigenvalues) == 0):
            raise DataError("the sampled model has a pole at z = 0 (a pure delay): it has no continuous-time "
                            "equivalent; convert the delay states out (model.delays_as_states) or drop them")
        values = np.log(eigenvalues.astype(complex)) / Ts
    found = []
    for index, (value, vector, left) in enumerate(zip(values, vectors.T, lefts.T)):
        scale = abs(value)
        oscillatory = value.imag > REAL_POLE * scale
        if value.imag < -REAL_POLE * scale:
            continue                                    # the pair is reported once, by its upper pole
        shape = C @ vector
        reference = int(np.argmax(np.abs(shape))) if shape.size else 0
        shape_spreads = _shape_spreads(model, index, eigenvalues, vectors, lefts, shape=shape, reference=reference) \
            if shape.size and np.any(shape) else (None, None)
        largest = shape[reference] if shape.size and np.any(shape) else 1.0
        shape = shape / largest
        pole = complex(value) if oscillatory else complex(value.real, 0.0)
        damping = -pole.real / scale if scale > 0 else float("nan")
        spreads = _spreads(model, complex(value), vector, left, Ts)
        found.append(Mode(pole, float(scale), float(scale / (2 * np.pi)), float(damping), shape, bool(oscillatory),
                          *spreads, *shape_spreads))
    return tuple(sorted(found, key=lambda mode: mode.natural_frequency))
