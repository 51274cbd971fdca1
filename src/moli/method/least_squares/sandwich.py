"""The covariance of the per-output least-squares parameters, and its image in ``A, B, C, D``.

Output ``j``'s parameters come from ``y_j = Phi_j theta_j + e_j`` (docs/method.md §3).
Their joint covariance is the sandwich

    Cov(theta) = (Phi^T Phi)^-1 S (Phi^T Phi)^-1,

with ``S`` the long-run (Newey-West, Bartlett kernel) covariance of the scores
``phi_t e_t`` of all outputs together: the equation errors are coloured, and a plain
``sigma^2 (Phi^T Phi)^-1`` misjudges the spread (docs/uncertainty.md §2). ``S`` is
the Gram matrix of the scores' moving sums, ``S = W^T W``; the covariance is
``F^T F`` with ``F = [W_j R_j^-1 R_j^-T]_j``, from the triangular factors ``R_j`` of the
column-scaled problems by triangular solves: no normal equations are formed or inverted.
The model's matrices are smooth functions of ``theta`` through the observer-form
realization (docs/method.md §4, §8); :func:`matrix_directions` is its Jacobian.
"""

from __future__ import annotations

import math
from typing import Callable, Iterable, Iterator, Sequence

import numpy as np
import scipy.linalg

from ...errors import DataError
from ...numerics.triangular import TALL_QR_BLOCK, fold, streamed_factor

__all__ = ["sandwich_factor", "streamed_sandwich_factor", "long_run_covariance",
           "matrix_directions", "matrix_covariance", "sandwich_root", "check_rank"]

# A problem whose column-scaled factor has max|r_ii| / min|r_ii| beyond this gets the
# minimum-norm solution in the estimation (solve_batch): its parameters are not
# determined by the data, and neither is their covariance.
RANK_LIMIT = 1e13
# AR(1) coefficients of the scores are capped here before they enter the bandwidth
# rule, which grows like (1 - rho)^(-4/3): a near-unit root would ask for a kernel as
# long as the record.
MAX_SCORE_CORRELATION = 0.97
# The kernel never spans more than this share of the rows: beyond it the long-run
# covariance is a sum over too few independent stretches to be estimated at all.
MAX_WIDTH_SHARE = 0.25
# Rows reduced at a time, by the QR of each problem and in the moving sums of the
# scores: blocks stay in cache, and of the moving sums only their Gram matrix is kept.
BLOCK_ROWS = 8192


def _separated(scores: np.ndarray, breaks: Sequence[int], gap: int) -> np.ndarray:
    """``scores`` with ``gap`` zero rows inserted before each row of ``breaks`` (segment starts).

    With ``width - 1`` zero rows between segments, no moving sum of ``width`` rows spans
    two of them: the long-run covariance is the sum of each segment's own.
    """
    if not breaks or gap == 0:
        return scores
    return np.insert(scores, np.repeat(np.asarray(breaks), gap), 0.0, axis=0)


def _bandwidth(scores: np.ndarray, rows: int) -> int:
    """Bartlett kernel width from Andrews' (1991) AR(1) plug-in rule, for ``rows`` scores.

    Each score column is read as an AR(1) with coefficient ``rho_a``. With unit
    variances the rule's ``alpha(1)`` is ``sum 4 rho^2 / (1 - rho)^4`` over
    ``sum (1 + rho)^2 / (1 - rho)^2``, which weighs every column alike whatever its
    units; the width is ``1.1447 (alpha(1) N)^(1/3)``, rounded up.
    """
    lagged = np.einsum("ta,ta->a", scores[1:], scores[:-1])
    power = np.einsum("ta,ta->a", scores[:-1], scores[:-1])
    return _width(lagged, power, rows)


def _width(lagged: np.ndarray, power: np.ndarray, rows: int) -> int:
    """:func:`_bandwidth` from the scores' lag-one and lag-zero sums over ``rows`` rows."""
    rho = np.divide(lagged, power, out=np.zeros_like(lagged), where=power > 0)
    rho = np.clip(rho, -MAX_SCORE_CORRELATION, MAX_SCORE_CORRELATION)
    alpha1 = np.sum(4 * rho**2 / (1 - rho) ** 4) / np.sum((1 + rho) ** 2 / (1 - rho) ** 2)
    width = math.ceil(1.1447 * (alpha1 * rows) ** (1 / 3))
    return int(min(max(width, 1), max(1, MAX_WIDTH_SHARE * rows)))


