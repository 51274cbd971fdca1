"""Time stamps of a record: seconds, the sampling period and the steps that break it.

A time column holds numbers (any unit; the period comes out in that unit) or
date-times (ISO 8601 text, ``datetime64`` values, spreadsheet or Parquet time stamps),
which become seconds since the first sample, so their period is in seconds.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Real
from typing import Callable

import numpy as np

from .arguments import period
from .cells import optional
from ..errors import DataError, IrregularSamplingWarning, OptionError

__all__ = ["SamplingGap", "find_gaps"]

# Column names (compared without case and surrounding blanks) taken as the time axis.
TIME_COLUMNS = ("time", "t", "timestamp", "date", "datetime")
# A step may differ from the sampling period by this fraction of it and still count as
# regular: time stamps written with a few digits (a logger's milliseconds, a
# spreadsheet's rounding) wobble by that much without any sample being late.
TIME_TOLERANCE = 0.01
# Steps longer than this many periods are gaps (samples missing), listed by name in
# the warning; shorter irregular steps are jitter.
GAP_FACTOR = 1.5
# The warning's message names this many gaps; its ``gaps`` attribute holds them all.
LISTED_GAPS = 5


@dataclass(frozen=True)
class SamplingGap:
    """One step between consecutive time stamps that is not the sampling period.

    Attributes
    ----------
    index : int
        Sample (0-based) after the step: the step runs from sample ``index - 1`` to ``index``.
    start, stop : float
        Times of samples ``index - 1`` and ``index`` (seconds since the first sample
        when the time stamps are date-times).
    missing : int
        Whole sampling periods missing in the step, ``round(step / Ts) - 1``; 0 for a
        step that is only late or early.

    Examples
    --------
    >>> gap = SamplingGap(index=3, start=0.2, stop=0.5, missing=2)
    >>> round(gap.step, 12)
    0.3
    """

    index: int
    start: float
    stop: float
    missing: int

    @property
    def step(self) -> float:
        """Length of the step, ``stop - start``."""
        return self.stop - self.start


def check_period(Ts: object) -> float:
    """``Ts`` as a positive finite float in :data:`moli.data.arguments.PERIOD_RANGE`, or an error
    saying what is accepted."""
    return period(Ts)


def check_tolerance(tolerance: object) -> float:
    """``tolerance`` as a float in [0, 0.5), or an error saying what is accepted."""
    if isinstance(tolerance, bool) or not isinstance(tolerance, Real) or not 0 <= tolerance < 0.5:
        raise OptionError(
            f"time_tolerance must be a number in [0, 0.5) (a fraction of Ts), got {tolerance!r}"
        )
    return float(tolerance)


def find_gaps(times: object, Ts: float, tolerance: float = TIME_TOLERANCE) -> tuple[SamplingGap, ...]:
    """Every step of ``times`` that differs from ``Ts`` by more than ``tolerance * Ts``.

    Parameters
    ----------
    times : array_like, shape (N,)
        Time stamps in the unit of ``Ts`` (seconds for date-times).
    Ts : float
        Sampling period.
    tolerance : float, default 0.01
        Fraction of ``Ts`` a step may be off and still count as regular.

    Returns
    -------
    tuple of SamplingGap
        In time order; empty when the sampling is regular.

    Examples
    --------
    >>> find_gaps([0.0, 0.1, 0.2, 0.5, 0.6], 0.1)
    (SamplingGap(index=3, start=0.2, stop=0.5, missing=2),)
    """
    values = np.asarray(times, dtype=float)
    if values.ndim != 1 or not np.all(np.isfinite(values)):
        raise DataError(f"times must be a 1-D array of finite numbers, got shape {values.shape}")
    Ts = check_period(Ts)
    tolerance = check_tolerance(tolerance)
    steps = np.diff(values)
    irregular = np.flatnonzero(np.abs(steps - Ts) > tolerance * Ts) + 1
    return tuple(
        SamplingGap(int(k), float(values[k - 1]), float(values[k]),
                    max(int(round(steps[k - 1] / Ts)) - 1, 0))
        for k in irregular
    )


def datetimes_to_seconds(values: np.ndarray) -> np.ndarray:
    """``datetime64`` or ``timedelta64`` values as seconds since the first (NaT stays NaN)."""
    stamps = np.asarray(values)
    start = stamps[0] if stamps.dtype.kind == "M" else np.timedelta64(0, "ns")
    seconds = (stamps - start) / np.timedelta64(1, "s")
    return np.where(np.isnat(stamps), np.nan, seconds)


def iso_to_seconds(values: np.ndarray, time_format: str | None = None) -> tuple[np.ndarray, int | None]:
    """Date-time text as seconds since the first stamp, and the first cell that is not one.

    The text is ISO 8601 unless ``time_format`` (a strftime format) says otherwise.
    Offsets such as ``+02:00`` are honoured (every stamp is moved to UTC); stamps
    without one are taken as they are. Missing cells give NaN.
    """
    pd = optional("pandas", "reading date-time text")
    text = pd.Series(np.asarray(values, dtype=object))
    stamps = pd.to_datetime(text, format=time_format or "ISO8601", utc=True, errors="coerce")
    bad = np.flatnonzero(stamps.isna().to_numpy() & text.notna().to_numpy()
                         & (text.astype(str).str.strip() != "").to_numpy())
    if bad.size:
        return np.full(len(text), np.nan), int(bad[0])
    naive = stamps.dt.tz_convert(None).to_numpy(dtype="datetime64[ns]")
    return datetimes_to_seconds(naive), None


def sampling_period(
    times: np.ndarray,
    Ts: float | None,
    tolerance: float,
    where: Callable[[int], str],
    stated: str = "given",
) -> tuple[float, tuple[SamplingGap, ...]]:
    """The period of increasing time stamps: their median step, or ``Ts`` if it agrees.

    ``where(k)`` names the time stamp of sample ``k`` in messages (file, line, column).
    Raises :class:`DataError` when the stamps do not increase, or when their median step
    and ``Ts`` differ by more than ``tolerance``; ``stated`` says where ``Ts`` came from.
    Returns the period and the irregular steps found with it.
    """
    steps = np.diff(times)
    if steps.size == 0:
        if Ts is None:
            raise DataError(f"{where(0)}: a single time stamp; state the period with Ts")
        return Ts, ()
    backwards = np.flatnonzero(~(steps > 0))
    if backwards.size:
        k = int(backwards[0]) + 1
        raise DataError(
            f"{where(k)}: time does not increase (from {times[k - 1]:g} to {times[k]:g}); "
            "sort the record by time and remove repeated rows"
        )
    median = float(np.median(steps))
    if Ts is not None and abs(median - Ts) > tolerance * Ts:
        raise DataError(
            f"{where(0)}: the time stamps step by {median:g} (median), but Ts = {Ts:g} was "
            f"{stated}; they must agree within {tolerance:.0%}: drop Ts to take the period "
            "from the time stamps, or correct it"
        )
    period = median if Ts is None else Ts
    return period, find_gaps(times, period, tolerance)


def gap_starts(gaps: tuple[SamplingGap, ...], Ts: float) -> list[int]:
    """Segment starts of a record whose time steps have these gaps: 0, then after each
    step longer than 1.5 Ts (a sample or more is missing there)."""
    return [0] + [g.index for g in gaps if g.step > GAP_FACTOR * Ts]


def irregular_warning(
    gaps: tuple[SamplingGap, ...],
    Ts: float,
    samples: int,
    tolerance: float,
    source: str,
    where: Callable[[int], str],
    *,
    unit: str = "",
) -> IrregularSamplingWarning:
    """The warning for irregular steps of ``source``, naming the gaps longer than 1.5 Ts.

    The record's reader splits it at those gaps (:func:`gap_starts`).

    ``where(k)`` says where sample ``k`` is in the file (e.g. ``"line 9"``); ``unit``
    follows every time in the message (``" s"`` for date-times).
    """
    long = [g for g in gaps if g.step > GAP_FACTOR * Ts]
    text = (f"{source}: {len(gaps)} of {samples - 1} time steps differ from "
            f"Ts = {Ts:g}{unit} by more than {tolerance:.0%}")
    if long:
        listed = "; ".join(
            f"{where(g.index)} (sample {g.index}): t = {g.start:g}{unit} to {g.stop:g}{unit}, "
            f"{g.missing} sample{'' if g.missing == 1 else 's'} missing"
            for g in long[:LISTED_GAPS]
        )
        more = f"; and {len(long) - LISTED_GAPS} more" if len(long) > LISTED_GAPS else ""
        plural = "" if len(long) == 1 else "s"
        text += f"; {len(long)} gap{plural} longer than {GAP_FACTOR:g} Ts: {listed}{more}"
    # both time domains read the same record: the sentence says what each does with it
    text += (". A sampled (discrete-time) model splits the record into segments at each gap (the "
             "filters restart there) and takes the shorter irregular steps as if evenly spaced; "
             "a continuous-time fit (--continuous) uses every stamp as read. The warning's gaps "
             "attribute lists every irregular step." if long else
             ". A sampled (discrete-time) model takes the samples as if evenly spaced; a "
             "continuous-time fit (--continuous) uses every stamp as read. The warning's gaps "
             "attribute lists every irregular step.")
    return IrregularSamplingWarning(text, gaps)
