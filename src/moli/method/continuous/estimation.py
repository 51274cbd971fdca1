"""Continuous-time least squares: a record's stamps, its filtered regressors, the fit.

docs/continuous.md §2-§4. A record is cut into segments (its own segments, and steps
longer than ``gap_factor`` median steps); every segment's filters start from zero at
its first stamp. For a filter ``alpha`` of degree ``nbar`` in the filter's time unit
``tau = wc t``, the observer state holds every channel filtered by
``s^t / alpha(s)``, ``t = 0..nbar-1``: the state of ``xi' = F xi + e_nbar z``, ``F``
the companion matrix of ``alpha``, propagated exactly between stamps
(:func:`~moli.models.propagation.propagate`). Each output's regression is
the discrete one (docs/method.md §3) with ``s`` in place of ``q``, so the discrete
route from one triangular factor per filter to every output's problem carries over
unchanged, and so does the observer form (docs/method.md §4): ``x' = A x + B u``,
``y = C x`` in units of ``tau``, then ``A = wc A_tau``, ``B = wc B_tau``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ...data.iodata import IOData
from ...errors import DataError
from ..least_squares.realization import observer_form_matrices
from ..least_squares.shared_factors import quotient_map, reduced_problems
from ..structure.indices import Indices
from .filters import unit_divisors
from ...models.propagation import propagate

__all__ = ["StampedRecord", "stamped_record", "observer_rows", "filter_factor", "fit_list", "model_part",
           "output_problems", "solve_scaled", "simulate_stamped", "warm_up_rows"]

# A step longer than this many median steps starts a new segment (samples missing):
# the input over it is unknown, so no inter-sample assumption bridges it.
GAP_FACTOR = 5.0


@dataclass(frozen=True)
class StampedRecord:
    """A record as the continuous-time identification reads it.

    Attributes
    ----------
    times : tuple of ndarray
        Each segment's stamps (strictly increasing).
    y, u : tuple of ndarray
        Each segment's outputs (N_s, p) and inputs (N_s, m).
    """

    times: tuple[np.ndarray, ...]
    y: tuple[np.ndarray, ...]
    u: tuple[np.ndarray, ...]

    @property
    def p(self) -> int:
        """Number of outputs."""
        return self.y[0].shape[1]

    @property
    def m(self) -> int:
        """Number of inputs."""
        return self.u[0].shape[1]

    def steps(self) -> np.ndarray:
        """Every step between consecutive stamps of a segment."""
        return np.concatenate([np.diff(t) for t in self.times])

    def durations(self) -> np.ndarray:
        """Each segment's span from its first stamp to its last."""
        return np.array([t[-1] - t[0] for t in self.times])

    def rows(self, skip: int) -> int:
        """Regression rows when each segment drops its first ``skip`` samples."""
        return sum(max(t.size - skip, 0) for t in self.times)

    def with_rows(self, skip: int) -> int:
        """Segments that keep rows when each drops its first ``skip`` samples: each has a
        transient channel (:func:`observer_rows`)."""
        return sum(t.size > skip for t in self.times)


def stamped_record(data: IOData, gap_factor: float = GAP_FACTOR) -> StampedRecord:
    """``data``'s stretches between steps over ``gap_factor`` median steps.

    The stamps are ``data.times`` when the record carries them, else ``k * Ts``.
    Consecutive segments of ``data`` whose stamps continue across the boundary (a step
    forward within the bound) are one stretch: the readers' cuts at steps of 1.5
    periods and at missing samples are gaps of a sampled model only. Segments whose
    stamps restart (separate experiments) or jump further stay apart.
    """
    stamps = data.time()
    pieces: list[tuple[int, int]] = []
    for start, stop in data.bounds:
        steps = np.diff(stamps[start:stop])
        if np.any(steps <= 0):
            k = start + 1 + int(np.flatnonzero(steps <= 0)[0])
            raise DataError(f"time stamps must increase within a segment: sample {k} is at "
                            f"{stamps[k]:g}, after {stamps[k - 1]:g}")
        pieces.append((start, stop))
    steps = np.concatenate([np.diff(stamps[a:b]) for a, b in pieces])
    if steps.size == 0:
        raise DataError("the record has no two stamps in one segment: continuous time needs steps")
    limit = gap_factor * float(np.median(steps))
    # a segment boundary the stamps step over within the bound is rejoined: the readers
    # cut at steps of 1.5 periods and at missing samples, which are a sampled model's
    # gaps, not a continuous one's
    joined = [pieces[0]]
    for start, stop in pieces[1:]:
        if 0 < stamps[start] - stamps[joined[-1][1] - 1] <= limit and start == joined[-1][1]:
            joined[-1] = (joined[-1][0], stop)
        else:
            joined.append((start, stop))
    cut: list[tuple[int, int]] = []
    for start, stop in joined:
        breaks = start + 1 + np.flatnonzero(np.diff(stamps[start:stop]) > limit)
        edges = [start, *breaks.tolist(), stop]
        cut += [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b - a >= 2]
    return StampedRecord(
        tuple(stamps[a:b].copy() for a, b in cut), tuple(data.y[a:b] for a, b in cut),
        tuple(data.u[a:b] for a, b in cut),
    )