def _moving_sums(scores: np.ndarray, width: int, start: int, stop: int) -> np.ndarray:
    """Rows ``start..stop-1`` of ``b_t = sum_{i<width} s_(t-i)``, ``s`` zero outside the record.

    ``sum_t b_t b_t^T / width`` over ``t = 0..N+width-2`` is exactly the Bartlett
    (Newey-West) sum ``sum_|h|<width (1 - |h|/width) Gamma_h``, and positive
    semidefinite. The cumulative sums run over one block of zero-mean scores (normal
    equations), so they stay small and their differences keep their digits.
    """
    first = max(start - width + 1, 0)
    window = np.zeros((stop - start + width, scores.shape[1]))
    taken = scores[first : min(stop, scores.shape[0])]
    at = 1 + first - (start - width + 1)          # row 0 stays zero: sums[0] = 0
    window[at : at + taken.shape[0]] = taken
    sums = np.cumsum(window, axis=0)
    return sums[width:] - sums[:-width]


def sandwich_factor(
    phis: Sequence[np.ndarray], targets: np.ndarray, breaks: Sequence[int] = ()
) -> tuple[np.ndarray, list[np.ndarray], int]:
    """Joint covariance factor of every output's least-squares parameters.

    Parameters
    ----------
    phis : sequence of ndarray
        Output ``j``'s regressors, shape (N', k_j), the same rows for every output.
    targets : ndarray, shape (N', p)
    breaks : sequence of int, default ()
        Rows where a new segment of the record starts: the scores of two segments are
        not correlated with each other (no lag spans a boundary).

    Returns
    -------
    factor : ndarray, shape (P, P)
        ``Cov(theta) = factor.T @ factor`` for the stacked ``theta = [theta_1, ...,
        theta_p]`` (``P = sum k_j``): each row is one independent direction.
    thetas : list of ndarray
        The least-squares solutions.
    width : int
        Bartlett kernel width (lags ``0..width-1`` enter the long-run covariance).

    Raises
    ------
    DataError
        A problem is rank deficient.
    """
    rows = targets.shape[0]
    splits = np.cumsum([phi.shape[1] for phi in phis])[:-1]
    # the scores of all outputs, output j's in its own columns: phi_t e_t, phi scaled
    stacked = np.empty((rows, sum(phi.shape[1] for phi in phis)))
    solved, thetas = [], []
    for j, (phi, scores) in enumerate(zip(phis, np.split(stacked, splits, axis=1))):
        k = phi.shape[1]
        norms = np.linalg.norm(phi, axis=0)
        norms[norms == 0] = 1.0
        # block by block: a tall QR in one piece runs out of cache and is several times slower
        r = streamed_factor((np.column_stack([phi[start : start + BLOCK_ROWS] / norms,
                                              targets[start : start + BLOCK_ROWS, j]]).T
                             for start in range(0, rows, BLOCK_ROWS)), TALL_QR_BLOCK)
        check_rank(np.abs(np.diagonal(r)[:k]), j)
        solution = scipy.linalg.solve_triangular(r[:k, :k], r[:k, k])
        np.divide(phi, norms, out=scores)
        scores *= (targets[:, j] - scores @ solution)[:, None]
        thetas.append(solution / norms)
        # columns back in theta's units, and rows / (N' - k) in place of rows / N'
        solved.append((r[:k, :k], norms / math.sqrt(rows / (rows - k))))
    long_run, width = long_run_covariance(stacked, breaks)
    return sandwich_root(long_run, solved, splits), thetas, width


def long_run_covariance(scores: np.ndarray, breaks: Sequence[int] = ()) -> tuple[np.ndarray, int]:
    """Newey-West (Bartlett kernel) long-run covariance of the rows of ``scores``, and its width.

    ``breaks``: the rows where a new segment starts; no lag spans a boundary. The width
    comes from :func:`_bandwidth`; the sum is that of the moving sums' Gram matrix.
    """
    # one zero row at each boundary keeps the lag-1 products inside the segments
    width = _bandwidth(_separated(scores, breaks, 1), scores.shape[0])
    stacked = _separated(scores, breaks, width - 1)
    total = stacked.shape[0] + width - 1
    meat = np.zeros((stacked.shape[1],) * 2)
    for start in range(0, total, BLOCK_ROWS):
        block = _moving_sums(stacked, width, start, min(start + BLOCK_ROWS, total))
        meat += block.T @ block
    return meat / width, width


def sandwich_root(long_run: np.ndarray, solved: list[tuple[np.ndarray, np.ndarray]], splits: np.ndarray) -> np.ndarray:
    """``F`` with ``F^T F = (R^T R)^-1 S (R^T R)^-1`` per output block, ``S`` the long-run covariance."""
    # any square root of the (positive semidefinite) long-run covariance will do:
    # S = root^T root, with round-off's tiny negative eigenvalues set to zero
    values, vectors = np.linalg.eigh(long_run)
    root = np.sqrt(np.clip(values, 0.0, None))[:, None] * vectors.T
    parts = []
    for (r, scale), columns in zip(solved, np.split(root, splits, axis=1)):
        # root (R^T R)^-1 by two triangular solves
        inner = scipy.linalg.solve_triangular(r, columns.T, trans="T")
        parts.append(scipy.linalg.solve_triangular(r, inner).T / scale)
    return np.concatenate(parts, axis=1)


