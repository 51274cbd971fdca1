"""The two-stage method for closed-loop records: each input replaced by its part the reference explains.

Under feedback a plant input is ``u = S_u r + S_v v``: a part made by the logged
references ``r`` (set-points, dither) through the loop, and a part made by the output
noise ``v`` through the controller. The second part is correlated with the noise, so an
open-loop method fitted on ``(u, y)`` is biased. The first part is independent of the
noise. Stage one estimates it as a causal FIR regression of each input on the references
(lags ``0..L`` of every reference and an intercept), ``u_hat = F(q) r``; stage two
identifies the plant on ``(u_hat, y)``. Its error ``y - G u_hat = G S_v v + v`` is then
uncorrelated with the regressors, so the plant estimate is consistent and the usual
sandwich covariances hold (docs/closed_loop.md §2; Van den Hof and Schrama, 1993).

``L`` is chosen by AIC among ``0, 1, 2, 4, 8, ...`` up to a bound set by the record's
rows (:data:`ROWS_PER_COEFFICIENT`) and :data:`MAX_LAGS`. Too short a FIR leaves part of
the reference's effect in the error, correlated with ``u_hat``: a bias. BIC's heavier
penalty chose ``L = 0`` or 1 on PI loops whose inputs are mostly noise-driven, with gain
bias of 2 standard deviations; AIC and a fixed ``L = 16`` removed most of it
(docs/closed_loop.md §4). The lags are nested, so one
triangular factor of ``[regressors | inputs]`` gives every candidate's residual sums (the
norm of the trailing part of ``Q^T u``), streamed in row blocks: memory is that factor,
whatever the record's length. Before its first sample a reference is taken as constant at
its first value (a set-point held before the record starts).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..data.iodata import IOData
from ..errors import DataError, WeakReferenceWarning
from .row_blocks import BLOCK_ROWS, streamed_factor

__all__ = ["FirstStage", "ReferenceProjection", "fit_projection", "two_stage_records", "without_reference"]

# Longest FIR of the first stage: 128 samples cover the loop's settling on the records
# moli is used on; the factor holds (1 + r (L + 1) + m)^2 values.
MAX_LAGS = 128
# Rows of the first-stage regression per coefficient of one input's FIR at the longest
# lag count allowed, so that the noise in u_hat from the FIR's own estimate stays small.
ROWS_PER_COEFFICIENT = 10
# An input of which the references explain less than this share of the variance is
# driven by the noise, not the references: the second stage then has little to go on.
WEAK_SHARE = 0.05


@dataclass(frozen=True)
class FirstStage:
    """The first stage's regressors and residuals on the samples of a record, as the covariance
    of the second stage needs them: the plant estimate depends on the FIR estimate through
    ``u_hat``, and the FIR's estimation error widens the plant's bands (docs/closed_loop.md §3).

    Attributes
    ----------
    design : ndarray, shape (N, 1 + r (L + 1))
        The FIR's regressors per sample.
    residual : ndarray, shape (N, m)
        Each plant input less its projection.
    """

    design: np.ndarray
    residual: np.ndarray

    def rows(self, bounds: tuple[tuple[int, int], ...], left_out: list[int], samples: int | None) -> "FirstStage":
        """The rows of the segments not ``left_out``, then the first ``samples`` of them (all when None):
        the samples :func:`moli.method.records.long_segments` and the search window keep."""
        kept = np.concatenate([np.arange(a, b) for i, (a, b) in enumerate(bounds) if i not in left_out])
        kept = kept[:samples] if samples is not None else kept
        return FirstStage(self.design[kept], self.residual[kept])


@dataclass(frozen=True)
class ReferenceProjection:
    """The first stage of the two-stage method: a FIR from the references to each plant input.

    Attributes
    ----------
    reference : tuple of str
        The references' channel names.
    inputs : tuple of str
        The plant inputs' names.
    lags : int
        ``L``: each input is regressed on the references at lags ``0..L``.
    coefficients : ndarray, shape (1 + r (L + 1), m)
        Intercept, then the references at lag 0, lag 1, ... (every reference per lag).
    explained : ndarray, shape (m,)
        Share of each input's variance (about its mean) that the references explain.
    """

    reference: tuple[str, ...]
    inputs: tuple[str, ...]
    lags: int
    coefficients: np.ndarray
    explained: np.ndarray

    def project(self, data: IOData) -> IOData:
        """``data`` with its plant inputs replaced by their projections and the references dropped."""
        design, plant = self._design(data)
        return _with_inputs(data, design @ self.coefficients, plant)

    def first_stage(self, data: IOData) -> FirstStage:
        """The regressors and residuals of the first stage on ``data`` (the record it was fitted on)."""
        design, plant = self._design(data)
        return FirstStage(design, data.u[:, plant] - design @ self.coefficients)

    def _design(self, data: IOData) -> tuple[np.ndarray, list[int]]:
        r, plant = _columns(data, self.reference)
        return np.concatenate([_lagged(r[a:b], self.lags, 0, b - a) for a, b in data.bounds]), plant

    def to_dict(self) -> dict[str, object]:
        """What a model's ``info["closed_loop"]`` records of the first stage."""
        return {"reference": list(self.reference), "fir_lags": self.lags,
                "explained_share": dict(zip(self.inputs, np.round(self.explained, 4).tolist()))}


