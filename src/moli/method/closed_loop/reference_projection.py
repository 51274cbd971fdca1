"""The two-stage method for closed-loop records: each input replaced by its part the reference explains.

Under feedback a plant input is ``u = S_u r + S_v v``: a part made by the logged
references ``r`` (set-points, dither) through the loop, and a part made by the output
noise ``v`` through the controller. The second part is correlated with the noise, so an
open-loop method fitted on ``(u, y)`` is biased. The first part is independent of the
noise. Stage one estimates it by least squares as ``u_hat = F(q) r``, ``F`` a combination of
orthonormal basis functions of the references: each reference itself (the controller's
direct term), then the Laguerre functions ``L_k(q) = sqrt(1 - a^2) / (q - a) ((1 - a q) / (q - a))^k``,
``k < K``, and an intercept. With ``a = 0`` they are the plain delays (a FIR of lags
``0..K``); with ``a`` near the loop's slow pole a few functions span a response that a FIR
would need hundreds of lags for. Stage two identifies the plant on ``(u_hat, y)``. Its
error ``y - G u_hat = G S_v v + v`` is then uncorrelated with the regressors, so the plant
estimate is consistent (docs/closed_loop.md §2; Van den Hof and Schrama, 1993).

``a`` (in :data:`POLES`) and ``K`` (``0, 1, 2, 4, ...`` up to a bound set by the fitting
rows, :data:`ROWS_PER_COEFFICIENT`, and :data:`MAX_FUNCTIONS`) are chosen on the
estimation record itself: each basis is fitted on its first 70 % and judged by its squared
errors on the rest (:data:`HELD_OUT`). The inputs' noise-driven part is slow (the loop
filters the output noise), a slow basis can fit it by chance, and information criteria,
which take the residuals as white, chose such bases (docs/closed_loop.md §4). The
functions are nested, so one triangular factor of the fitting rows and one Gram matrix of
the held-out rows per pole give every ``K``'s errors, streamed in row blocks with the
filters' states carried: memory is bounded whatever the record's length. The chosen basis
is then fitted on the whole record. Before its first sample a reference is taken as
constant at its first value (a set-point held before the record starts).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Iterator

import numpy as np

from ...data.iodata import IOData
from ...errors import DataError, WeakReferenceWarning
from ...numerics.recursive_filter import recursive_filter
from ...numerics.triangular import streamed_factor
from ..least_squares.row_blocks import BLOCK_ROWS

__all__ = ["FirstStage", "ReferenceProjection", "fit_projection", "two_stage_records", "without_reference"]

# Poles of the Laguerre bases tried (0: the plain FIR), and the most functions of one: 128
# delays cover the loop's settling on the records moli is used on, and a pole near the
# loop's slowest covers far more with fewer; a factor holds (1 + r (K + 1) + m)^2 values.
POLES = (0.0, 0.5, 0.8, 0.9, 0.95, 0.98)
MAX_FUNCTIONS = 128
# Share of the estimation record, at its end, on which the bases are compared.
HELD_OUT = 0.3
# Fitting rows per coefficient of one input's regression at the most functions allowed, so
# that the noise u_hat takes from the first stage's own estimate stays small.
ROWS_PER_COEFFICIENT = 10
# An input of which the references explain less than this share of the variance is
# driven by the noise, not the references: the second stage then has little to go on.
WEAK_SHARE = 0.05


@dataclass(frozen=True)
class FirstStage:
    """The first stage's regressors and residuals on the samples of a record, as the covariance
    of the second stage needs them: the plant estimate depends on the first stage's through
    ``u_hat``, whose estimation error widens the plant's bands (docs/closed_loop.md §3).

    Attributes
    ----------
    design : ndarray, shape (N, 1 + r (K + 1))
        The first stage's regressors per sample.
    residual : ndarray, shape (N, m)
        Each plant input less its projection.
    """

    design: np.ndarray
    residual: np.ndarray

    def rows(self, bounds: tuple[tuple[int, int], ...], left_out: list[int], samples: int | None) -> "FirstStage":
        """The rows of the segments not ``left_out``, then the first ``samples`` of them (all when None):
        the samples :func:`moli.method.pipeline.records.long_segments` and the search window keep."""
        kept = np.concatenate([np.arange(a, b) for i, (a, b) in enumerate(bounds) if i not in left_out])
        kept = kept[:samples] if samples is not None else kept
        return FirstStage(self.design[kept], self.residual[kept])


@dataclass(frozen=True)
class ReferenceProjection:
    """The first stage of the two-stage method: each plant input on a basis of the references.

    Attributes
    ----------
    reference : tuple of str
        The references' channel names.
    inputs : tuple of str
        The plant inputs' names.
    pole : float
        ``a`` of the Laguerre functions (0: plain delays).
    functions : int
        ``K``: the Laguerre functions of each reference, beside the reference itself.
    coefficients : ndarray, shape (1 + r (K + 1), m)
        Intercept, then every reference, then every reference's first function, ...
    explained : ndarray, shape (m,)
        Share of each input's variance (about its mean) that the references explain on the
        held-out rows of the estimation record, by the basis fitted on the others.
    """

    reference: tuple[str, ...]
    inputs: tuple[str, ...]
    pole: float
    functions: int
    coefficients: np.ndarray
    explained: np.ndarray

    def project(self, data: IOData) -> tuple[IOData, FirstStage]:
        """``data`` with its plant inputs replaced by their projections and the references
        dropped, and the first stage's regressors and residuals on it."""
        r, plant = _columns(data, self.reference)
        design = np.concatenate([block for a, b in data.bounds
                                 for block in _basis_blocks(r[a:b], self.pole, self.functions)])
        projected = design @ self.coefficients
        return _with_inputs(data, projected, plant), FirstStage(design, data.u[:, plant] - projected)

    def to_dict(self) -> dict[str, object]:
        """What a model's ``info["closed_loop"]`` records of the first stage."""
        return {"reference": list(self.reference), "basis_pole": self.pole, "basis_functions": self.functions,
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


def _basis_blocks(r: np.ndarray, pole: float, count: int, block_rows: int = BLOCK_ROWS) -> Iterator[np.ndarray]:
    """Row blocks of ``[1, r, L_0 r, ..., L_{K-1} r]`` (function-major) for one segment, each
    filter started in the steady state of ``r`` held at its first value."""
    gain = math.sqrt(1.0 - pole**2)
    first, allpass, denominator = np.array([0.0, gain]), np.array([-pole, 1.0]), np.array([1.0, -pole])
    # lfilter's state before the first sample, in the steady state of r held at r[0]: the
    # first filter's output there is held, and so is every all-pass's; the state of
    # y = b0 x + z is z = y - b0 x
    held = r[:1] * gain / (1.0 - pole)
    states = [held] + [held * (1.0 + pole) for _ in range(count - 1)]
    for k0 in range(0, r.shape[0], block_rows):
        chunk = r[k0 : k0 + block_rows]
        columns = [np.ones((chunk.shape[0], 1)), chunk]
        signal = chunk
        for k in range(count):
            b = first if k == 0 else allpass
            signal, states[k] = recursive_filter(b, denominator, signal, axis=0, zi=states[k])
            columns.append(signal)
        yield np.concatenate(columns, axis=1)


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
        The references explain less than 5 % of an input's variance on the held-out rows.
    """
    r, plant = _columns(data, reference)
    for name, column in zip(reference, r.T):
        spread = np.ptp(column)
        if not spread > 1e-12 * max(1.0, float(np.max(np.abs(column)))):
            raise DataError(f"reference {name!r} is constant over the estimation record: it does not excite "
                            "the loop, so it cannot tell the plant from the noise; step or dither the "
                            "set-point, or identify with closed_loop='direct'")
    u = data.u[:, plant]
    nr, m = r.shape[1], u.shape[1]
    longest = max(b - a for a, b in data.bounds)
    bound = (int(data.N * (1 - HELD_OUT)) // ROWS_PER_COEFFICIENT - 1) // nr - 1
    top = min(MAX_FUNCTIONS, bound, longest - 1)
    if top < 0:
        raise DataError(f"the record holds {data.N} samples: too few for the two-stage method's first stage "
                        f"(at least {ROWS_PER_COEFFICIENT * (1 + nr)} with {nr} reference{'s' * (nr > 1)})")
    counts = [0] + [2**i for i in range(int(math.log2(top)) + 1)] if top >= 1 else [0]
    width = 1 + nr * (top + 1)
    cut = data.N - max(1, int(round(HELD_OUT * data.N)))     # rows from here on judge the bases

    def rows(pole: float) -> Iterator[tuple[int, np.ndarray]]:
        """``(first row, [regressors | inputs])`` blocks of this pole's basis of ``top`` functions."""
        for a, b in data.bounds:
            for k0, block in zip(range(a, b, BLOCK_ROWS), _basis_blocks(r[a:b], pole, top)):
                yield k0, np.concatenate([block, u[k0 : k0 + block.shape[0]]], axis=1)

    def split_factor(pole: float) -> tuple[np.ndarray, np.ndarray]:
        """The factor of the fitting rows and the Gram matrix of the held-out rows."""
        gram = np.zeros((width + m, width + m))

        def fitting() -> Iterator[np.ndarray]:
            for k0, block in rows(pole):
                fit = max(0, min(block.shape[0], cut - k0))
                gram[...] += block[fit:].T @ block[fit:]
                if fit:
                    yield block[:fit].T
        return streamed_factor(fitting()), gram

    # Each basis (pole, count) is fitted on the first rows and judged by its squared errors on
    # the held-out rest: the inputs' noise-driven part is slow (the loop filters the output
    # noise), and a slow basis can fit slow noise by chance; AIC, which takes the residuals
    # as white, then chose 64 Laguerre functions, or explained a third of an input with
    # references unrelated to it (docs/closed_loop.md §4)
    best = None
    for pole in POLES:
        R, gram = split_factor(pole)
        for count in counts:
            used = 1 + nr * (count + 1)
            beta = np.linalg.lstsq(R[:used, :used], R[:used, width:], rcond=None)[0]
            held = (np.diagonal(gram)[width:] - 2 * np.einsum("ij,ij->j", beta, gram[:used, width:])
                    + np.einsum("ij,ik,kj->j", beta, gram[:used, :used], beta))
            scaled = float(np.sum(held / np.maximum(np.diagonal(gram)[width:], 1e-300)))
            if best is None or scaled < best[0]:
                best = (scaled, pole, count, held, gram)
    _, pole, count, held, gram = best
    # the held-out share of each input's variance the chosen basis explains
    spread = np.diagonal(gram)[width:] - gram[0, width:] ** 2 / max(gram[0, 0], 1.0)
    explained = 1.0 - held / np.where(spread > 0, spread, 1.0)
    used = 1 + nr * (count + 1)
    R = streamed_factor(block[:, list(range(used)) + list(range(width, width + m))].T for _, block in rows(pole))
    coefficients = np.linalg.lstsq(R[:used, :used], R[:used, used:], rcond=None)[0]
    names = tuple(data.input_names[j] for j in plant)
    weak = [f"{name} ({share:.1%})" for name, share in zip(names, explained) if share < WEAK_SHARE]
    if weak:
        warnings.warn(f"the references {list(reference)} explain little of input{'s' * (len(weak) > 1)} "
                      f"{', '.join(weak)}: the loop is driven by its noise more than by the references, and "
                      "the two-stage estimate rests on that small part; excite the set-points more",
                      WeakReferenceWarning, stacklevel=3)
    return ReferenceProjection(tuple(reference), names, pole, count, coefficients, explained)


def two_stage_records(estimation: IOData, validation: IOData,
                      reference: tuple[str, ...]) -> tuple[IOData, IOData, ReferenceProjection, FirstStage]:
    """Both records with their inputs projected on the references (the projection is fitted
    on ``estimation`` only and applied to ``validation`` as it is), and the first stage on
    the estimation record."""
    projection = fit_projection(estimation, reference)
    projected, first = projection.project(estimation)
    return projected, projection.project(validation)[0], projection, first


def without_reference(data: IOData, reference: tuple[str, ...]) -> IOData:
    """``data`` with the reference channels dropped: the plant inputs alone."""
    _, plant = _columns(data, reference)
    return _with_inputs(data, data.u[:, plant], plant)


def _with_inputs(data: IOData, u: np.ndarray, plant: list[int]) -> IOData:
    """``data``'s outputs, segments and stamps with ``u`` as the inputs at positions ``plant``."""
    record = IOData(data.y, u, data.Ts, data.output_names, [data.input_names[j] for j in plant],
                    segment_starts=data.segment_starts, times=data.times, time_unit=data.time_unit)
    record.y_offset = data.y_offset.copy()
    record.u_offset = data.u_offset[plant].copy()
    return record