def _companion(alpha: np.ndarray) -> np.ndarray:
    """``F`` with ``xi_t = s^t / alpha(s) z``: ones above the diagonal, last row ``-a``."""
    nbar = alpha.size - 1
    F = np.diag(np.ones(nbar - 1), 1)
    F[-1] = -alpha[:0:-1]
    return F


def observer_rows(record: StampedRecord, wc: float, alpha: np.ndarray, linear_inputs: bool,
                  skip: int) -> list[np.ndarray]:
    """Per segment, the rows ``[xi, y, 1]``, the first ``skip`` dropped.

    ``xi`` has ``nbar`` columns (``r nbar + t``) for each of the ``p + m`` channels, then
    for each segment (with rows) the channel of an impulse at its first stamp, zero in
    the other segments: its filtered values ``exp(F tau) e_nbar`` span every transient
    of the observer's unknown initial state there. The last column, 1 throughout, takes
    up the offset of a record centred on means that are not an equilibrium: a constant
    filtered from rest is that constant's steady value plus the impulse channel's
    transients (docs/continuous.md §4).

    Parameters
    ----------
    record : StampedRecord
    wc : float
        The filter's cutoff: its time unit is ``1 / wc``.
    alpha : ndarray
        The filter polynomial for ``wc = 1`` (:func:`unit_divisors`).
    linear_inputs : bool
        Inputs linear between samples (else held); outputs are always linear.
    skip : int
        Samples dropped at each segment's start.

    Returns
    -------
    list of ndarray
        One array of shape (N_s - skip, (p + m + S) nbar + p + 1) per segment with rows.
    """
    nbar = alpha.size - 1
    F = _companion(alpha)
    G = np.eye(nbar)[:, -1:]
    p, m, S = record.p, record.m, record.with_rows(skip)
    linear = np.array([[True] * p + [linear_inputs] * m])
    rows = []
    kept = [k for k, t in enumerate(record.times) if t.size > skip]
    for k, (t, y, u) in enumerate((record.times[i], record.y[i], record.u[i]) for i in kept):
        z = np.concatenate([y, u], axis=1)
        xi = np.zeros((t.size, nbar, p + m + S))
        xi[:, :, : p + m] = propagate(F, G, wc * (t - t[0]), z[:, None, :], linear)
        xi[:, :, p + m + k] = propagate(F, G, wc * (t - t[0]), np.zeros((t.size, 1, 1)),
                                        np.zeros((1, 1), bool), start=G)[:, :, 0]
        rows.append(np.concatenate([xi.transpose(0, 2, 1).reshape(t.size, -1), y, np.ones((t.size, 1))],
                                   axis=1)[skip:])
    return rows


def filter_factor(record: StampedRecord, wc: float, alpha: np.ndarray, linear_inputs: bool,
                  skip: int) -> np.ndarray:
    """Triangular factor of the stacked rows of :func:`observer_rows`."""
    rows = np.concatenate(observer_rows(record, wc, alpha, linear_inputs, skip))
    return scipy.linalg.qr(rows, mode="r", check_finite=False)[0][: rows.shape[1]]


