"""The output-error problem of a MOLI model: residuals and analytic Jacobian in observer-form parameters.

The refinement (:mod:`moli.method.refinement.levenberg_marquardt`) minimizes the weighted simulation error
over the observer-form pieces ``D``, ``B``, ``G`` and the feedthrough (docs/method.md
§12). Every parameter's sensitivity is the response of the model, from one state, to
an input or a simulated output: one block simulation per signal gives those of all
states at once.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ...models.simulation import free_response, simulate_batch, state_responses
from .observer_form import ObserverForm

__all__ = ["OutputErrorProblem"]


class OutputErrorProblem:
    """Residuals and Jacobian of the output-error criterion in observer-form parameters.

    ``through`` leading inputs (all by default) have feedthrough parameters where the
    model has a feedthrough; the others reach the outputs through the state only.
    """

    def __init__(
        self, form: ObserverForm, u: np.ndarray, y: np.ndarray, fit_x0: bool, starts: tuple[int, ...] = (0,),
        through: int | None = None,
    ) -> None:
        self.form = form
        self.through = u.shape[1] if through is None else through
        # each segment is simulated from its own initial state, all of them estimated
        self.bounds = tuple(zip(starts, (*starts[1:], y.shape[0])))
        self.x0_size = form.B.shape[0] * len(starts)
        self.feedthrough = bool(np.any(form.F != 0))
        self.u, self.y = u, y
        self.n, self.p, self.m = form.B.shape[0], y.shape[1], u.shape[1]
        norms = np.linalg.norm(y, axis=0)
        # a constant (zero after centring) output has no scale of its own: unit weight
        self.weights = 1.0 / np.where(norms > 0, norms, 1.0)
        self.fit_x0 = fit_x0
        self.lower = np.tril_indices(self.p, -1)

    def pack(self, form: ObserverForm, x0: np.ndarray) -> np.ndarray:
        parts = [form.D.ravel(), form.B.ravel(), form.G[self.lower]]
        if self.feedthrough:
            parts.append(form.F[:, : self.through].ravel())
        if self.fit_x0:
            parts.append(x0)
        return np.concatenate(parts)

    def unpack(self, theta: np.ndarray) -> tuple[ObserverForm, np.ndarray]:
        n, p, m = self.n, self.p, self.m
        D = theta[: n * p].reshape(n, p)
        B = theta[n * p : n * p + n * m].reshape(n, m)
        G = np.zeros((p, p))
        count = len(self.lower[0])
        G[self.lower] = theta[n * p + n * m : n * p + n * m + count]
        at = n * p + n * m + count
        F = np.zeros((p, m))
        if self.feedthrough:
            F[:, : self.through] = theta[at : at + p * self.through].reshape(p, self.through)
            at += p * self.through
        x0 = theta[at:] if self.fit_x0 else np.zeros(self.x0_size)
        return ObserverForm(self.form.A_D, self.form.C_D, D, B, G, F), x0

    def simulate(self, theta: np.ndarray) -> np.ndarray:
        """The simulated outputs at ``theta``, each segment from its own initial state."""
        form, x0 = self.unpack(theta)
        A, B, C = form.matrices()
        starts = x0.reshape(-1, self.n)
        return np.concatenate([simulate_batch(A[None], B[None], C[None], self.u[a:b], start[None])[0]
                               for (a, b), start in zip(self.bounds, starts)]) + self.u @ form.F.T

    def residual(self, yhat: np.ndarray) -> np.ndarray:
        return ((self.y - yhat) * self.weights).ravel()

    def initial_state_columns(self, theta: np.ndarray) -> np.ndarray:
        """d yhat / d x0, weighted, shape (N p, n segments): the Jacobian's last columns."""
        form, _ = self.unpack(theta)
        A, _, C = form.matrices()
        return (self._free(A, C) * self.weights[None, :, None]).reshape(-1, self.x0_size)

    def _free(self, A: np.ndarray, C: np.ndarray) -> np.ndarray:
        """d yhat / d x0 unweighted, (N, p, n segments): each segment's free response in its own columns."""
        if len(self.bounds) == 1:
            return free_response(A, C, self.y.shape[0])
        free = np.zeros((self.y.shape[0], self.p, self.x0_size))
        for i, (a, b) in enumerate(self.bounds):
            free[a:b, :, i * self.n : (i + 1) * self.n] = free_response(A, C, b - a)
        return free

    def jacobian(self, theta: np.ndarray, yhat: np.ndarray, residual: np.ndarray) -> np.ndarray:
        """``[d yhat / d theta, residual]``, weighted, shape (N p, parameters + 1).

        Built in place, one signal's sensitivities at a time, with the residual as its
        last column: the record-long matrix is the least-squares problem's, held once.
        """
        n, p, m = self.n, self.p, self.m
        form, _ = self.unpack(theta)
        A, _, C = form.matrices()
        yx = yhat - self.u @ form.F.T                   # C x: the part the state produces
        signals = np.concatenate([self.u, yx], axis=1)
        N = self.y.shape[0]
        H = np.linalg.inv(np.eye(p) - form.G)
        pairs = list(zip(*self.lower))
        # columns: D (n p), B (n m), G's lower part, F (p m) with feedthrough, x0 (n per segment)
        at_g = n * p + n * m
        at_f = at_g + len(pairs)
        count = at_f + (p * self.through if self.feedthrough else 0) + (self.x0_size if self.fit_x0 else 0)
        # stored column by column (a view indexed sample, output, column): each column is
        # written in one piece, and LAPACK factors the matrix without reordering it
        augmented = np.empty((count + 1, N, p)).transpose(1, 2, 0)
        if self.fit_x0:
            augmented[:, :, count - self.x0_size : count] = 0.0   # a segment's x0 moves that segment alone
        # the sensitivities restart with the state at each segment (its x0 is a parameter of its own);
        # each piece is weighted as it is written, not the record-long matrix afterwards
        w = self.weights
        for segment, (a, b) in enumerate(self.bounds):
            rows = augmented[a:b]
            for c, S_c in state_responses(A, C, signals[a:b]):
                j = c - m
                for q, (i, jj) in enumerate(pairs):
                    if jj == j:                         # dC x = H e_i (C x)_j, and through D
                        direct = np.outer(yx[a:b, j], H[:, i])
                        rows[:, :, at_g + q] = (direct + np.einsum("tpa,a->tp", S_c, form.D @ H[:, i])) * w
                # weighted as written: B[a, c] (input u_c into state a), or D[a, j] (signal yhat_j into state a)
                np.multiply(S_c, w[:, None], out=rows[:, :, n * p + c : at_g : m] if c < m else rows[:, :, j : n * p : p])
            if self.fit_x0:
                at_x0 = count - self.x0_size + segment * n
                rows[:, :, at_x0 : at_x0 + n] = free_response(A, C, b - a) * w[:, None]
        if self.feedthrough:                       # F[i, j]: u_j straight to y_i, to no other output
            block = augmented[:, :, at_f : at_f + p * self.through]
            block[...] = 0.0
            for i in range(p):
                block[:, i, i * self.through : (i + 1) * self.through] = self.u[:, : self.through] * w[i]
        augmented = augmented.reshape(N * p, count + 1)
        augmented[:, count] = residual
        return augmented

    def radius(self, theta: np.ndarray) -> float:
        """Largest pole modulus of the model at ``theta``: what the refinement keeps below its bound."""
        A, _, _ = self.unpack(theta)[0].matrices()
        return float(np.max(np.abs(np.linalg.eigvals(A)), initial=0.0))

    def model_matrices(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, None]:
        """``(A, B, C, D, K)`` of the model at ``theta`` (no Kalman gain: None)."""
        form, _ = self.unpack(theta)
        A, B, C = form.matrices()
        return A, B, C, form.F, None

    def matrix_changes(self, C: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """First-order changes of ``[A, B, C, D]`` (flattened, row-major) for each row of ``dtheta``.

        ``A = A_D + D_o C``, ``C = (I - G)^-1 C_D``: ``dA = dD_o C + D_o dC``, ``dC = H dG C``
        with ``H = (I - G)^-1``; ``C`` is the model's.
        """
        p = C.shape[0]
        H = scipy.linalg.solve_triangular(np.eye(p) - self.form.G, np.eye(p), lower=True, unit_diagonal=True)
        out = []
        for row in dtheta:
            # the pieces are linear in the parameters: unpacking a direction gives its dD_o, dB, dG, dF
            d, _ = self.unpack(np.concatenate([row, np.zeros(self.x0_size)]))
            dC = H @ d.G @ C
            dA = d.D @ C + self.form.D @ dC
            out.append(np.concatenate([dA.ravel(), d.B.ravel(), dC.ravel(), d.F.ravel()]))
        return np.array(out).reshape(dtheta.shape[0], -1)
