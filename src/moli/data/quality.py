"""Data-quality screening of a record before identification (docs/data.md).

:func:`check_data` lists what would make a model unreliable or misleading: constant
channels, duplicate or collinear inputs, inputs that do not excite the orders asked
for, clipped (saturated) and coarsely quantized channels, outliers (moli.data.outliers). :func:`screen` raises for
what makes identification meaningless (a constant input) and warns about the rest
with :class:`~moli.errors.DataQualityWarning`; :func:`moli.identify` calls it on the
estimation record.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import DataError, DataQualityWarning
from ..numerics.triangular import streamed_factor
from .arguments import integer
from .iodata import IOData
from .outliers import flag_outliers
from ..numerics.blas_threads import limited_blas

__all__ = ["QualityIssue", "check_data", "check_scale", "screen"]

# Identification forms products of samples: beyond these magnitudes they overflow or
# fall into the subnormals of double precision, so such a channel must be rescaled.
LARGEST_MAGNITUDE = 1e150
SMALLEST_MAGNITUDE = 1e-150
# A channel whose spread is below this share of its magnitude (its level, when it is
# nearly constant) carries no information at double precision: a constant plus round-off.
CONSTANT_SPREAD = 1e-9
# An input whose spread is below this share of its level moves less than 16 steps of
# single precision (6e-8 of the level), the resolution of the many loggers that store
# float32, and far less than any actuator moves about its operating point: what it
# shows is storage or conversion error, and a model's gain from it is that error's.
NEARLY_CONSTANT_SPREAD = 1e-6
# Inputs whose normalized smallest singular value is below this are (nearly) linear
# combinations of each other: their separate effects cannot be told apart.
COLLINEAR_RATIO = 1e-6
# An input is persistently exciting of order L when its L-block Hankel matrix has a
# condition number below this.
EXCITATION_CONDITION = 1e4
# A channel that sits at its own minimum or maximum for more than this share of the
# samples is clipped by a sensor range or a saturating actuator.
CLIPPED_SHARE = 0.05
# Fewer distinct levels than this (on records long enough to show more) is a coarse
# quantization: the model sees steps, not the plant's response.
QUANTIZATION_LEVELS = 16
# Hankel matrices of longer records are reduced to their triangular factor in blocks
# of BLOCK_ROWS rows (same singular values, memory bounded by a block).
WHOLE_ROWS = 2**15
BLOCK_ROWS = 8192


@dataclass(frozen=True)
class QualityIssue:
    """One finding of :func:`check_data`.

    Attributes
    ----------
    kind : str
        "scale", "constant", "nearly-constant", "collinear", "excitation", "clipped", "quantized"
        or "outliers".
    channels : tuple of str
        The channels concerned.
    message : str
        What was found and what to do about it.
    fatal : bool
        True when identification cannot give a meaningful model (a constant input).
    """

    kind: str
    channels: tuple[str, ...]
    message: str
    fatal: bool = False


def _scale_issues(data: IOData) -> list[QualityIssue]:
    issues = []
    for what, names, x in (("input", data.input_names, data.u), ("output", data.output_names, data.y)):
        for name, peak in zip(names, np.max(np.abs(x), axis=0, initial=0.0)):
            if peak > LARGEST_MAGNITUDE or 0.0 < peak < SMALLEST_MAGNITUDE:
                issues.append(QualityIssue(
                    "scale", (name,),
                    f"{what} {name!r} reaches at most {peak:.3g} in magnitude: products of such samples "
                    f"{'overflow' if peak > 1 else 'underflow'} double precision; rescale it to "
                    "magnitudes near 1 (change its unit)", fatal=True,
                ))
    return issues


def check_scale(data: IOData) -> None:
    """Raise :class:`DataError` naming each channel whose magnitude double precision cannot
    identify from (above 1e150, or nonzero and below 1e-150)."""
    issues = _scale_issues(data)
    if issues:
        raise DataError("; ".join(issue.message for issue in issues))


def _spread(x: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Each channel's standard deviation over its magnitude, offset included: a centred
    record (identify screens one) keeps its level in ``offset``."""
    scale = np.max(np.abs(x + offset), axis=0)
    return np.std(x, axis=0) / np.where(scale > 0, scale, 1.0)


