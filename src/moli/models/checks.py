"""Checks of what a state-space model is built from: matrices, covariances, filters."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..data.arguments import integer, name_list, real_array
from ..errors import DataError

__all__ = ["matrix", "covariance", "checked_divisors", "channel_names", "stored_names", "indices_of",
           "vector", "time_delays", "Dimensions"]

# A value quoted in a message about a model file is cut to this many characters.
QUOTED_CHARS = 60


def matrix(name: str, value: object, shape: tuple[int, int] | None = None) -> np.ndarray:
    array = np.array(real_array(name, value, finite=False), ndmin=2)
    if array.ndim != 2 or not np.all(np.isfinite(array)):
        raise DataError(f"{name} must be a finite 2-D matrix, got shape {array.shape}")
    if shape is not None and array.shape != shape:
        raise DataError(f"{name} must have shape {shape}, got {array.shape}")
    return array


def channel_names(given: Sequence[str] | None, count: int, prefix: str, what: str) -> tuple[str, ...]:
    """``given`` checked as ``count`` distinct names, or ``prefix1, prefix2, ...``."""
    if given is None:
        return tuple(f"{prefix}{i + 1}" for i in range(count))
    return name_list(what, given, count)


def _quoted(value: object) -> str:
    text = repr(value)
    return text if len(text) <= QUOTED_CHARS else text[:QUOTED_CHARS] + "..."


def stored_names(what: str, value: object, count: int) -> tuple[str, ...]:
    """Channel names as a model file holds them: a list of ``count`` distinct strings.

    Stricter than :func:`channel_names`, which takes any sequence and turns numbers into
    text: in a file, one string would be read as its characters and a number is a
    spoiled field, not a name.
    """
    if not isinstance(value, list) or not all(isinstance(name, str) for name in value):
        raise DataError(f"{what} must be a list of {count} names (distinct strings), got {_quoted(value)}")
    return name_list(what, value, count)


def time_delays(value: object, m: int) -> tuple[float, ...]:
    """The dead time of each of ``m`` inputs of a continuous model: finite, non-negative."""
    delays = real_array("input_delays", value, ndim=1, finite=False)
    if delays.size != m:
        raise DataError(f"input_delays must have {m} entries (one per input), got {_quoted(value)}")
    if not np.all(np.isfinite(delays) & (delays >= 0)):
        raise DataError(f"input_delays must be finite and non-negative (time units), got {_quoted(value)}")
    return tuple(float(d) for d in delays)


def indices_of(given: object) -> tuple[int, ...] | None:
    """A list of observability indices: positive integers, or None."""
    if given is None:
        return None
    if isinstance(given, (str, bytes)) or not isinstance(given, (list, tuple, np.ndarray)):
        raise DataError(f"indices must be a list of positive integers, got {given!r}")
    return tuple(integer("indices", v, low=1) for v in given)


def vector(name: str, value: object | None, count: int) -> np.ndarray:
    """A finite float vector of ``count`` entries (zeros when None)."""
    if value is None:
        return np.zeros(count)
    array = real_array(name, value)
    if array.size != count:
        raise DataError(f"{name} must have {count} entries (one per channel), got shape {array.shape}")
    return array.reshape(count)


def covariance(value: object, p: int) -> np.ndarray:
    array = matrix("noise_cov", value, (p, p))
    scale = float(np.max(np.abs(array), initial=0.0))
    # round-off tolerances: a covariance computed as E^T E / N is symmetric and PSD to
    # a few ulps of its largest entry
    if not np.allclose(array, array.T, rtol=0.0, atol=1e-12 * scale) or \
            np.min(np.linalg.eigvalsh(array), initial=0.0) < -1e-10 * scale:
        raise DataError("noise_cov must be symmetric positive semidefinite")
    return array


def checked_divisors(given: Sequence[Sequence[float]], indices: tuple[int, ...] | None,
                     p: int) -> tuple[np.ndarray, ...]:
    """Per-output filter polynomials: one per output, monic, stable, of degree ``indices[j]``."""
    if indices is None or len(given) != len(indices) or len(indices) != p:
        raise DataError(f"divisors need the model's indices, one divisor per output ({p})")
    checked = []
    for j, (coeffs, l) in enumerate(zip(given, indices)):
        alpha_j = matrix(f"divisor of output {j + 1}", coeffs).ravel()
        if alpha_j.size - 1 != l or alpha_j[0] != 1.0:
            raise DataError(f"divisor of output {j + 1} must be monic of degree {l}, got {alpha_j.tolist()}")
        if np.max(np.abs(np.roots(alpha_j))) >= 1.0:
            raise DataError(f"divisor of output {j + 1} must be stable (roots strictly inside the unit circle)")
        checked.append(alpha_j)
    return tuple(checked)


class Dimensions:
    """``n``, ``p`` and ``m`` of a model that holds ``A``, ``B`` and ``C``."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray

    @property
    def n(self) -> int:
        """Order (number of states)."""
        return self.A.shape[0]

    @property
    def p(self) -> int:
        """Number of outputs."""
        return self.C.shape[0]

    @property
    def m(self) -> int:
        """Number of inputs."""
        return self.B.shape[1]
