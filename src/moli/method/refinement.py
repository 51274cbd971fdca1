"""Output-error refinement of a MOLI model: minimize the simulation error over theta.

The MOLI estimate minimizes a one-step (filtered) equation error. Refinement starts
from it and minimizes the *simulation* error on the estimation record,

    V(theta, x0) = sum_j |y_j - yhat_j(theta, x0)|^2 / |y_j|^2
                   + ridge * sum_k d_k^2 (theta_k - theta0_k)^2,

over the same parameters ``theta`` (the observer-form matrices ``D``, ``B``, the
output coupling ``G`` of docs/method.md §4 and the feedthrough when the model
has one, with the filter ``alpha`` kept), and
optionally the initial state ``x0`` of the estimation record, a nuisance parameter.
``d_k`` is the norm of the ``k``-th Jacobian column at the start, so ``ridge`` is a
fraction of the data term's own curvature and does not depend on the units.

The solver is Levenberg-Marquardt with analytic Jacobians: every parameter's
sensitivity is a convolution of the model's impulse response from one state with an
input or a simulated output, computed for all parameters at once by FFT. A step is
accepted only if it lowers ``V`` *and* keeps every pole inside the circle of radius
``max_radius``, so a stable start stays stable and ``V`` never increases.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator, Sequence

import numpy as np

from ..data.iodata import IOData
from ..errors import DataError, OptionError
from .observer_form import ObserverForm, observer_form
from .row_blocks import column_norms, tall_factor
from ..models.delays import shift_inputs
from ..models.statespace import StateSpaceModel
from ..models.simulation import free_response, simulate_batch

__all__ = ["RefineResult", "refine", "refine_each"]

# Poles may move up to this radius: 1 - 1e-3 keeps time constants below 1000 samples,
# far beyond any record the method is used on, while leaving round-off room.
MAX_RADIUS = 1.0 - 1e-3


@dataclass
class RefineResult:
    """Outcome of :func:`refine`.

    Attributes
    ----------
    model : StateSpaceModel
        Refined model (same indices, alpha, offsets; ``info['refined']`` added).
    x0 : ndarray, shape (n,) or (segments, n)
        Initial state of the estimation record (zero unless estimated); one row per
        segment when the record has several.
    cost_start, cost : float
        ``V`` at the start and at the end (``cost <= cost_start``).
    iterations : int
        Accepted steps.
    rejected_unstable : int
        Proposed steps refused because they left the stability radius.
    """

    model: StateSpaceModel
    x0: np.ndarray
    cost_start: float
    cost: float
    iterations: int
    rejected_unstable: int


def _sensitivities(
    A: np.ndarray, C: np.ndarray, signals: np.ndarray
) -> tuple[np.ndarray, Iterator[tuple[int, np.ndarray]]]:
    """Responses ``C (qI - A)^-1 e_a v`` for every state ``a`` and signal ``v``, one signal at a time.

    Returns the free responses ``C A^t e_a``, (N, p, n), and an iterator of ``(c,
    S_c)``, ``S_c[t, :, a]`` the response to signal ``c`` injected into state ``a``
    (each array valid until the next): the responses to all ``k`` signals at once
    would hold ``N p n k`` values, many times the record's size.
    """
    import scipy.fft  # slow to import: only when refining

    N = signals.shape[0]
    free = free_response(A, C, N)                     # (N, p, n): C A^t
    # any length from 2N - 1 on keeps the circular convolution's first N samples
    # linear; 2N itself can be a slow length (glassfurnace: 2 x 7 x 89)
    size = scipy.fft.next_fast_len(2 * N - 1, real=True)
    H = scipy.fft.rfft(free, size, axis=0)            # (F, p, n)
    V = scipy.fft.rfft(signals, size, axis=0)         # (F, k)

    def responses() -> Iterator[tuple[int, np.ndarray]]:
        # stored with a stride between states, as one signal's slice of all of them
        # at once was: the products below then sum in the same order, to the bit
        buffer = np.zeros(free.shape + (2,))
        for c in range(signals.shape[1]):
            # one-step delay of (qI - A)^-1
            buffer[1:, :, :, 0] = scipy.fft.irfft(H * V[:, c, None, None], size, axis=0)[: N - 1]
            yield c, buffer[:, :, :, 0]

    return free, responses()


class OutputErrorProblem:
    """Residuals and Jacobian of the output-error criterion in observer-form parameters."""

    def __init__(
        self, form: ObserverForm, u: np.ndarray, y: np.ndarray, fit_x0: bool, starts: tuple[int, ...] = (0,)
    ) -> None:
        self.form = form
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
            parts.append(form.F.ravel())
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
            F = theta[at : at + p * m].reshape(p, m)
            at += p * m
        x0 = theta[at:] if self.fit_x0 else np.zeros(self.x0_size)
        return ObserverForm(self.form.A_D, self.form.C_D, D, B, G, F), x0

    def simulate(self, theta: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, ...], np.ndarray]:
        form, x0 = self.unpack(theta)
        A, B, C = form.matrices()
        starts = x0.reshape(-1, self.n)
        yhat = np.concatenate([simulate_batch(A[None], B[None], C[None], self.u[a:b], start[None])[0]
                               for (a, b), start in zip(self.bounds, starts)]) + self.u @ form.F.T
        return yhat, (A, B, C), form.G

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
        count = at_f + (p * m if self.feedthrough else 0) + (self.x0_size if self.fit_x0 else 0)
        augmented = np.empty((N, p, count + 1))
        if self.fit_x0:
            augmented[:, :, count - self.x0_size : count] = 0.0   # a segment's x0 moves that segment alone
        # the sensitivities restart with the state at each segment (its x0 is a parameter of its own)
        for segment, (a, b) in enumerate(self.bounds):
            free, responses = _sensitivities(A, C, signals[a:b])
            rows = augmented[a:b]
            for c, S_c in responses:
                if c < m:                               # B[a, c]: input u_c into state a
                    rows[:, :, n * p + c : at_g : m] = S_c
                    continue
                j = c - m
                rows[:, :, j : n * p : p] = S_c         # D[a, j]: signal yhat_j into state a
                for q, (i, jj) in enumerate(pairs):
                    if jj == j:                         # dC x = H e_i (C x)_j, and through D
                        direct = np.outer(yx[a:b, j], H[:, i])
                        rows[:, :, at_g + q] = direct + np.einsum("tpa,a->tp", S_c, form.D @ H[:, i])
            if self.fit_x0:
                at_x0 = count - self.x0_size + segment * n
                rows[:, :, at_x0 : at_x0 + n] = free
        if self.feedthrough:                       # F[i, j]: u_j straight to y_i
            eye = np.eye(p)
            for i in range(p):                     # one output at a time: N p m values, not N p p m
                augmented[:, i, at_f : at_f + p * m] = (eye[i, None, :, None] * self.u[:, None, :]).reshape(N, p * m)
        augmented[:, :, :count] *= self.weights[None, :, None]
        augmented = augmented.reshape(N * p, count + 1)
        augmented[:, count] = residual
        return augmented


def refine(
    model: StateSpaceModel,
    data: IOData,
    *,
    iterations: int = 10,
    ridge: float = 0.0,
    fit_x0: bool = True,
    max_radius: float = MAX_RADIUS,
    tolerance: float = 1e-4,
) -> RefineResult:
    """Minimize the simulation error of a MOLI model on its estimation data.

    Parameters
    ----------
    model : StateSpaceModel
        Start, e.g. ``moli.estimate(...)`` or ``identify(...).model``; must carry
        ``indices`` and ``alpha``. Must be stable (an unstable start is returned
        unchanged, with zero iterations).
    data : IOData
        Estimation record, centred like the data the model was estimated on. Each of
        its segments is simulated from its own initial state.
    iterations : int, default 10
        Most Levenberg-Marquardt steps to accept (few steps act as early stopping).
    ridge : float, default 0.0
        Weight of the penalty toward the start, relative to each parameter's
        curvature in the data term (0: free refinement).
    fit_x0 : bool, default True
        Estimate the initial state of the estimation record jointly.
    max_radius : float, default 1 - 1e-3
        Steps that move a pole to this radius or beyond are refused.
    tolerance : float, default 1e-4
        Stop when a step lowers ``V`` by less than this fraction.

    Returns
    -------
    RefineResult

    Examples
    --------
    >>> import numpy as np, moli
    >>> from moli.method.refinement import refine
    >>> est, _ = moli.example_data(N=600, seed=1).split(400)
    >>> est = est.remove_means()
    >>> start = moli.estimate(est, [2, 1, 1], moli.filter_polynomial(0.5, 0.8, [2, 1, 1]))
    >>> result = refine(start, est)
    >>> bool(result.cost <= result.cost_start)
    True
    """
    return refine_each(model, data, (ridge,), iterations=iterations, fit_x0=fit_x0,
                       max_radius=max_radius, tolerance=tolerance)[0]


def refine_each(
    model: StateSpaceModel,
    data: IOData,
    ridges: Sequence[float],
    *,
    iterations: int = 10,
    fit_x0: bool = True,
    max_radius: float = MAX_RADIUS,
    tolerance: float = 1e-4,
) -> list[RefineResult]:
    """:func:`refine` of one start with each of several ridges.

    Each result is the one :func:`refine` gives with that ridge, to the bit; the work
    they share (the start's simulation, its initial state, its Jacobian and that
    Jacobian's triangular factor) is done once.

    Parameters
    ----------
    model, data, iterations, fit_x0, max_radius, tolerance
        As in :func:`refine`.
    ridges : sequence of float
        The ridges, at least one.

    Returns
    -------
    list of RefineResult
        One per ridge, in order.
    """
    if int(iterations) != iterations or iterations < 0:
        raise OptionError(f"iterations must be a non-negative integer, got {iterations!r}")
    ridges = tuple(ridges)
    if not ridges or not all(np.isfinite(r) and r >= 0 for r in ridges):
        raise OptionError(f"each ridge must be a non-negative number, and one at least; got {ridges!r}")
    if not 0 < max_radius <= 1:
        raise OptionError(f"max_radius must be in (0, 1], got {max_radius!r}")
    if (data.p, data.m) != (model.p, model.m):
        raise DataError(f"model has {model.p} outputs and {model.m} inputs, data {data.p} and {data.m}")
    start = RefinementStart(model, data, fit_x0, max_radius)
    return [start.descend(ridge, iterations, tolerance) for ridge in ridges]


class RefinementStart:
    """The start of a refinement, shared by the ridges refined from it (and by the
    covariance of a refined model, taken at its own matrices)."""

    def __init__(self, model: StateSpaceModel, data: IOData, fit_x0: bool, max_radius: float) -> None:
        self.model, self.data, self.fit_x0, self.max_radius = model, data, fit_x0, max_radius
        form = observer_form(model)
        # a model with input delays is refined on the inputs as its simulation shifts them
        # each segment from its own initial state, its inputs shifted within it
        u = np.concatenate([shift_inputs(data.u[a:b], model.input_delays) for a, b in data.bounds])
        problem = self.problem = OutputErrorProblem(form, u, data.y, fit_x0, data.segment_starts)
        self.theta0 = problem.pack(form, np.zeros(problem.x0_size))
        theta = self.theta0.copy()
        yhat, _, _ = problem.simulate(theta)
        residual = problem.residual(yhat)
        self.stable = bool(np.max(np.abs(model.poles()), initial=0.0) < max_radius)
        if fit_x0 and self.stable:
            # start from the best initial state for the start model (a linear problem)
            theta[-problem.x0_size :] = np.linalg.lstsq(problem.initial_state_columns(theta), residual, rcond=None)[0]
            yhat, _, _ = problem.simulate(theta)
            residual = problem.residual(yhat)
        self.theta, self.yhat, self.residual = theta, yhat, residual
        self.cost = float(residual @ residual)
        self._linearized: tuple[np.ndarray, np.ndarray | None] | None = None

    def linearize(self, theta: np.ndarray, yhat: np.ndarray, residual: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """The Jacobian's column norms and the triangular factor ``T`` of ``[jac, residual]``
        (None where either is not finite), once at the start for every ridge.

        ``|jac s - residual| = |T[:, :-1] s - T[:, -1]|``: each damping tried solves a
        problem of the parameters' size instead of the record's.
        """
        at_start = theta is self.theta
        if at_start and self._linearized is not None:
            return self._linearized
        augmented = self.problem.jacobian(theta, yhat, residual)
        jac = augmented[:, :-1]
        norms = column_norms(jac)
        norms[norms == 0] = 1.0
        finite = bool(np.all(np.isfinite(jac)) and np.all(np.isfinite(residual)))
        linearized = norms, (tall_factor(augmented) if finite else None)
        if at_start:
            self._linearized = linearized
        return linearized

    def descend(self, ridge: float, iterations: int, tolerance: float) -> RefineResult:
        """Levenberg-Marquardt steps from the start with this ridge."""
        problem, theta0, model, data = self.problem, self.theta0, self.model, self.data
        theta, yhat, residual = self.theta, self.yhat, self.residual
        scale = None
        penalty = np.sqrt(ridge)

        def total(res: np.ndarray, th: np.ndarray) -> float:
            extra = 0.0 if scale is None or ridge == 0 else float(np.sum((penalty * scale * (th - theta0)) ** 2))
            return float(res @ res) + extra

        cost = cost_start = self.cost
        accepted = rejected = 0
        damping = 1e-3
        while self.stable and accepted < iterations:
            norms, reduced = self.linearize(theta, yhat, residual)
            if scale is None:
                scale = norms.copy()
                if self.fit_x0:
                    scale[-problem.x0_size :] = 0.0     # x0 is a nuisance parameter: not penalised
            if reduced is None:
                break                           # nothing sound to step along: keep what we have
            improved = False
            while damping < 1e8:
                # solved for the step in units of each column's norm: the parameters'
                # scales (the record's units) then leave the solution unchanged, where
                # lstsq's rank cut-off on the raw columns would drop the small ones
                rows = [reduced[:, :-1] / norms, np.sqrt(damping) * np.eye(theta.size)]
                rhs = [reduced[:, -1], np.zeros(theta.size)]
                if ridge > 0:
                    rows.append(np.diag(penalty * scale / norms))
                    rhs.append(-penalty * scale * (theta - theta0))
                step = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0] / norms
                trial = theta + step
                new_yhat, (A, _, _), _ = problem.simulate(trial)
                if np.max(np.abs(np.linalg.eigvals(A))) >= self.max_radius:
                    rejected += 1
                    damping *= 10
                    continue
                new_res = problem.residual(new_yhat)
                new_cost = total(new_res, trial)
                if np.isfinite(new_cost) and new_cost < cost:
                    gain = (cost - new_cost) / cost
                    theta, yhat, residual, cost = trial, new_yhat, new_res, new_cost
                    damping = max(damping / 10, 1e-9)
                    improved = True
                    accepted += 1
                    break
                damping *= 10
            if not improved or gain < tolerance:
                break
        form_end, x0 = problem.unpack(theta)
        A, B, C = form_end.matrices()
        F = form_end.F
        if accepted == 0:  # nothing accepted: keep the start's matrices bit for bit
            A, B, C, F = model.A, model.B, model.C, model.D
        info = dict(model.info)
        info.update({"refined": True, "refine_iterations": accepted, "refine_ridge": ridge,
                     "refine_cost_start": cost_start, "refine_cost": cost})
        refined = model.with_matrices(A, B, C, F, info, model.divisors)
        return RefineResult(refined, x0 if data.n_segments == 1 else x0.reshape(data.n_segments, -1),
                            cost_start, cost, accepted, rejected)
