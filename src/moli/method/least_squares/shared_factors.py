"""The least-squares problems of a filter search, factored once and shared.

Every list of indices tried with the same filter ``alpha`` solves its per-output
problems from one triangular factor of the filtered record (docs/method.md §3 and §8):
:class:`RegressionCache` holds those factors, the per-output solutions and the
nested F-test of the "auto" feedthrough.
"""

from __future__ import annotations

import functools
from typing import Iterator, Sequence

import numpy as np
import scipy.linalg
import scipy.linalg.lapack
from numpy.lib.stride_tricks import as_strided

from ...errors import OptionError
from .estimation import solve_batch
from .regularization import REGULARIZATIONS, ridge_gcv
from ..structure.filters import needs_real_root, filter_rows
from ...numerics.recursive_filter import recursive_filter
from ...numerics.triangular import QR_BLOCK, WHOLE_TALL_ROWS, streamed_factor, tall_factor
from .row_blocks import WHOLE_ROWS, lagged_blocks
from ..structure.indices import Indices

__all__ = ["RegressionCache", "quotient_map", "reduced_problems"]

FEEDTHROUGH_CHOICES = (False, True, "auto")
# Significance level of the "auto" feedthrough test. Strict, because the equation
# errors are coloured and the nominal F distribution then overstates significance.
FEEDTHROUGH_LEVEL = 1e-3
# Filters factored whole at a time hold at most this many bytes of matrices: sharing
# one allocation saves time on short records, and the bound keeps it off long ones.
BATCH_BYTES = 2**25


