"""The refinement's parameters: A in real modal form, B, C and D free.

``A`` is block diagonal: each complex pair of poles ``sigma ± j omega`` a block
``[[sigma, omega], [-omega, sigma]]`` (states ``2i, 2i + 1``), each real pole ``lambda`` a
1 x 1 block after the pairs. The poles are then the parameters themselves (their
conditioning is that of the poles, not of a polynomial's coefficients), stability is a
bound on each block, and the resolvent is analytic block by block. ``theta`` is
``[sigma (pairs), omega (pairs), lambda (reals), B, C, D]`` (matrices row by row; ``D``
only with a feedthrough). Each block's similarities that keep its form (a complex scalar
on a pair, a real one on a real pole) change ``B`` and ``C`` but not ``G``: the Jacobian
has ``2 pairs + reals`` null directions (:attr:`ModalLayout.gauge`), which the
Levenberg-Marquardt damping and the covariance's pseudo-inverse leave out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...models.modal import REAL_POLE

__all__ = ["ModalLayout", "modal_parameters", "split", "matrices", "matrix_jacobian", "is_stable", "reflected"]

# Eigenvector bases worse conditioned than this (a defective A, two poles merging) give no modal form.
MAX_CONDITION = 1e12


@dataclass(frozen=True)
class ModalLayout:
    """How ``theta`` is laid out: ``pairs`` complex pairs, ``reals`` real poles, ``p`` outputs, ``m`` inputs."""

    pairs: int
    reals: int
    p: int
    m: int
    feedthrough: bool

    @property
    def n(self) -> int:
        return 2 * self.pairs + self.reals

    @property
    def poles(self) -> int:
        """Entries of theta that set A."""
        return 2 * self.pairs + self.reals

    @property
    def size(self) -> int:
        return self.poles + self.n * self.m + self.p * self.n + (self.p * self.m if self.feedthrough else 0)

    @property
    def gauge(self) -> int:
        """Directions of theta along which the response does not change."""
        return 2 * self.pairs + self.reals


def modal_parameters(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray,
                     feedthrough: bool) -> tuple[ModalLayout, np.ndarray] | None:
    """``(layout, theta)`` of the model in modal form; None where A has no well-conditioned eigenbasis."""
    values, vectors = np.linalg.eig(A)
    oscillating = values.imag > REAL_POLE * np.abs(values)
    real = np.abs(values.imag) <= REAL_POLE * np.abs(values)
    if 2 * oscillating.sum() + real.sum() != A.shape[0]:
        return None
    upper, lower = values[oscillating], vectors[:, oscillating]
    order = np.argsort(np.abs(upper))
    upper, lower = upper[order], lower[:, order]
    singles, single_vectors = values[real].real, vectors[:, real]
    # a real eigenvector may come back times a complex phase: turn its largest entry real
    largest = single_vectors[np.argmax(np.abs(single_vectors), axis=0), np.arange(singles.size)]
    single_vectors = (single_vectors * (np.abs(largest) / largest)).real
    order = np.argsort(np.abs(singles))
    singles, single_vectors = singles[order], single_vectors[:, order]
    basis = np.concatenate([np.stack([lower.real, lower.imag], axis=2).reshape(A.shape[0], -1), single_vectors],
                           axis=1)
    if basis.size and np.linalg.cond(basis) > MAX_CONDITION:
        return None
    # A [vr, vi] = [vr, vi] [[sigma, omega], [-omega, sigma]] for A (vr + j vi) = (sigma + j omega)(vr + j vi)
    Bm, Cm = np.linalg.solve(basis, B) if basis.size else B, C @ basis
    # each mode's share of the gain split evenly between B and C: comparable scales in theta
    for start, stop in _blocks(upper.size, singles.size):
        inward, outward = np.linalg.norm(Bm[start:stop]), np.linalg.norm(Cm[:, start:stop])
        if inward > 0 and outward > 0:
            scale = np.sqrt(outward / inward)
            Bm[start:stop] *= scale
            Cm[:, start:stop] /= scale
    layout = ModalLayout(upper.size, singles.size, C.shape[0], B.shape[1], feedthrough)
    theta = np.concatenate([upper.real, upper.imag, singles, Bm.ravel(), Cm.ravel(),
                            D.ravel() if feedthrough else []])
    return layout, theta


def _blocks(pairs: int, reals: int) -> list[tuple[int, int]]:
    return [(2 * i, 2 * i + 2) for i in range(pairs)] + [(2 * pairs + i, 2 * pairs + i + 1) for i in range(reals)]


def split(layout: ModalLayout, theta: np.ndarray) -> tuple[np.ndarray, ...]:
    """``sigma, omega, lambda, B, C, D`` from ``theta``."""
    c, r, n, p, m = layout.pairs, layout.reals, layout.n, layout.p, layout.m
    ends = np.cumsum([c, c, r, n * m, p * n])
    sigma, omega, lam, B, C, D = np.split(theta, ends)
    return (sigma, omega, lam, B.reshape(n, m), C.reshape(p, n),
            D.reshape(p, m) if layout.feedthrough else np.zeros((p, m)))


def matrices(layout: ModalLayout, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``A, B, C, D`` of ``theta``."""
    sigma, omega, lam, B, C, D = split(layout, theta)
    A = np.zeros((layout.n, layout.n))
    i = np.arange(layout.pairs)
    A[2 * i, 2 * i] = A[2 * i + 1, 2 * i + 1] = sigma
    A[2 * i, 2 * i + 1], A[2 * i + 1, 2 * i] = omega, -omega
    j = 2 * layout.pairs + np.arange(layout.reals)
    A[j, j] = lam
    return A, B.copy(), C.copy(), D.copy()


