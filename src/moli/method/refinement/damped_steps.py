"""Levenberg-Marquardt's damped steps from one linearization: normal equations, QR where they are unsafe.

At each linearization the refinement tries steps of several dampings ``d``; each solves

    min |J_s s - r|^2 + d |s|^2 + |W s - c|^2

for the step ``s`` in units of each Jacobian column's norm (``J_s`` has unit columns; ``W``
diagonal, the ridge's penalty toward the start, absent for a free refinement). Its normal
equations ``(J_s^T J_s + d I + W^2) s = J_s^T r + W c`` need only the Gram matrix of
``[J_s, r]``, one symmetric product of the record-long matrix, where a QR of that matrix costs
two to three times as much (docs/performance.md).

Why the normal equations are safe here although the Jacobians are not well conditioned
(their scaled condition numbers run from 1e11 to 1e16 on the DaISy records): the damping
bounds the system's smallest eigenvalue below by ``d``, and the columns' unit norms bound its
largest by the number of columns ``k``, whatever ``J_s`` is. What remains is the round-off of
the Gram matrix itself, at most about ``rows * eps`` in each entry (sums of ``rows`` products of
unit-norm columns), which moves the solution by at most that over ``d``, relatively.
:data:`GRAM_ROUNDOFF_SHARE` keeps that below one part in a thousand; a damping smaller than
that allows (a record of over about 4500 rows per parameter at the damping floor) takes the
QR of ``[J_s, r]`` instead, computed once per linearization when first needed. Every step is
then accepted only where it lowers the criterion, as before.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ...numerics.triangular import column_norms, tall_factor

__all__ = ["Linearization", "GRAM_ROUNDOFF_SHARE"]

# Largest relative change of a step that the Gram matrix's round-off may cause: the bound
# rows * eps / damping must stay under it, else the step is solved from a QR.
GRAM_ROUNDOFF_SHARE = 1e-3


class Linearization:
    """The Jacobian ``J`` and residual ``r`` of one refinement iterate, reduced to what the damped steps need.

    Parameters
    ----------
    augmented : ndarray, shape (rows, k + 1)
        ``[J, r]``: the Jacobian and the residual as its last column. Kept (not copied)
        only where a damping of ``floor`` or more may need its QR.
    floor : float
        The smallest damping any step will be tried with.

    Attributes
    ----------
    norms : ndarray, shape (k,)
        The Jacobian's column norms (a zero column counts as one).
    finite : bool
        Whether ``J`` and ``r`` are finite; a step is solved only from a finite one.
    """

    def __init__(self, augmented: np.ndarray, floor: float) -> None:
        k = augmented.shape[1] - 1
        # one symmetric product (BLAS syrk for a matrix times its own transpose); a NaN or
        # infinity anywhere in [J, r] reaches the Gram matrix, and its diagonal holds the
        # columns' squared norms
        gram = augmented.T @ augmented
        self.finite = bool(np.all(np.isfinite(gram)))
        self.norms = np.sqrt(np.diag(gram)[:k]) if self.finite else column_norms(augmented[:, :k])
        self.norms[self.norms == 0] = 1.0
        self.rows = augmented.shape[0]
        self._augmented = None if self.uses_normal_equations(floor) else augmented
        self._factor: np.ndarray | None = None
        scaled = np.concatenate([self.norms, [1.0]])
        self.gram = gram / np.outer(scaled, scaled)

    def uses_normal_equations(self, damping: float) -> bool:
        """Whether a step of this damping is solved from the Gram matrix (else from a QR)."""
        return self.rows * np.finfo(float).eps <= GRAM_ROUNDOFF_SHARE * damping

    def step(self, damping: float, penalty: np.ndarray | None = None,
             target: np.ndarray | None = None) -> np.ndarray | None:
        """The damped step ``s`` in units of the column norms (divide by :attr:`norms` for ``theta``'s);
        None where the damping is too small for the normal equations to be positive definite
        to round-off and no QR is at hand (the bound above says it is not: the caller raises
        the damping, as for a step it refuses).

        Parameters
        ----------
        damping : float
            ``d``, at least the refinement's damping floor.
        penalty, target : ndarray, shape (k,), optional
            ``W``'s diagonal and ``c``: the ridge's rows ``W s = c`` (both or neither).
        """
        assert self.finite, "no step from a linearization that is not finite"
        k = self.norms.size
        if self.uses_normal_equations(damping):
            gram = self.gram
            system = gram[:k, :k] + damping * np.eye(k)
            rhs = gram[:k, k].copy()
            if penalty is not None:
                system[np.diag_indices(k)] += penalty ** 2
                rhs += penalty * target
            try:
                return scipy.linalg.cho_solve(scipy.linalg.cho_factor(system, check_finite=False), rhs,
                                              check_finite=False)
            except np.linalg.LinAlgError:
                if self._augmented is None:
                    return None
        return self._qr_step(damping, penalty, target)

    def _qr_step(self, damping: float, penalty: np.ndarray | None, target: np.ndarray | None) -> np.ndarray:
        """The same step from the triangular factor of ``[J, r]`` (computed once)."""
        k = self.norms.size
        if self._factor is None:
            self._factor = tall_factor(self._augmented)
        reduced = self._factor
        rows = [reduced[:, :-1] / self.norms, np.sqrt(damping) * np.eye(k)]
        rhs = [reduced[:, -1], np.zeros(k)]
        if penalty is not None:
            rows.append(np.diag(penalty))
            rhs.append(target)
        return _damped_solution(np.vstack(rows), np.concatenate(rhs))


def _damped_solution(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Least-squares solution of a damped step's problem, by QR.

    Its columns have norm at most one and its damping rows ``sqrt(damping) I`` keep its
    smallest singular value at ``sqrt(damping)`` or above, so the triangular factor is
    regular and a QR gives the solution an SVD would, at a fraction of the cost.
    """
    k = matrix.shape[1]
    factor = tall_factor(np.column_stack([matrix, rhs]))
    return scipy.linalg.solve_triangular(factor[:k, :k], factor[:k, k])
