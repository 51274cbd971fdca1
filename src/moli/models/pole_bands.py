"""How far the record supports each pole of a sampled model: its modulus's confidence interval
and its time constant against the record's length.

A pole whose interval reaches the unit circle cannot be told from an integrator by the data,
and one whose time constant is longer than the estimation record was never seen to settle:
a step response drawn out to such a pole's settling shows the model's guess, not the plant.

The interval is first order, from the covariance of the matrices (``cov_factor``, as the bands
of :mod:`moli.models.bands` use it): for a simple eigenvalue ``lambda`` of ``A`` with right and
left eigenvectors ``v`` and ``w``, ``d lambda = w^H dA v / (w^H v)``, and the modulus moves by
``Re(conj(lambda) d lambda) / |lambda|``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import OptionError

__all__ = ["PoleSupport", "pole_support"]


@dataclass(frozen=True)
class PoleSupport:
    """One pole of a sampled model and what the record says of it.

    Attributes
    ----------
    pole : complex
    upper : float
        Upper end of the modulus's confidence interval; NaN without a covariance, or where the
        eigenvalue is repeated and has no first-order interval.
    time_constant : float
        ``-1 / ln|pole|`` in samples; inf at or beyond the unit circle.
    reaches_unit_circle : bool
        The pole or its interval's upper end is on or beyond the unit circle.
    longer_than_record : bool
        The time constant exceeds the estimation record's samples (when given).
    """

    pole: complex
    upper: float
    time_constant: float
    reaches_unit_circle: bool
    longer_than_record: bool

    @property
    def supported(self) -> bool:
        """Neither reaches the unit circle nor outlasts the record."""
        return not (self.reaches_unit_circle or self.longer_than_record)

    def reason(self, record_samples: int | None, confidence: float) -> str:
        """Why the record does not support the pole ("" where it does)."""
        why = []
        if self.longer_than_record:
            why.append(f"time constant {self.time_constant:.0f} samples, longer than the "
                       f"{record_samples}-sample estimation record")
        if self.reaches_unit_circle:
            why.append(f"its {confidence:.0%} interval of the modulus reaches the unit circle "
                       f"({self.upper:.4f})")
        return "; ".join(why)


def pole_support(model: Any, record_samples: int | None = None, confidence: float = 0.95) -> list[PoleSupport]:
    """Each pole of a sampled model with its modulus interval and time constant, slowest first.

    Parameters
    ----------
    model : StateSpaceModel
        Poles are those of ``A``; intervals need ``model.cov_factor`` (NaN without it).
    record_samples : int, optional
        Samples of the estimation record; None: time constants are not compared with it.
    confidence : float, default 0.95

    Returns
    -------
    list of PoleSupport

    Examples
    --------
    >>> import numpy as np
    >>> from moli.models.statespace import StateSpaceModel
    >>> m = StateSpaceModel([[0.999]], [[1.0]], [[1.0]], cov_factor=np.array([[0.002], [0.0], [0.0], [0.0]]))
    >>> [round(s.upper, 5) for s in pole_support(m)]          # 0.999 + 1.96 * 0.002
    [1.00292]
    >>> pole_support(m, record_samples=500)[0].supported
    False
    """
    if isinstance(confidence, bool) or not isinstance(confidence, (int, float)) or not 0 < confidence < 1:
        raise OptionError(f"confidence must be a number strictly between 0 and 1, got {confidence!r}")
    A = np.asarray(model.A, float)
    n = A.shape[0]
    if n == 0:
        return []
    poles, right = np.linalg.eig(A)
    sd = np.full(n, np.nan)
    if model.cov_factor is not None:
        with np.errstate(all="ignore"):
            left = np.linalg.solve(right, np.eye(n)) if np.linalg.cond(right) < 1e8 else None
        if left is not None:            # simple eigenvalues: the first-order interval exists
            directions = np.asarray(model.cov_factor, float)[: n * n].T.reshape(-1, n, n)
            moves = np.einsum("in,knm,mi->ki", left, directions, right)
            with np.errstate(all="ignore"):
                radial = np.real(np.conj(poles) * moves) / np.abs(poles)
            sd = np.sqrt(np.sum(radial ** 2, axis=0))
    import scipy.special  # only when asked

    upper = np.abs(poles) + float(scipy.special.ndtri(0.5 + confidence / 2)) * sd
    radius = np.abs(poles)
    with np.errstate(divide="ignore"):
        constants = np.where(radius >= 1.0, np.inf, -1.0 / np.log(np.maximum(radius, 1e-300)))
    found = [PoleSupport(complex(z), float(top), float(tau), bool(top >= 1.0 or abs(z) >= 1.0),
                         record_samples is not None and bool(tau > record_samples))
             for z, top, tau in zip(poles, upper, constants)]
    return sorted(found, key=lambda s: -s.time_constant)
