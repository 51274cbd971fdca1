"""Parameter estimation: one linear least-squares problem per output.

For output ``j`` with index ``l`` and divisor ``alpha_j``, the regressors are the
signals ``z = [y, u]`` filtered by ``q^i / alpha_j(q)``, ``i = 0..l-1``, plus the
current outputs ``y_i``, ``i < j``. Since ``q^i/alpha_j = q^(i-l) (q^l/alpha_j)``,
all of them are delays of the single filtered signal ``lfilter(1, alpha_j, z)``.
"""

from __future__ import annotations

import warnings
from typing import Iterator, Sequence

import numpy as np
import scipy.linalg

from ...data.iodata import IOData
from ...errors import DataError, IllConditionedWarning, OptionError
from .sandwich import matrix_covariance
from ..structure.filters import check_alpha, divisors
from ...numerics.recursive_filter import recursive_filter
from ...numerics.triangular import fold, tall_factor
from .realization import realize
from .row_blocks import WHOLE_ROWS, lagged_blocks
from ...models.statespace import StateSpaceModel
from ..structure.rows import check_regression_rows, check_sample_count, regression_rows, row_breaks, row_count
from ..structure.indices import Indices, check_indices
from ...numerics.blas_threads import limited_blas

__all__ = [
    "filtered_regressors", "segment_filtered", "output_regressors", "solve_batch", "fit_batch",
    "check_sample_count", "estimate", "regressor_blocks",
]

# Condition numbers (of the column-scaled regressor) above this are reported:
# beyond it the solution has lost at least 10 of its 16 significant digits.
COND_LIMIT = 1e10


def filtered_regressors(z: np.ndarray, alpha_j: np.ndarray) -> np.ndarray:
    """Regressors ``(q^i/alpha_j(q)) z_r`` for all channels ``r`` and ``i = 0..l-1``.

    Parameters
    ----------
    z : ndarray, shape (N, c)
        Signals, zero initial filter state.
    alpha_j : ndarray, shape (l + 1,)
        Monic filter denominator.

    Returns
    -------
    ndarray, shape (N, c * l)
        Column ``r * l + i`` holds channel ``r`` filtered by ``q^i / alpha_j``.
    """
    N, c = z.shape
    l = alpha_j.size - 1
    base = recursive_filter([1.0], alpha_j, z, axis=0)
    phi = np.zeros((N, c, l))
    for i in range(l):
        delay = l - i
        phi[delay:, :, i] = base[: N - delay]
    return phi.reshape(N, c * l)


def segment_filtered(z: np.ndarray, alpha_j: np.ndarray, skip: int, starts: Sequence[int] = (0,)) -> np.ndarray:
    """:func:`filtered_regressors` of each segment from a zero filter state, at the :func:`regression_rows`."""
    if len(starts) == 1:
        return filtered_regressors(z, alpha_j)[skip:]
    stops = (*starts[1:], z.shape[0])
    return np.concatenate([filtered_regressors(z[a:b], alpha_j)[skip:] for a, b in zip(starts, stops)
                           if b - a > skip])


def output_regressors(
    z: np.ndarray, indices: Indices, alphas: Sequence[np.ndarray], through: np.ndarray | None = None,
    starts: Sequence[int] = (0,),
) -> list[np.ndarray]:
    """Each output's least-squares regressors, rows ``max(indices)..N-1`` (docs/method.md §3, §8).

    Output ``j``'s columns: :func:`filtered_regressors` with ``alphas[j]``, the earlier
    outputs ``y_i``, ``i < j``, and the current inputs when ``through[j]`` (feedthrough).
    A record of several segments (``starts``) stacks each segment's rows.
    """
    p = len(indices)
    skip = max(indices)
    rows = regression_rows(z, skip, starts)
    phis = []
    for j, alpha_j in enumerate(alphas):
        parts = [segment_filtered(z, alpha_j, skip, starts), rows[:, :j]]
        if through is not None and through[j]:
            parts.append(rows[:, p:])
        phis.append(np.concatenate(parts, axis=1))
    return phis


def regressor_blocks(
    z: np.ndarray, indices: Indices, alphas: Sequence[np.ndarray], through: np.ndarray | None = None,
    starts: Sequence[int] = (0,),
) -> Iterator[tuple[list[np.ndarray], np.ndarray]]:
    """:func:`output_regressors` and the targets ``y`` in row blocks (bounded memory).

    Yields each block's regressors of every output, shapes (rows_b, k_j), and its
    targets, shape (rows_b, p); concatenated, the blocks are :func:`output_regressors`
    and the targets at the :func:`regression_rows`. Each segment (``starts``) is filtered
    from rest and gives its rows from ``max(indices)`` samples on; no block spans two.
    """
    p = len(indices)
    skip = max(indices)
    signals = np.ascontiguousarray(z.T)
    bounds = tuple(zip(starts, (*starts[1:], z.shape[0])))
    streams = [lagged_blocks(signals, np.asarray(a, float), skip, bounds) for a in alphas]
    for parts in zip(*streams):
        k0, k1 = parts[0][:2]
        current = z[k0:k1]
        phis = []
        for j, (_, _, lagged) in enumerate(parts):
            columns = [lagged.transpose(2, 0, 1).reshape(k1 - k0, -1), current[:, :j]]
            if through is not None and through[j]:
                columns.append(current[:, p:])
            phis.append(np.concatenate(columns, axis=1))
        yield phis, current[:, :p]


