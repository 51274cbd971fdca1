"""Zero-order oracle filter tuning (ZOFT): barycenter search over eta = (wc, zeta).

``J(eta)`` is the paper's criterion: estimate with the filter ``alpha(eta)``,
simulate the model from the zero state on the estimation inputs, and average
``min(var(y_i - yhat_i)/var(y_i), 1)`` over the outputs. Candidates are scored in
batches (one least-squares batch per output, one batched simulation).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import scipy.linalg
import scipy.linalg.lapack
import scipy.stats
from numpy.lib.stride_tricks import as_strided
from scipy.signal import lfilter

from .errors import OptionError
from .estimation import _observer_form, fit_batch, realize, solve_batch
from .filters import _needs_real, filter_divisors, filter_rows
from .simulation import simulate_batch
from .structure import Indices
from .validation import X0_CHOICES

TUNING_METHODS = ("grid", "random", "zoom")
# Highest degree of the error trend J may ignore: beyond a few terms the polynomials
# reach the plant's own frequencies on short records.
MAX_TREND_DEGREE = 5
FEEDTHROUGH_CHOICES = (False, True, "auto")
# Significance level of the "auto" feedthrough test. Strict, because the equation
# errors are coloured and the nominal F distribution then overstates significance.
FEEDTHROUGH_LEVEL = 1e-3
# The paper's weight: mu = 40 / min J, i.e. a candidate whose J is 10 % above the
# best weighs exp(-4) ~ 2 % of it.
MU_SCALE = 40.0
# The paper's evaporator grid (T = 1): wc = 0.02*pi ... 0.3548*pi, log-spaced.
PAPER_ZETAS = (0.6, 0.7, 1.1)
PAPER_WCS_PER_TS = tuple(0.02 * np.pi * 10 ** (0.25 * k) for k in range(6))
# Lists scored together (score_lists) share a simulation batch of at most this many
# simulated values (1 MB): that saves the per-call cost of many small batches, while
# larger batches leave the processor's cache (with a 16 MB limit, glassfurnace's six
# lists of 18 models, 3 MB, were scored 11-21 % slower together than one by one).
JOINT_BATCH_VALUES = 2**17
# Block size of the QR of the filtered data: the record-long matrices have a few dozen
# columns, too few for LAPACK's blocked dgeqrf (which then applies one reflector at a
# time); dgeqrt in blocks of 8 took 17-44 % less time on 433 x 30 to 645 x 90
QR_BLOCK = 8


def default_omega(Ts: float = 1.0) -> np.ndarray:
    """The paper's 18-point evaporator grid with frequencies scaled to ``Ts``.

    Cutoffs span 0.02*pi/Ts to 0.355*pi/Ts (1 % to 18 % of the Nyquist frequency,
    log-spaced), dampings 0.6, 0.7, 1.1: the range holds the dominant dynamics of
    plants sampled 5 to 50 times per time constant.

    Returns
    -------
    ndarray, shape (18, 2)
        Rows ``(wc, zeta)``, wc in rad per time unit of ``Ts``.
    """
    return grid(np.array(PAPER_WCS_PER_TS) / Ts, PAPER_ZETAS)


def grid(wcs: Sequence[float], zetas: Sequence[float]) -> np.ndarray:
    """All pairs ``(wc, zeta)`` of the given values, shape (len(wcs) * len(zetas), 2).

    Examples
    --------
    >>> grid([1.0, 2.0], [0.7])
    array([[1. , 0.7],
           [2. , 0.7]])
    """
    w, z = np.meshgrid(np.asarray(wcs, float), np.asarray(zetas, float), indexing="ij")
    return np.column_stack([w.ravel(), z.ravel()])


def check_omega(omega: object) -> np.ndarray:
    """Validate a candidate set: finite positive rows ``(wc, zeta)``."""
    array = np.array(omega, dtype=float)
    if array.ndim != 2 or array.shape[1] != 2 or array.shape[0] < 1:
        raise OptionError(f"omega must have shape (R, 2) with rows (wc, zeta), got {array.shape}")
    if not np.all(np.isfinite(array)) or np.any(array <= 0):
        raise OptionError("omega's wc and zeta must all be positive and finite")
    return array


def check_trend_degree(degree: object) -> int:
    """Validate the degree of the error trend J ignores: an integer 0..MAX_TREND_DEGREE."""
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or not (
        0 <= degree <= MAX_TREND_DEGREE
    ):
        raise OptionError(f"trend_degree must be an integer from 0 to {MAX_TREND_DEGREE}, got {degree!r}")
    return int(degree)


def barycenter(etas: np.ndarray, costs: np.ndarray) -> np.ndarray:
    """Paper eq. (5): ``sum eta_r exp(-mu J_r) / sum exp(-mu J_r)``, ``mu = 40/min J``.

    Examples
    --------
    >>> barycenter(np.array([[1.0, 1.0], [3.0, 1.0]]), np.array([0.1, 0.1]))
    array([2., 1.])
    """
    best = costs.min()
    if best <= 0:
        weights = (costs <= best).astype(float)
    else:
        weights = np.exp(-MU_SCALE * (costs - best) / best)
    return weights @ etas / weights.sum()


class RegressionCache:
    """Triangular factors and per-output solutions shared by the lists of one search.

    For a filter ``alpha`` of degree ``nbar`` the observer state ``xi`` holds every
    signal filtered by ``q^t/alpha``, ``t < nbar``; each output's regressors are ``xi``
    times a fixed matrix built from ``alpha/alpha_j`` (ALGORITHM.md, section 3), and
    its earlier outputs are columns of ``y``. So one QR of ``X = [xi, y]`` (triangular
    factor only) serves every output and every list that uses the same ``alpha``: each
    least-squares problem ``min |X (T theta - e)|`` becomes the small problem
    ``min |R (T theta - e)|``, with the same solution. Solutions are cached per
    ``(alpha, output, index)``, so a list that differs from an earlier one in a single
    index re-solves a single output.

    Parameters
    ----------
    z : ndarray, shape (N, p + m)
        Estimation outputs then inputs (centred).
    p : int
        Number of outputs.
    feedthrough : {False, True, "auto"}
        Add the current inputs to every output's regressors (direct feedthrough);
        ``"auto"`` keeps them for an output only where a nested F-test on the
        estimation data finds them significant at level :data:`FEEDTHROUGH_LEVEL`
        (otherwise that output's feedthrough is exactly zero).
    """

    def __init__(self, z: np.ndarray, p: int, feedthrough: bool | str = False) -> None:
        if feedthrough not in FEEDTHROUGH_CHOICES:
            raise OptionError(f"feedthrough must be one of {FEEDTHROUGH_CHOICES}, got {feedthrough!r}")
        self.z = z
        self.p = p
        self.feedthrough = feedthrough
        # columns appended to xi: the outputs, and the inputs when they feed through
        self.extra = z.shape[1] if feedthrough else p
        self._factors: dict[bytes, np.ndarray] = {}
        self._thetas: dict[tuple[bytes, int, int], np.ndarray] = {}
        # quotient maps of a batch of filters for one divisor degree (outputs share them)
        self._quotients: dict[tuple[tuple[bytes, ...], int], np.ndarray] = {}
        # filter polynomials by degree, per eta and root-rule key (see filters)
        self._filters: dict[tuple, dict[int, np.ndarray]] = {}
        self.factorizations = 0
        self.solves = 0

    def filters(
        self, etas: np.ndarray, indices: Indices, Ts: float, s: float
    ) -> tuple[list[np.ndarray], list[list[np.ndarray]]]:
        """``alpha`` and the divisors of ``indices`` for each row ``eta = (wc, zeta)`` (cached).

        The roots depend on ``indices`` only through ``max(indices)`` and whether an
        odd index below it needs a real root (see :mod:`moli.filters`): that is the key.
        Filters not seen yet are built together by :func:`moli.filters.filter_rows`.
        """
        etas = np.asarray(etas, float)
        nbar, needs_real = max(indices), _needs_real(indices)
        keys = [(w, zeta, Ts, s, nbar, needs_real) for w, zeta in etas.tolist()]
        degrees = set(indices)
        todo = [i for i, k in enumerate(keys) if not degrees <= self._filters.get(k, {}).keys()]
        if todo:
            _, built = filter_rows(etas[todo], indices, Ts, s)
            for row, i in enumerate(todo):
                known = self._filters.setdefault(keys[i], {})
                for l, coeffs in built.items():
                    known.setdefault(l, coeffs[row])     # an alpha already used keeps its bytes
        found = [self._filters[k] for k in keys]
        return [f[nbar] for f in found], [[f[l] for l in indices] for f in found]

    def factor(self, alphas: Sequence[np.ndarray]) -> list[np.ndarray]:
        """Triangular factors of ``[xi, y]`` for each filter polynomial (batched, cached)."""
        keys = [a.tobytes() for a in alphas]
        todo = {k: a for k, a in zip(keys, alphas) if k not in self._factors}
        if todo:
            by_degree: dict[int, list[tuple[bytes, np.ndarray]]] = {}
            for k, a in todo.items():
                by_degree.setdefault(a.size - 1, []).append((k, a))
            N, c = self.z.shape
            signals = np.ascontiguousarray(self.z.T)
            for nbar, items in by_degree.items():
                rows, cols = N - nbar, c * nbar + self.extra
                # each matrix stored column by column: LAPACK factors it in place, without
                # the copies np.linalg.qr makes of its input
                columns = np.empty((len(items), cols, rows))
                for i, (_, a) in enumerate(items):
                    # column r nbar + t (channel r filtered by q^t/alpha, from sample nbar
                    # on) is the filtered channel r from sample t on
                    base = lfilter([1.0], a, signals, axis=-1)
                    s_r, s_k = base.strides
                    delayed = as_strided(base, (c, nbar, rows), (s_r, s_k, s_k), writeable=False)
                    np.copyto(columns[i, : c * nbar].reshape(c, nbar, rows), delayed)
                columns[:, c * nbar :] = signals[: self.extra, nbar:]
                block = min(QR_BLOCK, rows, cols)
                below = _below_diagonal(min(rows, cols), cols)
                for (k, _), matrix in zip(items, columns):
                    factored = scipy.linalg.lapack.dgeqrt(block, matrix.T, overwrite_a=True)[0]
                    factor = np.array(factored[: min(rows, cols)], order="C")
                    factor[below] = 0.0          # the reflectors LAPACK leaves below R
                    self._factors[k] = factor
                self.factorizations += len(items)
        return [self._factors[k] for k in keys]

    def solve(
        self, batches: Sequence[tuple[Sequence[np.ndarray], Sequence[Sequence[np.ndarray]], Indices]]
    ) -> list[list[bytes]]:
        """Solve and cache the per-output problems of several batches of filters.

        Each batch is ``(alphas, divisors, indices)``: filter polynomials, each
        one's divisors for ``indices``, and the list. The factors of all the new
        filters are computed together, and the problems of one shape (filter degree,
        output, index) are solved together whichever batch they come from.

        Returns
        -------
        list of list of bytes
            Each batch's filter keys, for :meth:`thetas`.
        """
        keys = [[a.tobytes() for a in alphas] for alphas, _, _ in batches]
        groups: dict[tuple[int, int, int], dict[bytes, tuple[np.ndarray, np.ndarray]]] = {}
        for (alphas, divisors_, indices), batch_keys in zip(batches, keys):
            for key, alpha, divs in zip(batch_keys, alphas, divisors_):
                for j, l in enumerate(indices):
                    if (key, j, l) not in self._thetas:
                        groups.setdefault((alpha.size - 1, j, l), {}).setdefault(key, (alpha, divs[j]))
        if not groups:
            return keys
        needed = {k: a for members in groups.values() for k, (a, _) in members.items()}
        factors = dict(zip(needed, self.factor(list(needed.values()))))
        c = self.z.shape[1]
        extra_u = c - self.p if self.feedthrough else 0
        for (nbar, j, l), members in groups.items():
            batch = (tuple(members), l)
            if batch not in self._quotients:
                self._quotients[batch] = _quotient_map(
                    np.stack([a for a, _ in members.values()]), np.stack([d for _, d in members.values()])
                )
            small, rhs = _small_problems(
                np.stack([factors[k] for k in members]), self._quotients[batch], c, self.p, j, extra_u
            )
            if self.feedthrough == "auto":
                theta = self._solve_tested(small, rhs, nbar)
            else:
                theta = solve_batch(small, rhs)[0]
            for k, row in zip(members, theta):
                self._thetas[(k, j, l)] = row
            self.solves += len(members)
        return keys

    def thetas(self, keys: Sequence[bytes], indices: Indices) -> list[np.ndarray]:
        """Per-output parameters of solved filters (keys from :meth:`solve`), as :func:`fit_batch` has them.

        ``thetas[j]`` has shape (R, (p + m) l_j + j), followed by the ``m`` feedthrough
        coefficients when the cache was built with ``feedthrough``.
        """
        return [np.array([self._thetas[(k, j, l)] for k in keys]) for j, l in enumerate(indices)]

    def _solve_tested(self, small: np.ndarray, rhs: np.ndarray, nbar: int) -> np.ndarray:
        """Solve with feedthrough, and keep it only where an F-test on the estimation data asks.

        ``small`` (R, k, q) and ``rhs`` (R, k) are reduced problems
        (:func:`_small_problems`) of filters of degree ``nbar``, with the ``m``
        feedthrough columns last. The residual sums of squares of the reduced problems
        equal those of the full ones (``|X v| = |R v|``), and one triangular factor of
        the column-scaled ``[M, b]`` gives both nested fits: the problem without
        feedthrough is its leading block. The level :data:`FEEDTHROUGH_LEVEL` is strict
        because the residuals are coloured.
        """
        m = self.z.shape[1] - self.p
        count, k_rows, q1 = small.shape
        dof = self.z.shape[0] - nbar - q1
        if k_rows <= q1 or dof <= 0:
            return solve_batch(small, rhs)[0]        # short records: keep the feedthrough
        q0 = q1 - m
        norms = np.sqrt(np.add.reduce(small * small, axis=1, keepdims=True))   # np.linalg.norm's sums
        norms[norms == 0] = 1.0
        # each matrix stored column by column for LAPACK, factored in place one at a
        # time: most batches hold one or two filters, where a stacked np.linalg.qr and
        # solve cost several times the arithmetic (same routines, same R)
        scaled = np.empty((count, q1 + 1, k_rows))
        np.divide(small.transpose(0, 2, 1), norms.transpose(0, 2, 1), out=scaled[:, :q1])
        scaled[:, q1] = rhs
        critical = _f_critical(m, dof)
        theta = np.zeros((count, q1))
        with np.errstate(divide="ignore", invalid="ignore"):
            for i in range(count):
                r = scipy.linalg.lapack.dgeqrf(scaled[i].T, overwrite_a=True)[0]
                rss1 = r[q1, q1] ** 2
                tail = r[q0 : q1 + 1, q1]
                statistic = (tail @ tail - rss1) / m / (rss1 / dof)
                k = q0 if statistic <= critical else q1    # NaN (exact fit) keeps the feedthrough
                diag = np.abs(r.diagonal()[:k])
                smallest = diag.min()
                if smallest > 0 and diag.max() / smallest < 1e13:
                    theta[i, :k] = scipy.linalg.lapack.dtrtrs(r[:k, :k], r[:k, q1])[0]
                else:                                      # rank deficient: minimum-norm solution
                    theta[i, :k] = scipy.linalg.lstsq(small[i, :, :k] / norms[i, 0, :k], rhs[i])[0]
        return theta / norms[:, 0, :]


@functools.lru_cache(maxsize=None)
def _below_diagonal(rows: int, cols: int) -> np.ndarray:
    """Boolean mask of the entries below the diagonal of a ``rows x cols`` matrix."""
    return np.tri(rows, cols, -1, dtype=bool)


@functools.lru_cache(maxsize=None)
def _f_critical(m: int, dof: int) -> float:
    """Critical value of the F(m, dof) distribution at level :data:`FEEDTHROUGH_LEVEL`."""
    return float(scipy.stats.f.isf(FEEDTHROUGH_LEVEL, m, dof))


def _quotient_map(alpha: np.ndarray, alpha_j: np.ndarray) -> np.ndarray:
    """``(nbar, l)`` matrix ``Q`` with ``Q[t, i]`` the weight of ``q^t/alpha`` in ``q^i/alpha_j``.

    With ``alpha/alpha_j = sum_k c_k q^(d-k)``, ``d = nbar - l``:
    ``q^i/alpha_j = q^i (alpha/alpha_j)/alpha = sum_k c_k q^(i+d-k)/alpha``.
    Stacks of polynomials (leading axes) give a stack of maps.
    """
    nbar, l = alpha.shape[-1] - 1, alpha_j.shape[-1] - 1
    d = nbar - l
    # monic long division alpha / alpha_j (exact: alpha_j divides alpha); c_k is left
    # in rest[k], where the division would only write a zero
    rest = alpha.copy()
    tail = alpha_j[..., 1:]
    for k in range(d + 1):
        rest[..., k + 1 : k + l + 1] -= rest[..., k, None] * tail
    quotient = np.zeros(alpha.shape[:-1] + (d + 2,))      # c_0 .. c_d, then a zero
    quotient[..., : d + 1] = rest[..., : d + 1]
    return quotient[..., _band(nbar, l)]


@functools.lru_cache(maxsize=None)
def _band(nbar: int, l: int) -> np.ndarray:
    """Index ``k`` of ``c_k`` at each entry of an ``(nbar, l)`` quotient map; ``d + 1`` off the band."""
    d = nbar - l
    k = np.arange(l)[None, :] + d - np.arange(nbar)[:, None]
    return np.where((k >= 0) & (k <= d), k, d + 1)


def _regressor_map(
    alpha: np.ndarray, alpha_j: np.ndarray, c: int, p: int, j: int, m: int = 0
) -> np.ndarray:
    """Matrix ``T`` with ``[xi, y] T`` = output ``j``'s regressors ``[w_j, y_<j]``.

    Column ``r l + i`` is ``q^i/alpha_j`` applied to channel ``r``, a combination of the
    columns ``r nbar + t`` of ``xi`` (see :func:`_quotient_map`). With ``m > 0`` the data
    matrix is ``[xi, y, u]`` and the ``m`` current inputs are appended to the regressors
    (direct feedthrough).
    """
    nbar, l = alpha.size - 1, alpha_j.size - 1
    T = np.kron(np.eye(c), _quotient_map(alpha, alpha_j))
    tail = np.zeros((p + m, c * l + j + m))
    tail[np.arange(j), c * l + np.arange(j)] = 1.0
    tail[p + np.arange(m), c * l + j + np.arange(m)] = 1.0
    return np.vstack([np.hstack([T, np.zeros((c * nbar, j + m))]), tail])


def _small_problems(
    factors: np.ndarray, quotients: np.ndarray, c: int, p: int, j: int, m: int
) -> tuple[np.ndarray, np.ndarray]:
    """``(R T, R e)``: output ``j``'s least-squares problems reduced by the factors ``R``.

    Same as ``factor @ _regressor_map(...)`` for each filter, without forming ``T``.

    Parameters
    ----------
    factors : ndarray, shape (B, k, c nbar + p [+ m])
        Triangular factors of ``[xi, y]`` (``[xi, y, u]`` with feedthrough), one per filter.
    quotients : ndarray, shape (B, nbar, l)
        Each filter's :func:`_quotient_map` for output ``j``'s divisor.
    c, p, j, m : int
        Signals, outputs, the output and the feedthrough inputs (0 for none).

    Returns
    -------
    ndarray, shape (B, k, c l + j + m)
    ndarray, shape (B, k)
    """
    B, k = factors.shape[:2]
    nbar = quotients.shape[1]
    w = (factors[:, :, : c * nbar].reshape(B, k, c, nbar) @ quotients[:, None]).reshape(B, k, -1)
    parts = [w, factors[:, :, c * nbar : c * nbar + j]]
    if m:
        parts.append(factors[:, :, c * nbar + p : c * nbar + p + m])
    return np.concatenate(parts, axis=2), factors[:, :, c * nbar + j]


def _initial_response(A: np.ndarray, C: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Least-squares fit of the free responses ``C A^k x0`` to ``error``, per model.

    Parameters: ``A`` (R, n, n), ``C`` (R, p, n), ``error`` (R, N, p). Returns (R, N, p);
    zero where the fit is not finite (unstable models).
    """
    R, n, _ = A.shape
    N, p = error.shape[1:]
    out = np.zeros(error.shape)
    with np.errstate(all="ignore"):
        free = simulate_batch(
            np.repeat(A, n, axis=0), np.zeros((R * n, n, 1)), np.repeat(C, n, axis=0),
            np.zeros((N, 1)), x0=np.tile(np.eye(n), (R, 1)),
        ).reshape(R, n, N * p).transpose(0, 2, 1)                       # (R, N p, n)
        ok = np.all(np.isfinite(free), axis=(1, 2)) & np.all(np.isfinite(error), axis=(1, 2))
        for r in np.flatnonzero(ok):
            x0 = np.linalg.lstsq(free[r], error[r].reshape(-1), rcond=None)[0]
            out[r] = (free[r] @ x0).reshape(N, p)
    return out


def _realize_feedthrough(
    thetas: Sequence[np.ndarray], parts: Sequence[Sequence[np.ndarray]], indices: Indices, m: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """State-space batch of observer-form fits whose last ``m`` parameters feed ``u`` through.

    Output ``j``'s equation is ``y_j = theta_j w_j + g_j y_<j + f_j u``, so
    ``y = (I - G)^-1 (C_D x + F u)``: ``C`` is unchanged, ``D = (I - G)^-1 F``, and the
    observer's output injection ``D_y y`` adds ``D_y D`` to ``B``.
    """
    A, B, C, D_y = _observer_form([t[:, :-m] for t in thetas], parts, indices, m)
    F = np.stack([t[:, -m:] for t in thetas], axis=1)             # (R, p, m)
    H = C[:, :, np.cumsum(indices) - 1]                           # (I - G)^-1
    D = H @ F
    return A, B + D_y @ D, C, D


@functools.lru_cache(maxsize=16)
def _trend_basis(N: int, degree: int) -> np.ndarray:
    """Orthonormal basis (N, degree + 1) of the polynomials of that degree over N samples."""
    basis = np.polynomial.legendre.legvander(np.linspace(-1.0, 1.0, N), degree)
    return np.linalg.qr(basis)[0]


def error_ratio(
    y: np.ndarray, yhat: np.ndarray, degree: int = 0, y_var: np.ndarray | None = None
) -> np.ndarray:
    """Per-output share of the output variance left in the simulation error, at most 1.

    ``min(|e - P e|^2 / (N var(y)), 1)`` with ``e = y - yhat`` and ``P`` the projection
    on the polynomials of the given degree over the record: degree 0 removes the
    error's mean (the paper's J); a higher degree also ignores a slow drift of the
    error. Diverging simulations (inf or NaN) score 1.

    Parameters
    ----------
    y : ndarray, shape (N, p)
        Measured outputs.
    yhat : ndarray, shape (R, N, p)
        Simulated outputs of ``R`` models.
    degree : int, default 0
        Degree of the polynomial trend ignored.
    y_var : ndarray, shape (p,), optional
        ``np.var(y, axis=0)`` when already known.

    Returns
    -------
    ndarray, shape (R, p)
    """
    y_var = np.var(y, axis=0) if y_var is None else y_var
    with np.errstate(all="ignore"):
        # samples first: the sums run over long contiguous rows, the same sequential
        # sums as along axis 1 of (R, N, p) but several times faster; the error is then
        # formed in place in that copy (a record-sized temporary costs about as much as
        # the arithmetic), never in a view of yhat
        error = yhat.transpose(1, 0, 2).copy(order="C")
        np.subtract(y[:, None, :], error, out=error)
        if degree == 0:
            ratio = np.var(error, axis=0) / y_var
        else:
            N = y.shape[0]
            basis = _trend_basis(N, degree)
            flat = error.reshape(N, -1)
            flat -= basis @ (basis.T @ flat)
            ratio = np.einsum("ij,ij->j", flat, flat).reshape(error.shape[1:]) / (N * y_var)
    return np.where(np.isfinite(ratio), np.minimum(ratio, 1.0), 1.0)


class FilterScorer:
    """Scores filter candidates for one list of indices on one estimation record.

    Parameters
    ----------
    z : ndarray, shape (N, p + m)
        Estimation outputs then inputs (centred).
    indices : tuple of int
    Ts, s : float
        Sampling period and root spacing factor of the filters.
    cache : RegressionCache, optional
        Factorizations shared with the other lists of a search on the same ``z``;
        without one, each candidate is estimated directly by :func:`fit_batch`. Both
        routes give the same models up to round-off.
    x0 : {"zero", "estimate"}
        Initial state of the simulations behind J: zero (the paper), or fitted by least
        squares to the estimation record (the record need not start at rest).
    max_radius : float, optional
        Candidates with a pole of at least this modulus score the worst J, 1, so that
        tuning and the structure path never prefer a (nearly) unstable model. None
        (the paper) scores every candidate by its fit alone.
    trend_degree : int, default 0
        J ignores the polynomial trend of this degree in the simulation error (see
        :func:`error_ratio`); 0 is the paper's J.
    """

    def __init__(
        self, z: np.ndarray, indices: Indices, Ts: float, s: float,
        cache: RegressionCache | None = None, x0: str = "zero",
        max_radius: float | None = None, trend_degree: int = 0,
    ) -> None:
        self.max_radius = max_radius
        self.trend_degree = check_trend_degree(trend_degree)
        if x0 not in X0_CHOICES:
            raise OptionError(f"x0 must be one of {X0_CHOICES}, got {x0!r}")
        self.x0 = x0
        self.z = z
        self.indices = indices
        self.Ts = Ts
        self.s = s
        self.cache = cache
        p = len(indices)
        self.y = z[:, :p]
        self.u = z[:, p:]
        self.y_var = np.var(self.y, axis=0)
        self.evaluations = 0

    def fit(self, etas: np.ndarray) -> tuple[np.ndarray, ...]:
        """The batch of models ``(A, B, C)`` (and ``D`` with feedthrough) for each candidate."""
        if self.cache is None:
            alphas = [filter_divisors(w, zeta, self.indices, self.Ts, self.s) for w, zeta in etas]
            A, B, C, _ = fit_batch(self.z, self.indices, alphas)
            return A, B, C
        return _fit_cached([self], [etas])[0]

    def realize(self, thetas: list[np.ndarray], parts: list[list[np.ndarray]]) -> tuple[np.ndarray, ...]:
        """State-space batch ``(A, B, C[, D])`` of per-output parameters.

        ``thetas[j]`` holds output ``j``'s parameters of each model (rows), as
        :meth:`RegressionCache.thetas` gives them; ``parts[r][j]`` is model ``r``'s
        divisor for output ``j``. Needs the scorer's cache.
        """
        m = self.z.shape[1] - len(self.indices)
        if not self.cache.feedthrough:
            return realize(thetas, parts, self.indices, m)
        return _realize_feedthrough(thetas, parts, self.indices, m)

    def score(self, etas: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        """J of each candidate and the batch of fitted models ``(A, B, C[, D])``."""
        return score_lists([self], [etas])[0]

    def criterion(self, matrices: tuple[np.ndarray, ...], radius_rule: bool = True) -> np.ndarray:
        """J of a batch of models ``(A, B, C[, D])`` on this scorer's record.

        With ``radius_rule=False`` the models are scored by their fit alone; the
        caller then applies :meth:`too_slow` to the ones it keeps.
        """
        A, B, C = matrices[:3]
        yhat = simulate_batch(A, B, C, self.u)
        if len(matrices) == 4:
            yhat = yhat + self.u @ matrices[3].transpose(0, 2, 1)
        if self.x0 == "estimate":
            yhat = yhat + _initial_response(A, C, self.y[None] - yhat)
        ratio = error_ratio(self.y, yhat, self.trend_degree, self.y_var)
        if radius_rule:
            ratio[self.too_slow(A)] = 1.0
        return ratio.mean(axis=1)

    def too_slow(self, A: np.ndarray) -> np.ndarray:
        """Which models of the batch ``A`` (R, n, n) have a pole of modulus ``max_radius`` or more."""
        if self.max_radius is None:
            return np.zeros(A.shape[0], bool)
        return np.max(np.abs(np.linalg.eigvals(A)), axis=1) >= self.max_radius


def score_lists(
    scorers: Sequence[FilterScorer], etas: Sequence[np.ndarray]
) -> list[tuple[np.ndarray, tuple[np.ndarray, ...]]]:
    """:meth:`FilterScorer.score` for several lists of indices at once.

    The models of lists of the same order share one simulation batch (up to
    :data:`JOINT_BATCH_VALUES` simulated values), which saves the per-call cost of
    the many small batches a structure search scores (one barycenter per list).

    Parameters
    ----------
    scorers : sequence of FilterScorer
        Scorers of one record, cache and criterion (``x0``, ``max_radius``,
        ``trend_degree``).
    etas : sequence of ndarray, shape (R_i, 2)
        Candidates ``(wc, zeta)`` of each scorer.

    Returns
    -------
    list of (ndarray, tuple of ndarray)
        Each scorer's J and models, as :meth:`FilterScorer.score` returns them.
    """
    first = scorers[0]
    for other in scorers[1:]:
        if other.z is not first.z or other.cache is not first.cache or (
            other.x0, other.max_radius, other.trend_degree
        ) != (first.x0, first.max_radius, first.trend_degree):
            raise OptionError("lists scored together must share the record, the cache and the criterion")
    if first.cache is None:
        fits = [scorer.fit(np.asarray(e, float)) for scorer, e in zip(scorers, etas)]
    else:
        fits = _fit_cached(scorers, etas)
    costs: list[np.ndarray] = [np.empty(0)] * len(scorers)
    by_order: dict[int, list[int]] = {}
    for i, matrices in enumerate(fits):
        by_order.setdefault(matrices[0].shape[1], []).append(i)
    limit = max(JOINT_BATCH_VALUES // first.y.size, 1)
    for members in by_order.values():
        for chunk in _chunks(members, [len(fits[i][0]) for i in members], limit):
            joint = first.criterion(tuple(
                np.concatenate([fits[i][k] for i in chunk]) for k in range(len(fits[chunk[0]]))
            ))
            ends = np.cumsum([len(fits[i][0]) for i in chunk])[:-1]
            for i, part in zip(chunk, np.split(joint, ends)):
                costs[i] = part
    for scorer, e in zip(scorers, etas):
        scorer.evaluations += len(e)
    return list(zip(costs, fits))


def _fit_cached(scorers: Sequence[FilterScorer], etas: Sequence[np.ndarray]) -> list[tuple[np.ndarray, ...]]:
    """Each scorer's models, with the least-squares problems of all of them solved together."""
    cache = scorers[0].cache
    filters = [cache.filters(np.asarray(e, float), sc.indices, sc.Ts, sc.s) for sc, e in zip(scorers, etas)]
    keys = cache.solve([(full, parts, sc.indices) for (full, parts), sc in zip(filters, scorers)])
    return [
        sc.realize(cache.thetas(k, sc.indices), parts) for sc, k, (_, parts) in zip(scorers, keys, filters)
    ]


def _chunks(items: list[int], sizes: list[int], limit: int) -> list[list[int]]:
    """Consecutive groups of ``items`` whose sizes add up to at most ``limit``.

    An item larger than ``limit`` forms a group of its own.
    """
    groups: list[list[int]] = []
    total = 0
    for item, size in zip(items, sizes):
        if not groups or total + size > limit:
            groups.append([])
            total = 0
        groups[-1].append(item)
        total += size
    return groups


@dataclass
class TuningResult:
    """Outcome of filter tuning for one list of indices.

    Attributes
    ----------
    eta : ndarray, shape (2,)
        Chosen ``(wc, zeta)``: the lowest J among every candidate and barycenter scored.
    J : float
        Its criterion value.
    barycenter : ndarray, shape (2,)
        Last barycenter computed.
    J_barycenter : float
        J evaluated at that barycenter.
    J_grid_best : float
        Lowest J over the grid Omega alone.
    evaluations : int
        Number of least-squares fits (each one per output) performed.
    A, B, C : ndarray
        Matrices of the chosen model.
    D : ndarray or None
        Its feedthrough, when the scorer estimates one.
    """

    eta: np.ndarray
    J: float
    barycenter: np.ndarray
    J_barycenter: float
    J_grid_best: float
    evaluations: int
    A: np.ndarray = field(repr=False)
    B: np.ndarray = field(repr=False)
    C: np.ndarray = field(repr=False)
    D: np.ndarray | None = field(default=None, repr=False)


class _Tracker:
    """Keeps the best candidate seen so far."""

    def __init__(self) -> None:
        self.J = np.inf
        self.eta: np.ndarray | None = None
        self.matrices: tuple[np.ndarray, ...] = ()

    def offer(self, etas: np.ndarray, costs: np.ndarray, matrices: tuple[np.ndarray, ...]) -> None:
        i = int(np.argmin(costs))
        if costs[i] < self.J:
            self.J = float(costs[i])
            self.eta = etas[i].copy()
            self.matrices = tuple(M[i] for M in matrices)


def tune_filter(
    scorer: FilterScorer,
    omega: np.ndarray,
    method: str = "random",
    iterations: int = 5,
    seed: int | np.random.Generator = 0,
) -> TuningResult:
    """Tune the filter of one list of indices.

    Parameters
    ----------
    scorer : FilterScorer
    omega : ndarray, shape (R, 2)
        Grid of candidates ``(wc, zeta)``.
    method : {"grid", "random", "zoom"}
        ``"grid"``: one barycenter over ``omega`` (paper eq. 5). ``"zoom"``: a bounded
        coarse-to-fine search from the best point of ``omega``: each step scores the
        eight neighbours at half the previous spacing (wc on a log scale, the first
        spacing half of ``omega``'s), clipped to ``omega``'s bounding box, and moves to
        the best point seen. ``"random"``: the
        paper's randomized variant; starting from the grid barycenter, each step
        scores seven candidates (the previous barycenter, three points of ``omega``
        drawn at random, three normal draws around the barycenter with standard
        deviation 20 % of the range of ``omega``'s wc and zeta values, clipped to
        ``omega``'s bounding box) and moves to their barycenter.
    iterations : int, default 5
        Steps of the randomized or the zoom search.
    seed : int or numpy.random.Generator
        Seed of the random draws (results are reproducible for a given seed).

    Returns
    -------
    TuningResult
    """
    return tune_filters([scorer], omega, method, iterations, [seed])[0]


def tune_filters(
    scorers: Sequence[FilterScorer],
    omega: np.ndarray,
    method: str = "random",
    iterations: int = 5,
    seeds: Sequence[int | np.random.Generator] | None = None,
) -> list[TuningResult]:
    """:func:`tune_filter` for several lists, run in step so their batches are scored together.

    Each list gets the result :func:`tune_filter` gives it alone (with its own seed),
    up to round-off; the scorers must qualify for :func:`score_lists`.

    Parameters
    ----------
    scorers : sequence of FilterScorer
    omega, method, iterations
        As in :func:`tune_filter`.
    seeds : sequence of int or numpy.random.Generator, optional
        One per scorer; 0 for each by default.

    Returns
    -------
    list of TuningResult
    """
    if method not in TUNING_METHODS:
        raise OptionError(f"tuning method must be one of {TUNING_METHODS}, got {method!r}")
    if int(iterations) != iterations or iterations < 0:
        raise OptionError(f"iterations must be a non-negative integer, got {iterations!r}")
    seeds = [0] * len(scorers) if seeds is None else list(seeds)
    if len(seeds) != len(scorers):
        raise OptionError(f"give one seed per scorer: {len(scorers)} scorers, {len(seeds)} seeds")
    rngs = [np.random.default_rng(seed) for seed in seeds]
    starts = [scorer.evaluations for scorer in scorers]
    trackers = [_Tracker() for _ in scorers]
    centers = []
    grid_scores = score_lists(scorers, [omega] * len(scorers))
    for tracker, (costs, matrices) in zip(trackers, grid_scores):
        tracker.offer(omega, costs, matrices)
        centers.append(barycenter(omega, costs))
    grid_best = [tracker.J for tracker in trackers]
    if method == "zoom":
        _zoom(scorers, omega, trackers, int(iterations))
        return [
            _result(tracker, center, np.nan, best, scorer.evaluations - start)
            for tracker, center, best, scorer, start in zip(trackers, centers, grid_best, scorers, starts)
        ]
    steps = 0 if method == "grid" else int(iterations)
    low, high = omega.min(axis=0), omega.max(axis=0)
    spread = 0.2 * (high - low)
    for _ in range(steps):
        drawn = [rng.choice(len(omega), size=min(3, len(omega)), replace=False) for rng in rngs]
        fresh = [
            np.vstack([center, np.clip(center + spread * rng.standard_normal((3, 2)), low, high)])
            for center, rng in zip(centers, rngs)
        ]
        for i, (costs, matrices) in enumerate(score_lists(scorers, fresh)):
            trackers[i].offer(fresh[i], costs, matrices)
            # the grid points drawn keep the J they scored in the grid round
            etas = np.vstack([fresh[i][:1], omega[drawn[i]], fresh[i][1:]])
            centers[i] = barycenter(etas, np.concatenate([costs[:1], grid_scores[i][0][drawn[i]], costs[1:]]))
    results = []
    last = score_lists(scorers, [center[None] for center in centers])
    for tracker, center, (cost, matrices), best, scorer, start in zip(
        trackers, centers, last, grid_best, scorers, starts
    ):
        tracker.offer(center[None], cost, matrices)
        results.append(_result(tracker, center, float(cost[0]), best, scorer.evaluations - start))
    return results


def _result(
    best: _Tracker, center: np.ndarray, J_barycenter: float, grid_best: float, evaluations: int
) -> TuningResult:
    A, B, C = best.matrices[:3]
    D = best.matrices[3] if len(best.matrices) == 4 else None
    return TuningResult(
        eta=best.eta, J=best.J, barycenter=center, J_barycenter=J_barycenter,
        J_grid_best=grid_best, evaluations=evaluations, A=A, B=B, C=C, D=D,
    )


def _spacing(values: np.ndarray) -> float:
    unique = np.unique(values)
    return float(np.median(np.diff(unique))) if unique.size > 1 else 0.1 * max(abs(unique[0]), 1e-3)


def _zoom(scorers: Sequence[FilterScorer], omega: np.ndarray, best: list[_Tracker], steps: int) -> None:
    """Coarse-to-fine search in ``(log wc, zeta)`` from each list's best grid point."""
    low = np.array([np.log(omega[:, 0].min()), omega[:, 1].min()])
    high = np.array([np.log(omega[:, 0].max()), omega[:, 1].max()])
    step = 0.5 * np.array([_spacing(np.log(omega[:, 0])), _spacing(omega[:, 1])])
    offsets = np.array([(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1) if (a, b) != (0, 0)], float)
    for _ in range(steps):
        etas = []
        for tracker in best:
            here = np.array([np.log(tracker.eta[0]), tracker.eta[1]])
            points = np.unique(np.clip(here + offsets * step, low, high), axis=0)
            etas.append(np.column_stack([np.exp(points[:, 0]), points[:, 1]]))
        for tracker, e, (costs, matrices) in zip(best, etas, score_lists(scorers, etas)):
            tracker.offer(e, costs, matrices)
        step = step / 2