def _columns(data: IOData, reference: tuple[str, ...]) -> tuple[np.ndarray, list[int]]:
    """The references' samples (N, r) and the positions of the plant inputs in ``data``."""
    missing = [name for name in reference if name not in data.input_names]
    if missing:
        raise DataError(f"reference channel{'s' if len(missing) > 1 else ''} {', '.join(map(repr, missing))} "
                        f"not among the record's inputs {list(data.input_names)}: name the reference "
                        "columns as inputs of the record")
    plant = [j for j, name in enumerate(data.input_names) if name not in reference]
    if not plant:
        raise DataError(f"every input of the record is named as a reference ({list(reference)}): "
                        "the record must also hold the plant inputs")
    return data.u[:, [data.input_names.index(name) for name in reference]], plant


def _lagged(r: np.ndarray, lags: int, k0: int, k1: int) -> np.ndarray:
    """Rows ``k0..k1-1`` of ``[1, r[k], r[k-1], ..., r[k-L]]`` for one segment, ``r`` held
    at its first value before the segment starts."""
    pad = max(lags - k0, 0)
    padded = np.concatenate([np.repeat(r[:1], pad, axis=0), r[max(k0 - lags, 0) : k1]])
    windows = np.lib.stride_tricks.sliding_window_view(padded, lags + 1, axis=0)   # (rows, r, L + 1)
    rows = windows[:, :, ::-1].transpose(0, 2, 1).reshape(k1 - k0, -1)              # lag-major
    return np.concatenate([np.ones((k1 - k0, 1)), rows], axis=1)