def _streamed_fit(
    z: np.ndarray, indices: Indices, alphas: Sequence[np.ndarray], starts: Sequence[int] = (0,)
) -> tuple[list[np.ndarray], float]:
    """Each output's least-squares parameters from the factor of ``[phi_j | y_j]`` built in row blocks.

    ``|Phi theta - y| = |R11 theta - r12|`` up to a constant and ``R11`` has the column
    norms of ``Phi``, so :func:`solve_batch` on the small triangular problem gives the
    whole-record solution and condition estimate.
    """
    factors: list[np.ndarray | None] = [None] * len(indices)
    for phis, targets in regressor_blocks(z, indices, alphas, None, starts):
        for j, phi in enumerate(phis):
            factors[j] = fold(factors[j], np.concatenate([phi, targets[:, j : j + 1]], axis=1).T)
    thetas, worst = [], 1.0
    for r in factors:
        k = r.shape[1] - 1
        theta, cond = solve_batch(r[None, :k, :k], r[None, :k, k])
        thetas.append(theta)
        worst = max(worst, float(cond[0]))
    return thetas, worst


# Problems of at most this many rows (the reduced problems of a search, tens of rows)
# are factored as one stack by np.linalg.qr; taller ones (a record's rows) one by one.
STACKED_ROWS = 256


def _triangular_factor(aug: np.ndarray) -> np.ndarray:
    """R factors of a batch of matrices ``[phi | target]``: Q is never formed, and the last
    column of each R holds ``Q^T target``."""
    if aug.shape[1] <= STACKED_ROWS:
        return np.linalg.qr(aug, mode="r")
    return np.array([tall_factor(matrix) for matrix in aug])