def matrix_jacobian(layout: ModalLayout) -> np.ndarray:
    """``d vec[A, B, C, D] / d theta``, shape (n n + n m + p n + p m, size): constant, A linear in theta."""
    n, p, m, c = layout.n, layout.p, layout.m, layout.pairs
    rows = n * n + n * m + p * n + p * m
    out = np.zeros((rows, layout.size))
    i = np.arange(c)
    out[(2 * i) * n + 2 * i, i] = out[(2 * i + 1) * n + 2 * i + 1, i] = 1.0        # sigma
    out[(2 * i) * n + 2 * i + 1, c + i] = 1.0                                       # omega
    out[(2 * i + 1) * n + 2 * i, c + i] = -1.0
    j = 2 * c + np.arange(layout.reals)
    out[j * n + j, 2 * c + np.arange(layout.reals)] = 1.0                           # lambda
    free = n * m + p * n
    out[n * n: n * n + free, layout.poles: layout.poles + free] = np.eye(free)
    if layout.feedthrough:
        out[n * n + free:, layout.poles + free:] = np.eye(p * m)
    return out


def is_stable(layout: ModalLayout, theta: np.ndarray, continuous: bool, radius: float | None) -> bool:
    """Every pole in the open left half-plane (continuous) or inside ``radius`` (discrete); True without a bound."""
    if radius is None:
        return True
    sigma, omega, lam = split(layout, theta)[:3]
    if continuous:
        return bool(np.all(sigma < 0) and np.all(lam < 0))
    return bool(np.all(sigma**2 + omega**2 < radius**2) and np.all(np.abs(lam) < radius))


def reflected(layout: ModalLayout, theta: np.ndarray, continuous: bool, radius: float) -> np.ndarray:
    """``theta`` with each pole outside the stable region mirrored into it (``-conj(s)``, ``radius^2 / conj(z)``).

    A pole on the boundary moves inside by a millionth of its modulus (the data cannot
    tell it from one just inside).
    """
    theta = theta.copy()
    c, r = layout.pairs, layout.reals
    sigma, omega, lam = theta[:c], theta[c:2 * c], theta[2 * c:2 * c + r]
    if continuous:
        sigma[:] = -np.maximum(np.abs(sigma), 1e-6 * np.hypot(sigma, omega))
        lam[:] = -np.maximum(np.abs(lam), 1e-300)
        return theta
    inside = radius * (1 - 1e-6)
    modulus = np.maximum(np.hypot(sigma, omega), 1e-300)
    scale = np.where(modulus >= inside, np.minimum(radius**2 / modulus**2, inside / modulus), 1.0)
    sigma *= scale
    omega *= scale
    lam[:] = np.where(np.abs(lam) >= inside, np.sign(lam) * np.minimum(radius**2 / np.abs(lam).clip(1e-300), inside),
                      lam)
    return theta