class RegressionCache:
    """Triangular factors and per-output solutions shared by the lists of one search.

    For a filter ``alpha`` of degree ``nbar`` the observer state ``xi`` holds every
    signal filtered by ``q^t/alpha``, ``t < nbar``; each output's regressors are ``xi``
    times a fixed matrix built from ``alpha/alpha_j`` (docs/method.md §3), and
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
    starts : sequence of int, default (0,)
        First sample of each segment of ``z``: each segment is filtered from a zero
        state and gives its own rows, all folded into one factor in row blocks
        (:mod:`moli.method.least_squares.row_blocks`), so no row spans a boundary.
    regularization : {"none", "gcv"}
        Plain least squares, or ridge with its weight chosen per problem by
        generalized cross-validation (:func:`moli.method.least_squares.regularization.ridge_gcv`).
    """

    def __init__(
        self, z: np.ndarray, p: int, feedthrough: bool | str = False, starts: Sequence[int] = (0,),
        regularization: str = "none",
    ) -> None:
        if feedthrough not in FEEDTHROUGH_CHOICES:
            raise OptionError(f"feedthrough must be one of {FEEDTHROUGH_CHOICES}, got {feedthrough!r}")
        if regularization not in REGULARIZATIONS:
            raise OptionError(f"regularization must be one of {REGULARIZATIONS}, got {regularization!r}")
        self.regularization = regularization
        self.z = z
        self.starts = tuple(starts)
        self._signals = np.ascontiguousarray(z.T)
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
        odd index below it needs a real root (see :mod:`moli.method.structure.filters`): that is the key.
        Filters not seen yet are built together by :func:`moli.method.structure.filters.filter_rows`.
        """
        etas = np.asarray(etas, float)
        nbar, needs_real = max(indices), needs_real_root(indices)
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
        """Triangular factors of ``[xi, y]`` for each filter polynomial (batched, cached).

        A record of one segment with at most :data:`WHOLE_ROWS` rows is factored whole,
        several filters at a time (at most :data:`BATCH_BYTES` of matrices); longer
        records and records of several segments are streamed through the factor in row
        blocks (:mod:`moli.method.least_squares.row_blocks`), one filter at a time.
        """
        keys = [a.tobytes() for a in alphas]
        todo = {k: a for k, a in zip(keys, alphas) if k not in self._factors}
        if todo:
            by_degree: dict[int, list[tuple[bytes, np.ndarray]]] = {}
            for k, a in todo.items():
                by_degree.setdefault(a.size - 1, []).append((k, a))
            bounds = tuple(zip(self.starts, (*self.starts[1:], self.z.shape[0])))
            for nbar, items in by_degree.items():
                cols = self.z.shape[1] * nbar + self.extra
                if len(bounds) == 1 and self.z.shape[0] - nbar <= WHOLE_ROWS:
                    rows = self.z.shape[0] - nbar
                    batch = max(1, BATCH_BYTES // (8 * rows * cols))
                    for first in range(0, len(items), batch):
                        chunk = items[first : first + batch]
                        factors = _record_factors(self.z, [a for _, a in chunk], self.extra)
                        self._factors.update((k, f) for (k, _), f in zip(chunk, factors))
                else:
                    # each segment filtered from a zero state, its rows folded into one
                    # factor block by block: no row spans a boundary, memory is a block
                    for k, a in items:
                        self._factors[k] = _streamed_record_factor(self._signals, a, self.extra, bounds)
                self.factorizations += len(items)
        return [self._factors[k] for k in keys]

    def rows(self, nbar: int) -> int:
        """Regression rows of filters of degree ``nbar``: each segment's samples from ``nbar`` on."""
        return sum(max(b - a - nbar, 0) for a, b in zip(self.starts, (*self.starts[1:], self.z.shape[0])))

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
                self._quotients[batch] = quotient_map(
                    np.stack([a for a, _ in members.values()]), np.stack([d for _, d in members.values()])
                )
            small, rhs = reduced_problems(
                np.stack([factors[k] for k in members]), self._quotients[batch], c, self.p, j, extra_u
            )
            if self.feedthrough == "auto":
                theta = self._solve_tested(small, rhs, nbar)
            elif self.regularization == "gcv":
                theta = ridge_gcv(small, rhs, self.rows(nbar))
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
        (:func:`reduced_problems`) of filters of degree ``nbar``, with the ``m``
        feedthrough columns last. The residual sums of squares of the reduced problems
        equal those of the full ones (``|X v| = |R v|``), and one triangular factor of
        the column-scaled ``[M, b]`` gives both nested fits: the problem without
        feedthrough is its leading block. The level :data:`FEEDTHROUGH_LEVEL` is strict
        because the residuals are coloured.
        """
        m = self.z.shape[1] - self.p
        count, k_rows, q1 = small.shape
        dof = self.rows(nbar) - q1
        if k_rows <= q1 or dof <= 0:
            return solve_batch(small, rhs)[0]        # short records: keep the feedthrough
        q0 = q1 - m
        norms = np.sqrt(np.add.reduce(small * small, axis=1, keepdims=True))   # np.linalg.norm's sums
        norms[norms == 0] = 1.0
        scaled = np.empty((count, k_rows, q1 + 1))
        np.divide(small, norms, out=scaled[:, :, :q1])
        scaled[:, :, q1] = rhs
        # one stacked factorization (numpy's loop over LAPACK's dgeqrf, the same R as
        # factoring each matrix alone), then the nested F-tests of all of them at once
        r = np.linalg.qr(scaled, mode="r")
        rss1 = r[:, q1, q1] ** 2
        tail = r[:, q0 : q1 + 1, q1]
        with np.errstate(divide="ignore", invalid="ignore"):
            statistic = (np.einsum("ij,ij->i", tail, tail) - rss1) / m / (rss1 / dof)
        # NaN (an exact fit) keeps the feedthrough
        kept = np.where(statistic <= _f_critical(m, dof), q0, q1)
        diag = np.abs(np.diagonal(r, axis1=1, axis2=2))
        # each fit's conditioning over its own columns (the first q0, or all q1)
        smallest = np.where(kept == q0, diag[:, :q0].min(axis=1), diag[:, :q1].min(axis=1))
        largest = np.where(kept == q0, diag[:, :q0].max(axis=1), diag[:, :q1].max(axis=1))
        with np.errstate(divide="ignore", invalid="ignore"):
            regular = (smallest > 0) & (largest / smallest < 1e13)
        theta = np.zeros((count, q1))
        for i, (k, ok) in enumerate(zip(kept.tolist(), regular.tolist())):
            if self.regularization == "gcv":
                theta[i, :k] = ridge_gcv(small[None, i, :, :k] / norms[None, i, :, :k], rhs[None, i], dof + q1)[0]
            elif ok:
                theta[i, :k] = scipy.linalg.lapack.dtrtrs(r[i, :k, :k], r[i, :k, q1])[0]
            else:                                      # rank deficient: minimum-norm solution
                theta[i, :k] = scipy.linalg.lstsq(small[i, :, :k] / norms[i, 0, :k], rhs[i])[0]
        return theta / norms[:, 0, :]


def _record_factors(z: np.ndarray, alphas: Sequence[np.ndarray], extra: int) -> list[np.ndarray]:
    """Triangular factors of ``[xi, y]`` (``extra`` columns of ``z`` after ``xi``) of one record,
    one per filter polynomial of the same degree, from a zero filter state."""
    nbar = alphas[0].size - 1
    N, c = z.shape
    signals = np.ascontiguousarray(z.T)
    rows, cols = N - nbar, c * nbar + extra
    # each matrix stored column by column: LAPACK factors it in place, without
    # the copies np.linalg.qr makes of its input
    columns = np.empty((len(alphas), cols, rows))
    for i, a in enumerate(alphas):
        # column r nbar + t (channel r filtered by q^t/alpha, from sample nbar
        # on) is the filtered channel r from sample t on
        base = recursive_filter([1.0], a, signals, axis=-1)
        s_r, s_k = base.strides
        delayed = as_strided(base, (c, nbar, rows), (s_r, s_k, s_k), writeable=False)
        np.copyto(columns[i, : c * nbar].reshape(c, nbar, rows), delayed)
    columns[:, c * nbar :] = signals[:extra, nbar:]
    block = min(QR_BLOCK, rows, cols)
    below = _below_diagonal(min(rows, cols), cols)
    factors = []
    for matrix in columns:
        if rows > WHOLE_TALL_ROWS:   # a long window: folded in blocks that stay in cache
            factors.append(tall_factor(matrix.T))
            continue
        factored = scipy.linalg.lapack.dgeqrt(block, matrix.T, overwrite_a=True)[0]
        factor = np.array(factored[: min(rows, cols)], order="C")
        factor[below] = 0.0          # the reflectors LAPACK leaves below R
        factors.append(factor)
    return factors


def _streamed_record_factor(
    signals: np.ndarray, a: np.ndarray, extra: int, bounds: Sequence[tuple[int, int]]
) -> np.ndarray:
    """Triangular factor of ``[xi, y]`` of one filter polynomial over the segments ``bounds``, in row blocks.

    ``signals`` is ``z`` transposed (channels, samples). Each segment is filtered from a
    zero state and gives its samples from ``nbar`` on (:func:`moli.method.least_squares.row_blocks.lagged_blocks`);
    the rows of all segments are folded into one factor (docs/method.md §3, "Segments"; §15).
    """
    c = signals.shape[0]
    nbar = a.size - 1
    cols = c * nbar + extra

    def blocks() -> Iterator[np.ndarray]:
        for k0, k1, lagged in lagged_blocks(signals, a, nbar, bounds):
            block = np.empty((cols, k1 - k0))
            block[: c * nbar].reshape(c, nbar, k1 - k0)[:] = lagged
            block[c * nbar :] = signals[:extra, k0:k1]
            yield block

    return streamed_factor(blocks())


@functools.lru_cache(maxsize=None)
def _below_diagonal(rows: int, cols: int) -> np.ndarray:
    """Boolean mask of the entries below the diagonal of a ``rows x cols`` matrix."""
    return np.tri(rows, cols, -1, dtype=bool)


@functools.lru_cache(maxsize=None)
def _f_critical(m: int, dof: int) -> float:
    """Critical value of the F(m, dof) distribution at level :data:`FEEDTHROUGH_LEVEL`."""
    import scipy.special  # only for the "auto" feedthrough

    return float(scipy.special.fdtri(m, dof, 1.0 - FEEDTHROUGH_LEVEL))   # scipy.stats.f.isf, without its slow import


def quotient_map(alpha: np.ndarray, alpha_j: np.ndarray) -> np.ndarray:
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


def reduced_problems(
    factors: np.ndarray, quotients: np.ndarray, c: int, p: int, j: int, m: int
) -> tuple[np.ndarray, np.ndarray]:
    """``(R T, R e)``: output ``j``'s least-squares problems reduced by the factors ``R``.

    ``T`` maps ``[xi, y]`` to output ``j``'s regressors ``[w_j, y_<j]``: column ``r l + i``
    of ``w_j`` is ``q^i/alpha_j`` applied to channel ``r``, the combination of the columns
    ``r nbar + t`` of ``xi`` given by :func:`quotient_map`; with ``m > 0`` the factors are
    of ``[xi, y, u]`` and the current inputs follow (direct feedthrough). ``T`` is never
    formed.

    Parameters
    ----------
    factors : ndarray, shape (B, k, c nbar + p [+ m])
        Triangular factors of ``[xi, y]`` (``[xi, y, u]`` with feedthrough), one per filter.
    quotients : ndarray, shape (B, nbar, l)
        Each filter's :func:`quotient_map` for output ``j``'s divisor.
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
