"""What every moli model answers, sampled or continuous: the protocol the later layers use.

:func:`moli.compare`, :func:`moli.predict`, :func:`moli.residual_analysis`,
:func:`moli.simulation_bands`, the bands and the command line take a
:class:`~moli.models.statespace.StateSpaceModel` and a
:class:`~moli.models.continuous.ContinuousModel` alike through the members listed in
:class:`LinearModel`; what differs between the two time domains lives in the two classes.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

from ..errors import DataError

__all__ = ["LinearModel", "check_model"]


@runtime_checkable
class LinearModel(Protocol):
    """A linear model on deviations from its operating point ``(u_offset, y_offset)``.

    Attributes
    ----------
    is_continuous : bool
        True for ``x' = A x + B u`` (time stamps), False for ``x[k+1] = A x[k] + B u[k]``.
    Ts : float or None
        The sampling period; None in continuous time (any stamps).
    A, B, C, D, cov_factor, K
        The matrices, their covariance factor (or None) and the Kalman gain (None
        without a noise model, always in continuous time).
    output_names, input_names, y_offset, u_offset, input_delays, info
    """

    is_continuous: bool
    Ts: float | None
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    cov_factor: np.ndarray | None
    K: np.ndarray | None
    output_names: tuple[str, ...]
    input_names: tuple[str, ...]
    y_offset: np.ndarray
    u_offset: np.ndarray
    input_delays: tuple[Any, ...]
    info: dict[str, Any]

    @property
    def n(self) -> int: ...

    @property
    def p(self) -> int: ...

    @property
    def m(self) -> int: ...

    def simulate_at(self, u: np.ndarray, t: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
        """Outputs (N, p) of one segment: input deviations ``u`` (N, m) at the stamps ``t`` from ``x0``."""

    def free_response_at(self, t: np.ndarray, negligible: float | None = None) -> np.ndarray:
        """Outputs (N, p, n) at the stamps ``t`` from each unit initial state, no input."""

    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A``: z-plane when sampled, s-plane in continuous time."""

    def is_stable(self) -> bool:
        """All poles inside the unit circle, or in the open left half-plane."""

    def frequency_response(self, omega: object) -> np.ndarray:
        """Complex responses (F, p, m) at ``omega`` rad per time unit."""

    def magnitude_bands(self, omega: object, confidence: float = 0.95, **options: Any) -> tuple[np.ndarray, np.ndarray]:
        """Pointwise bands of the gain at ``omega``."""

    def save(self, path: Any) -> None:
        """Write the model file."""


def check_model(model: object, what: str = "model") -> LinearModel:
    """``model`` when it answers the protocol, else a :class:`DataError` naming what it is.

    Examples
    --------
    >>> import moli
    >>> check_model(moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]])).is_continuous
    False
    >>> check_model("model.json")
    Traceback (most recent call last):
    moli.errors.DataError: model must be a StateSpaceModel or a ContinuousModel (moli.load_model reads a model file), got str
    """
    if not isinstance(model, LinearModel):
        raise DataError(f"{what} must be a StateSpaceModel or a ContinuousModel (moli.load_model reads a "
                        f"model file), got {type(model).__name__}")
    return model