def _exciting(u: np.ndarray, L: int, bounds: tuple[tuple[int, int], ...]) -> bool:
    """Whether the (centred) inputs are persistently exciting of order L.

    The rows of the block Hankel matrix are windows of ``L`` samples inside one
    segment each: no window spans a boundary.
    """
    m = u.shape[1]
    # the rows of segment (a, b) are the windows u[k : k + L], k = a .. b - L
    spans = [(a, b - L + 1) for a, b in bounds if b - a >= L]
    rows = sum(stop - start for start, stop in spans)
    if rows <= L * m:
        return False

    def windows(start: int, stop: int) -> np.ndarray:
        return np.concatenate([u[start + i : stop + i] for i in range(L)], axis=1)

    if rows <= WHOLE_ROWS:
        hankel = np.concatenate([windows(a, b) for a, b in spans])
    else:
        # a long record: the Hankel matrix's triangular factor, built block by block,
        # has its singular values and column norms without holding L copies of u
        hankel = streamed_factor(windows(start, min(start + BLOCK_ROWS, b)).T
                                 for a, b in spans for start in range(a, b, BLOCK_ROWS))
    norms = np.linalg.norm(hankel, axis=0)
    s = np.linalg.svd(hankel / np.where(norms > 0, norms, 1.0), compute_uv=False)
    return bool(s[-1] > 0 and s[0] / s[-1] <= EXCITATION_CONDITION)