def fit_projection(data: IOData, reference: tuple[str, ...]) -> ReferenceProjection:
    """Stage one of the two-stage method on ``data`` (the estimation record).

    Parameters
    ----------
    data : IOData
        Holds the plant inputs and the references (named among its inputs).
    reference : tuple of str
        The references' channel names.

    Returns
    -------
    ReferenceProjection

    Raises
    ------
    DataError
        A reference is not an input of ``data``, every input is a reference, or a
        reference is constant over the record (it cannot excite the loop).

    Warns
    -----
    WeakReferenceWarning
        The references explain less than 5 % of an input's variance.
    """
    r, plant = _columns(data, reference)
    for name, column in zip(reference, r.T):
        spread = np.ptp(column)
        if not spread > 1e-12 * max(1.0, float(np.max(np.abs(column)))):
            raise DataError(f"reference {name!r} is constant over the estimation record: it does not excite "
                            "the loop, so it cannot tell the plant from the noise; step or dither the "
                            "set-point, or identify with closed_loop='direct'")
    u = data.u[:, plant]
    nr = r.shape[1]
    longest = max(b - a for a, b in data.bounds)
    bound = (data.N // ROWS_PER_COEFFICIENT - 1) // nr - 1
    top = min(MAX_LAGS, bound, longest - 1)
    if top < 0:
        raise DataError(f"the record holds {data.N} samples: too few for the two-stage method's first stage "
                        f"(at least {ROWS_PER_COEFFICIENT * (1 + nr)} with {nr} reference{'s' * (nr > 1)})")
    candidates = [0] + [2**i for i in range(int(math.log2(top)) + 1)] if top >= 1 else [0]
    width = 1 + nr * (top + 1)

    def blocks():
        for a, b in data.bounds:
            for k0 in range(0, b - a, BLOCK_ROWS):
                k1 = min(k0 + BLOCK_ROWS, b - a)
                yield np.concatenate([_lagged(r[a:b], top, k0, k1), u[a + k0 : a + k1]], axis=1).T

    R = streamed_factor(blocks())
    tail = R[:, width:]                       # Q^T u: its trailing rows are what each lag count leaves
    leftover = np.sum(tail[width:] ** 2, axis=0)

    def residual(lags: int) -> np.ndarray:
        return np.sum(tail[1 + nr * (lags + 1) : width] ** 2, axis=0) + leftover

    lags = choose_lags(residual, candidates, data.N, nr)
    used = 1 + nr * (lags + 1)
    coefficients = np.linalg.lstsq(R[:used, :used], tail[:used], rcond=None)[0]
    total = np.sum(tail[1:] ** 2, axis=0)      # about the mean: the intercept is the first column
    explained = 1.0 - residual(lags) / np.where(total > 0, total, 1.0)
    names = tuple(data.input_names[j] for j in plant)
    weak = [f"{name} ({share:.1%})" for name, share in zip(names, explained) if share < WEAK_SHARE]
    if weak:
        warnings.warn(f"the references {list(reference)} explain little of input{'s' * (len(weak) > 1)} "
                      f"{', '.join(weak)}: the loop is driven by its noise more than by the references, and "
                      "the two-stage estimate rests on that small part; excite the set-points more",
                      WeakReferenceWarning, stacklevel=3)
    return ReferenceProjection(tuple(reference), names, lags, coefficients, explained)


def choose_lags(residual: Callable[[int], np.ndarray], candidates: list[int], N: int, nr: int) -> int:
    """The lag count of least AIC among ``candidates``; ``residual(L)`` gives each input's residual sum."""
    m = residual(candidates[0]).size
    aic = [float(np.sum(N * np.log(np.maximum(residual(L), 1e-300) / N)) + 2 * m * (1 + nr * (L + 1)))
           for L in candidates]
    return candidates[int(np.argmin(aic))]


def two_stage_records(estimation: IOData, validation: IOData,
                      reference: tuple[str, ...]) -> tuple[IOData, IOData, ReferenceProjection, FirstStage]:
    """Both records with their inputs projected on the references (the projection is fitted
    on ``estimation`` only and applied to ``validation`` as it is), and the first stage on
    the estimation record."""
    projection = fit_projection(estimation, reference)
    return (projection.project(estimation), projection.project(validation), projection,
            projection.first_stage(estimation))


def without_reference(data: IOData, reference: tuple[str, ...]) -> IOData:
    """``data`` with the reference channels dropped: the plant inputs alone."""
    _, plant = _columns(data, reference)
    return _with_inputs(data, data.u[:, plant], plant)


def _with_inputs(data: IOData, u: np.ndarray, plant: list[int]) -> IOData:
    """``data``'s outputs, segments and stamps with ``u`` as the inputs at positions ``plant``."""
    record = IOData(data.y, u, data.Ts, data.output_names, [data.input_names[j] for j in plant],
                    segment_starts=data.segment_starts, times=data.times)
    record.y_offset = data.y_offset.copy()
    record.u_offset = data.u_offset[plant].copy()
    return record