def check_rank(diag: np.ndarray, j: int) -> None:
    if not diag.min() > 0 or diag.max() / diag.min() >= RANK_LIMIT:
        raise DataError(
            f"the least-squares problem of output {j + 1} is rank deficient: its parameters, "
            "and so their covariance, are not determined by the data"
        )


def streamed_sandwich_factor(
    blocks: Callable[[], Iterable[tuple[list[np.ndarray], np.ndarray]]], breaks: Sequence[int] = (),
) -> tuple[np.ndarray, list[np.ndarray], int, int]:
    """:func:`sandwich_factor` of problems given in row blocks, in memory bounded by a block.

    ``blocks()`` returns a fresh iterator of ``(phis, targets)`` row blocks (as
    :func:`moli.method.least_squares.estimation.regressor_blocks` yields them); it is read three
    times: the triangular factors, the scores' lag-one correlation (the kernel width),
    and the moving sums of the scores. ``breaks``: the rows where the record's segments
    start, as :func:`sandwich_factor` takes them (no lag spans a boundary). Same
    quantities as :func:`sandwich_factor` up to round-off; also returns the number of rows.
    """
    factors: list[np.ndarray | None] = []
    rows = 0
    for phis, targets in blocks():
        factors = factors or [None] * len(phis)
        for j, phi in enumerate(phis):
            factors[j] = fold(factors[j], np.concatenate([phi, targets[:, j : j + 1]], axis=1).T)
        rows += targets.shape[0]
    solved, thetas, scales = [], [], []
    for j, r in enumerate(factors):
        k = r.shape[1] - 1
        norms = np.linalg.norm(r[:, :k], axis=0)          # the regressors' column norms
        norms[norms == 0] = 1.0
        scaled = r / np.append(norms, 1.0)                 # the factor of [phi / norms, y]
        check_rank(np.abs(np.diagonal(scaled)[:k]), j)
        solution = scipy.linalg.solve_triangular(scaled[:k, :k], scaled[:k, k])
        thetas.append(solution / norms)
        scales.append((norms, solution))
        solved.append((scaled[:k, :k], norms / math.sqrt(rows / (rows - k))))
    splits = np.cumsum([len(norms) for norms, _ in scales])[:-1]

    def scores() -> Iterable[np.ndarray]:
        for phis, targets in blocks():
            parts = []
            for j, (phi, (norms, solution)) in enumerate(zip(phis, scales)):
                scaled = phi / norms
                parts.append(scaled * (targets[:, j] - scaled @ solution)[:, None])
            yield np.concatenate(parts, axis=1)

    size = int(sum(len(norms) for norms, _ in scales))
    lagged, power, previous = np.zeros(size), np.zeros(size), None
    # one zero row at each boundary keeps the lag-1 products inside the segments
    for block in _separated_blocks(scores(), breaks, 1, size):
        joined = block if previous is None else np.concatenate([previous, block])
        lagged += np.einsum("ta,ta->a", joined[1:], joined[:-1])
        power += np.einsum("ta,ta->a", joined[:-1], joined[:-1])
        previous = block[-1:]
    width = _width(lagged, power, rows)
    meat = np.zeros((size, size))
    history = np.zeros((width - 1, size))               # the scores before the block (zero before the record)
    for block in _with_zero_tail(_separated_blocks(scores(), breaks, width - 1, size), width - 1, size):
        window = np.concatenate([np.zeros((1, size)), history, block])
        sums = np.cumsum(window, axis=0)
        moving = sums[width:] - sums[:-width]
        meat += moving.T @ moving
        history = window[window.shape[0] - (width - 1) :] if width > 1 else history
    return sandwich_root(meat / width, solved, splits), thetas, width, rows


def _separated_blocks(blocks: Iterable[np.ndarray], breaks: Sequence[int], gap: int, size: int) -> Iterator[np.ndarray]:
    """The score blocks with ``gap`` zero rows before each row of ``breaks``: :func:`_separated` in blocks."""
    pending = list(breaks)
    done = 0                                             # rows of the record before the block
    for block in blocks:
        at = 0
        while pending and pending[0] < done + block.shape[0]:
            cut = pending.pop(0) - done
            if cut > at:
                yield block[at:cut]
            if gap:
                yield np.zeros((gap, size))
            at = cut
        if at < block.shape[0]:
            yield block[at:]
        done += block.shape[0]