def output_problems(factor: np.ndarray, alpha: np.ndarray, divisors: list[np.ndarray],
                    p: int, channels: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each output's least-squares problem ``(matrix, target)`` reduced by ``factor``."""
    problems = []
    for j, alpha_j in enumerate(divisors):
        quotient = quotient_map(alpha, alpha_j)
        # the constant column rides where the discrete route puts a feedthrough input
        matrix, target = reduced_problems(factor[None], quotient[None], channels, p, j, 1)
        problems.append((matrix[0], target[0]))
    return problems


def model_part(theta: np.ndarray, l: int, p: int, m: int, channels: int) -> np.ndarray:
    """Output parameters without the nuisances (transients, offset): the ``(p + m) l``
    filter weights, then the ``y_<j`` ones."""
    return np.concatenate([theta[: (p + m) * l], theta[channels * l : -1]])


def solve_scaled(matrix: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Least squares with unit-norm columns (the minimum-norm solution when rank deficient)."""
    scale = np.linalg.norm(matrix, axis=0)
    scale[scale == 0] = 1.0
    theta = np.linalg.lstsq(matrix / scale, target, rcond=None)[0]
    return theta / scale


def fit_list(factor: np.ndarray, wc: float, zeta: float, indices: Indices, s: float, m: int
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[np.ndarray]]:
    """The list's model fitted with the filter ``(wc, zeta)``.

    Parameters
    ----------
    factor : ndarray
        Triangular factor of the filter's rows (:func:`filter_factor`).
    wc, zeta : float
        The filter.
    indices : tuple of int
    s : float
        Root spacing factor.
    m : int
        Number of inputs.

    Returns
    -------
    A, B, C : ndarray
        Shapes (n, n), (n, m), (p, n), per time unit of the stamps.
    thetas : list of ndarray
        Each output's parameters, the nuisance ones (transients, offset) included.
    """
    alpha, *divisors = unit_divisors(zeta, indices, s)
    p, nbar = len(indices), alpha.size - 1
    channels = (factor.shape[1] - p - 1) // nbar
    thetas = [solve_scaled(*problem) for problem in output_problems(factor, alpha, divisors, p, channels)]
    parts = [model_part(theta, l, p, m, channels)[None] for theta, l in zip(thetas, indices)]
    A, B, C, _ = observer_form_matrices(parts, [divisors], indices, m)
    return wc * A[0], wc * B[0], C[0], thetas


def warm_up_rows(size: int, share: float, n: int, p: int) -> int:
    """Samples of a segment of ``size`` on which its initial state is fitted: ``share`` of
    them, and at least twice the equations its ``n`` states and ``p`` offsets need."""
    return min(max(int(np.ceil(share * size)), 2 * -(-(n + p) // p)), size)


def simulate_stamped(A: np.ndarray, B: np.ndarray, C: np.ndarray, record: StampedRecord,
                     linear_inputs: bool, warm_up: float = 1.0, *, states: int | None = None) -> list[np.ndarray]:
    """Each segment's simulated outputs, from the initial state that fits it best.

    A record cut at gaps starts its segments mid-motion, so each segment's initial
    state is the least-squares fit of the free responses ``C exp(A t) e_i`` (beside a
    constant per output) to what the forced response leaves on the segment's first
    ``warm_up`` share of samples (docs/continuous.md §5), and at least the samples
    ``states`` states need (:func:`warm_up_rows`; default the model's own order).
    """
    n = A.shape[0]
    linear = np.full((record.m, 1), linear_inputs)
    out = []
    for t, y, u in zip(record.times, record.y, record.u):
        rows = warm_up_rows(t.size, warm_up, n if states is None else states, y.shape[1])
        forced = propagate(A, B, t - t[0], u[:, :, None], linear)[:, :, 0] @ C.T
        free = C @ propagate(A, np.zeros((n, 1)), t - t[0], np.zeros((t.size, 1, n)),
                             np.zeros((1, n), bool), start=np.eye(n))                  # (N, p, n)
        if np.all(np.isfinite(free)) and np.all(np.isfinite(forced)):
            # with an offset per output: the record's means need not be an equilibrium
            basis = np.concatenate([free, np.broadcast_to(np.eye(y.shape[1]), (t.size,) + (y.shape[1],) * 2)], axis=2)
            fitted = np.linalg.lstsq(basis[:rows].reshape(-1, basis.shape[2]), (y - forced)[:rows].ravel(),
                                     rcond=None)[0]
            forced = forced + free @ fitted[:n] + fitted[n:]
        out.append(forced)
    return out