def _excitation_order(u: np.ndarray, limit: int, bounds: tuple[tuple[int, int], ...]) -> int:
    """Largest L <= limit for which the inputs are persistently exciting of order L."""
    centred = u - u.mean(axis=0)
    # exciting of order L implies every lower order: test the order needed first; from
    # L m >= N on, the Hankel matrix has no more rows than columns, so no such L is exciting
    N, m = u.shape
    for L in range(min(limit, -(-N // m) - 1), 0, -1):
        if _exciting(centred, L, bounds):
            return L
    return 0


def _collinear(data: IOData, live: np.ndarray) -> list[QualityIssue]:
    names = [n for n, ok in zip(data.input_names, live) if ok]
    if len(names) < 2:
        return []
    u = data.u[:, live] - data.u[:, live].mean(axis=0)
    _, s, vt = np.linalg.svd(u / np.linalg.norm(u, axis=0), full_matrices=False)
    if s[-1] > COLLINEAR_RATIO * s[0]:
        return []
    weights = np.abs(vt[-1])
    involved = tuple(n for n, w in zip(names, weights) if w > 0.1)
    return [QualityIssue(
        "collinear", involved,
        f"inputs {', '.join(involved)} are (nearly) linear combinations of each other "
        f"(normalized singular value {s[-1] / s[0]:.1e}): their separate effects cannot be "
        "told apart; drop one, or excite them independently",
    )]


def _clipping_and_levels(names: tuple[str, ...], x: np.ndarray, what: str) -> list[QualityIssue]:
    """Clipped and coarsely quantized channels.

    A designed input (binary, multi-level, steps) sits at its extremes and has few
    levels on purpose, so inputs are only checked for clipping of a continuous-valued
    signal, and only outputs for quantization.
    """
    issues = []
    N = x.shape[0]
    for name, column in zip(names, x.T):
        low, high = column.min(), column.max()
        levels = np.unique(column).size
        at_low, at_high = np.mean(column == low), np.mean(column == high)
        continuous = levels >= QUANTIZATION_LEVELS or what == "output"
        if high > low and continuous and max(at_low, at_high) > CLIPPED_SHARE:
            edge, share = (low, at_low) if at_low >= at_high else (high, at_high)
            issues.append(QualityIssue(
                "clipped", (name,),
                f"{what} {name!r} sits at {edge:g} for {share:.0%} of the samples: clipped by a "
                "sensor range or a saturating actuator, where the plant is not linear; cut those "
                "stretches out or identify from a record that stays inside the range",
            ))
        if what == "output" and 1 < levels < QUANTIZATION_LEVELS and N >= 10 * QUANTIZATION_LEVELS:
            issues.append(QualityIssue(
                "quantized", (name,),
                f"output {name!r} takes only {levels} distinct values: coarse quantization hides "
                "the plant's response; use a finer resolution if the logger has one",
            ))
    return issues


def check_data(data: IOData, nmax: int | None = None) -> list[QualityIssue]:
    """Screen a record for what makes identification unreliable.

    Parameters
    ----------
    data : IOData
        The record (estimation data).
    nmax : int, optional
        Largest order to be identified: inputs must excite at least
        ``ceil(nmax / p) + 1`` lags (the regressors of a balanced list of indices).

    Returns
    -------
    list of QualityIssue
        Empty when nothing was found.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((200, 2)); u[:, 1] = 3.0
    >>> [issue.kind for issue in check_data(IOData(rng.standard_normal(200), u))]
    ['constant']
    """
    with limited_blas():
        if not isinstance(data, IOData):
            raise DataError(f"data must be an IOData, got {type(data).__name__}")
        if nmax is not None:
            nmax = integer("nmax", nmax, low=1)
        issues = _scale_issues(data)
        if issues:  # the other checks would overflow or call tiny channels constant
            return issues
        spread_u = _spread(data.u, data.u_offset)
        dead_u, dead_y = spread_u <= CONSTANT_SPREAD, _spread(data.y, data.y_offset) <= CONSTANT_SPREAD
        for name, dead, spread in zip(data.input_names, dead_u, spread_u):
            if dead:
                issues.append(QualityIssue(
                    "constant", (name,),
                    f"input {name!r} is constant (its standard deviation is {spread:.1e} of its "
                    "level): it carries no information about the plant; remove it from the inputs",
                    fatal=True,
                ))
            elif spread <= NEARLY_CONSTANT_SPREAD:
                issues.append(QualityIssue(
                    "nearly-constant", (name,),
                    f"input {name!r} is nearly constant: its standard deviation is {spread:.1e} of "
                    f"its level, below {NEARLY_CONSTANT_SPREAD:g}, where storage and conversion "
                    "errors are as large as its variations, so a model's gain from it is "
                    "meaningless; remove it from the inputs, or record it with its variations",
                ))
        for name, dead in zip(data.output_names, dead_y):
            if dead:
                issues.append(QualityIssue(
                    "constant", (name,),
                    f"output {name!r} is constant: its model will be a constant; check the sensor "
                    "or remove the output",
                ))
        collinear = _collinear(data, ~dead_u)
        issues += collinear
        # collinear inputs excite no lag together: that issue is theirs, said above, not the excitation's
        if nmax is not None and not dead_u.all() and not collinear:
            needed = math.ceil(nmax / data.p) + 1
            order = _excitation_order(data.u[:, ~dead_u], needed, data.bounds)
            if order < needed:
                issues.append(QualityIssue(
                    "excitation", tuple(n for n, d in zip(data.input_names, dead_u) if not d),
                    f"the inputs excite only {order} lag(s); models up to order {nmax} need "
                    f"{needed}: use a richer input (e.g. moli.random_binary_signal) or a lower nmax",
                ))
        issues += _clipping_and_levels(data.input_names, data.u, "input")
        issues += _clipping_and_levels(data.output_names, data.y, "output")
        return issues + _outliers(data)


def _outliers(data: IOData) -> list[QualityIssue]:
    report = flag_outliers(data)
    return [QualityIssue(
        "outliers", (name,),
        f"{'output' if name in data.output_names else 'input'} {name!r} has {count} outlier(s), the "
        f"first at sample {report.first[name]}: samples more than {report.threshold:g} standard "
        "deviations from the median of their 7 neighbours; check them, and if they are glitches "
        "replace them with moli.remove_outliers(data)",
    ) for name, count in report.counts.items()]


def screen(data: IOData, nmax: int | None = None, stacklevel: int = 2) -> list[QualityIssue]:
    """:func:`check_data`, raising :class:`DataError` on a fatal finding and warning on the rest.

    Returns the issues found (after warning about each).
    """
    issues = check_data(data, nmax)
    fatal = [issue.message for issue in issues if issue.fatal]
    if fatal:
        raise DataError("; ".join(fatal))
    for issue in issues:
        warnings.warn(issue.message, DataQualityWarning, stacklevel=stacklevel + 1)
    return issues