def solve_batch(phi: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least squares ``phi[r] theta[r] ~ target[r]`` for a batch, by QR.

    Parameters
    ----------
    phi : ndarray, shape (R, N, k)
    target : ndarray, shape (R, N)

    Returns
    -------
    theta : ndarray, shape (R, k)
    cond : ndarray, shape (R,)
        Condition estimate ``max|r_ii| / min|r_ii|`` of the column-scaled problem.
        Rank-deficient problems get the minimum-norm solution.
    """
    norms = np.linalg.norm(phi, axis=1, keepdims=True)
    norms[norms == 0] = 1.0
    scaled = phi / norms
    k = phi.shape[2]
    r_aug = _triangular_factor(np.concatenate([scaled, target[..., None]], axis=2))
    r, rhs = r_aug[:, :k, :k], r_aug[:, :k, k]
    diag = np.abs(np.diagonal(r, axis1=1, axis2=2))
    with np.errstate(divide="ignore"):
        cond = diag.max(axis=1) / diag.min(axis=1)
    theta = np.empty(rhs.shape)
    good = cond < 1e13
    if good.any():
        theta[good] = np.linalg.solve(r[good], rhs[good][..., None])[..., 0]
    for i in np.flatnonzero(~good):
        theta[i] = scipy.linalg.lstsq(scaled[i], target[i])[0]
    return theta / norms[:, 0, :], cond


def fit_batch(
    z: np.ndarray, indices: Indices, alphas: Sequence[Sequence[np.ndarray]], starts: Sequence[int] = (0,)
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Estimate one model per candidate filter on the same data.

    Parameters
    ----------
    z : ndarray, shape (N, p + m)
        Outputs then inputs.
    indices : tuple of int
    alphas : sequence of sequences of ndarray
        ``alphas[r][j]``: divisor of output ``j`` for candidate ``r``.
    starts : sequence of int, default (0,)
        First sample of each segment: the filters restart there and no regressor row
        spans a boundary (:func:`regression_rows`).

    Returns
    -------
    A, B, C : ndarray
        Batch matrices, see :func:`realize`.
    cond : ndarray, shape (R,)
        Worst condition estimate over the outputs of each candidate.
    """
    p = len(indices)
    m = z.shape[1] - p
    skip = max(indices)
    R = len(alphas)
    thetas = []
    cond = np.ones(R)
    # filtered signals depend on the divisor alone: outputs and candidates that share
    # one (the same filter's divisor of the same degree) filter the data once
    filtered: dict[bytes, np.ndarray] = {}
    rows = regression_rows(z, skip, starts)
    for j, l in enumerate(indices):
        phis = []
        for r in range(R):
            key = np.asarray(alphas[r][j], float).tobytes()
            if key not in filtered:
                filtered[key] = segment_filtered(z, alphas[r][j], skip, starts)
            phis.append(np.concatenate([filtered[key], rows[:, :j]], axis=1))
        phi = np.stack(phis)
        theta, c = solve_batch(phi, np.broadcast_to(rows[:, j], phi.shape[:2]))
        thetas.append(theta)
        cond = np.maximum(cond, c)
    A, B, C = realize(thetas, alphas, indices, m)
    return A, B, C, cond


def estimate(
    data: IOData, indices: Sequence[int], alpha: Sequence[float], *, covariance: bool = True
) -> StateSpaceModel:
    """Estimate a model for a fixed list of indices and filter polynomial.

    Parameters
    ----------
    data : IOData
        Estimation data (remove means beforehand if the plant has offsets).
    indices : sequence of int
        Observability indices, one per output.
    alpha : array_like
        Monic, stable filter polynomial of degree ``max(indices)``, e.g. from
        :func:`moli.filter_polynomial`.
    covariance : bool, default True
        Attach the covariance of the model's matrices (``cov_factor``,
        docs/uncertainty.md), which the confidence bands need; False skips it (it
        adds up to twice the estimate's time, and holds the regressors twice).

    Returns
    -------
    StateSpaceModel
        Discrete-time model, no feedthrough, in the observer form's coordinates, with
        the covariance of its matrices (``cov_factor``, docs/uncertainty.md) unless a
        problem is rank deficient (``info["covariance"]`` then says so).

    Warns
    -----
    IllConditionedWarning
        If a least-squares problem is badly conditioned (poor excitation).
    UnstableModelWarning
        If the model has poles on or outside the unit circle.

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(300)
    >>> y = np.zeros(300)
    >>> for k in range(1, 300):
    ...     y[k] = 0.8 * y[k - 1] + 0.5 * u[k - 1]
    >>> model = moli.estimate(moli.IOData(y, u), [1], moli.filter_polynomial(1.0, 1.0, [1]))
    >>> np.round(model.poles().real, 6)
    array([0.8])
    """
    with limited_blas():
        if not isinstance(data, IOData):
            raise DataError(f"data must be an IOData, got {type(data).__name__}")
        if not isinstance(covariance, bool):
            raise OptionError(f"covariance must be True or False, got {covariance!r}")
        idx = check_indices(indices, data.p)
        coeffs = check_alpha(alpha)
        alphas = divisors(coeffs, idx)
        check_regression_rows(data.bounds, idx, data.m)
        z = np.concatenate([data.y, data.u], axis=1)
        starts = data.segment_starts
        if row_count(data.bounds, max(idx)) <= WHOLE_ROWS:
            A, B, C, cond = fit_batch(z, idx, [alphas], starts)
        else:                           # a long record: in row blocks, in bounded memory
            thetas, worst = _streamed_fit(z, idx, alphas, starts)
            A, B, C = realize(thetas, [alphas], idx, data.m)
            cond = np.array([worst])
        if cond[0] > COND_LIMIT:
            warnings.warn(
                f"least-squares problem for list {list(idx)} is badly conditioned "
                f"(condition ~{cond[0]:.2g}): the input may not excite the plant enough, or the "
                "order is too high for the data",
                IllConditionedWarning,
                stacklevel=2,
            )
        model = StateSpaceModel(
            A[0], B[0], C[0], Ts=data.Ts, output_names=data.output_names,
            input_names=data.input_names, indices=idx, alpha=coeffs,
            y_offset=data.y_offset, u_offset=data.u_offset,
        )
        if covariance:
            _attach_covariance(model, z, idx, alphas, starts)
        model.warn_if_unstable(stacklevel=2)
        return model


def _attach_covariance(
    model: StateSpaceModel, z: np.ndarray, indices: Indices, alphas: Sequence[np.ndarray], starts: Sequence[int]
) -> None:
    """Give ``model`` the covariance of its matrices, or record in its ``info`` why it has none."""
    p = len(indices)
    skip = max(indices)
    through = np.zeros(p, bool)
    bounds = tuple(zip(starts, (*starts[1:], z.shape[0])))
    try:
        if row_count(bounds, skip) <= WHOLE_ROWS:
            problems = (output_regressors(z, indices, alphas, None, starts), regression_rows(z, skip, starts)[:, :p])
        else:                       # a long record: its problems in row blocks, in bounded memory
            problems = lambda: regressor_blocks(z, indices, alphas, through, starts)  # noqa: E731
        model.cov_factor, model.info["covariance"] = matrix_covariance(
            problems, indices, model.C, model.D, through, breaks=row_breaks(starts, z.shape[0], skip))
    except DataError as exc:
        model.info["covariance"] = {"method": "none", "reason": str(exc)}