def _with_zero_tail(blocks: Iterable[np.ndarray], rows: int, size: int) -> Iterator[np.ndarray]:
    """The blocks, then ``rows`` zero rows (the moving sums run ``width - 1`` rows past the record)."""
    yield from blocks
    if rows:
        yield np.zeros((rows, size))


def _observer_parts(
    indices: Sequence[int], p: int, m: int, through: np.ndarray, theta: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The observer-form pieces ``D_y, B_o, G, F`` that each row of stacked parameters holds.

    ``theta`` stacks every output's ``[(p + m) l_j filter coefficients, g_j (j entries),
    f_j (m entries, when through[j])]``, the columns of :func:`output_regressors`
    (docs/method.md §4, §8). Shapes (rows, n, p), (rows, n, m), (rows, p, p), (rows, p, m).
    """
    count, n = theta.shape[0], sum(indices)
    D_y, B_o = np.zeros((count, n, p)), np.zeros((count, n, m))
    G, F = np.zeros((count, p, p)), np.zeros((count, p, m))
    at, state = 0, 0
    for j, l in enumerate(indices):
        k = (p + m) * l
        coeffs = theta[:, at : at + k].reshape(count, p + m, l).transpose(0, 2, 1)
        D_y[:, state : state + l] = coeffs[:, :, :p]
        B_o[:, state : state + l] = coeffs[:, :, p:]
        G[:, j, :j] = theta[:, at + k : at + k + j]
        at += k + j
        if through[j]:
            F[:, j] = theta[:, at : at + m]
            at += m
        state += l
    return D_y, B_o, G, F


def matrix_directions(
    indices: Sequence[int], C: np.ndarray, D: np.ndarray, D_y: np.ndarray, through: np.ndarray,
    dtheta: np.ndarray,
) -> np.ndarray:
    """First-order changes of ``[A, B, C, D]`` (flattened, row-major) for each row of ``dtheta``.

    ``dtheta`` is laid out as in :func:`_observer_parts`. ``C``, ``D`` are the model's,
    ``D_y`` its output injection (``A = A_D + D_y C``). With ``H = (I - G)^-1`` (``C``'s
    columns at the blocks' last states): ``dC = H dG C``, ``dD = H (dG D + dF)``,
    ``dA = dD_y C + D_y dC`` and ``dB = dB_o + dD_y D + D_y dD`` (docs/uncertainty.md §3).

    Returns
    -------
    ndarray, shape (len(dtheta), n n + n m + p n + p m)
    """
    d_inj, d_b, d_g, d_f = _observer_parts(indices, C.shape[0], D.shape[1], through, dtheta)
    H = C[:, np.cumsum(indices) - 1]
    dC = H @ d_g @ C
    dD = H @ (d_g @ D + d_f)
    dA = d_inj @ C + D_y @ dC
    dB = d_b + d_inj @ D + D_y @ dD
    return np.concatenate([d.reshape(dtheta.shape[0], -1) for d in (dA, dB, dC, dD)], axis=1)


def matrix_covariance(
    problems: tuple[Sequence[np.ndarray], np.ndarray] | Callable[[], Iterable[tuple[list[np.ndarray], np.ndarray]]],
    indices: Sequence[int], C: np.ndarray, D: np.ndarray, through: np.ndarray, D_y: np.ndarray | None = None,
    *, breaks: Sequence[int] = (),
) -> tuple[np.ndarray, dict[str, object]]:
    """``cov_factor`` of a model from its least-squares problems, and the record for its ``info``.

    ``problems``: every output's regressors and the targets, ``(phis, targets)`` as
    :func:`sandwich_factor` takes them, or a function that returns a fresh iterator of
    their row blocks (:func:`streamed_sandwich_factor`, for long records). ``D_y``: the
    model's output injection, where the Jacobian is taken; None takes the least-squares
    solution's (the model is that estimate). ``breaks``: the rows where the record's
    segments start (:func:`sandwich_factor`). Raises :class:`DataError` when a problem
    is rank deficient.
    """
    if callable(problems):
        factor, thetas, width, rows = streamed_sandwich_factor(problems, breaks)
    else:
        factor, thetas, width = sandwich_factor(*problems, breaks)
        rows = problems[1].shape[0]
    if D_y is None:
        D_y = _observer_parts(indices, C.shape[0], D.shape[1], through, np.concatenate(thetas)[None])[0][0]
    record = {"method": "least squares, Newey-West", "kernel_width": width, "rows": rows,
              "parameters": factor.shape[1]}
    return matrix_directions(indices, C, D, D_y, through, factor).T, record
