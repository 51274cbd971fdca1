"""Which column of a table gives the sampling period: a time column, or a period or rate column.

A **time column** is the one named (``time_column=``), else found in this order among
the columns that are not channels:

1. a column named ``time``, ``t``, ``timestamp``, ``date`` or ``datetime`` (any case):
   it must hold increasing times, else the read is refused;
2. a column whose name *looks like* time (``Time [s]``, ``Timestamp (UTC)``,
   ``Date/Time``, ``Zeit``, ``time_s``, ``elapsed time (ms)``: words of
   :data:`TIME_WORDS` and :data:`UNIT_WORDS` only, at least one a time word) and that
   holds strictly increasing numbers or date-times; one that does not is passed over;
3. the table's first column, when its content leaves no doubt: date-times (no input is
   a date), or numbers under a blank or generic name (``Unnamed: 0``, ``x``,
   ``X_Value``, ``index``) that increase by one step throughout (within the
   tolerance) and do not merely count samples. A first column with a name of its own
   is never taken for numbers alone: an input ramp increases evenly too.

A **period column** is named ``Ts``, ``dt``, ``sampling period`` ... (:data:`PERIOD_NAMES`)
or, for a rate, ``Fs``, ``rate``, ``sampling rate`` ... (:data:`RATE_NAMES`; ``Ts =
1/value``), any case, a unit in brackets allowed, and holds one positive number in
every filled row (all rows alike, or only the first filled, as benchmark files store it).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from .cells import parse_numbers
from .timing import TIME_COLUMNS, datetimes_to_seconds, iso_to_seconds
from ..errors import DataError, SamplingPeriodWarning

__all__ = ["Clock", "find_clock", "looks_like_time", "named_unit", "period_kind", "stated_period", "period_notice"]

# Words a time column's name is made of (besides units): English, German, French,
# Spanish, Italian and Scandinavian names for time and date.
TIME_WORDS = frozenset({
    "time", "t", "timestamp", "date", "datetime", "stamp", "elapsed", "clock", "seconds",
    "sec", "secs", "zeit", "uhrzeit", "datum", "zeitstempel", "sekunden", "temps", "tiempo",
    "tempo", "tid", "heure", "hora", "ora",
})
# Units and qualifiers that may follow a time word: ``Time [s]``, ``Timestamp (UTC)``.
UNIT_WORDS = frozenset({
    "s", "ms", "us", "µs", "ns", "min", "h", "sec", "secs", "second", "seconds", "msec",
    "millisecond", "milliseconds", "minute", "minutes", "hour", "hours", "utc", "gmt",
    "local", "unix", "epoch", "abs", "rel", "since", "start", "sek",
})
# The unit each unit word of a time column's name stands for (``Time [s]``, ``t_ms``).
UNIT_OF_WORD = {"s": "s", "sec": "s", "secs": "s", "second": "s", "seconds": "s", "sek": "s", "sekunden": "s",
                "ms": "ms", "msec": "ms", "millisecond": "ms", "milliseconds": "ms", "us": "µs", "µs": "µs",
                "ns": "ns", "min": "min", "minute": "min", "minutes": "min", "h": "h", "hour": "h", "hours": "h"}
PERIOD_NAMES = frozenset({"ts", "dt", "sample time", "sampling time", "sample period",
                          "sampling period", "sample interval", "sampling interval"})
RATE_NAMES = frozenset({"fs", "rate", "sample rate", "sampling rate", "sample frequency",
                        "sampling frequency", "samplerate"})
# Names a first column gets when its header cell is blank or generic.
GENERIC_NAMES = frozenset({"", "x", "x_value", "x-value", "x axis", "x-axis", "xaxis", "index", "#"})
UNNAMED = re.compile(r"^unnamed: ?\d+$")
BRACKETS = re.compile(r"[\[(][^\])]*[\])]")
WORD_SPLIT = re.compile(r"[^0-9a-zµ]+")
CAMEL = re.compile(r"(?<=[a-z])(?=[A-Z])")
# Values of a period column may differ by this relative amount (digits written out).
PERIOD_AGREEMENT = 1e-9


@dataclass(frozen=True)
class Clock:
    """What :func:`find_clock` found.

    ``time``: the time column, or None; ``how``: how it was found ("named" by the
    caller, "standard" for the names of rule 1, "by its name" for rule 2, "as the first
    column ..." for rule 3); ``period``: ``(column, Ts, note)`` from a period or
    rate column, or None; ``passed``: candidates passed over, each with its reason.
    """

    time: str | None
    how: str = ""
    period: tuple[str, float, str] | None = None
    passed: tuple[str, ...] = ()


def _words(text: str) -> list[str]:
    return [word for word in WORD_SPLIT.split(CAMEL.sub(" ", text).lower()) if word]


def named_unit(name: str) -> str | None:
    """The time unit a time column's name states, or None.

    Examples
    --------
    >>> [named_unit(n) for n in ("Time [s]", "t (ms)", "time_min", "Zeit", "Timestamp (UTC)")]
    ['s', 'ms', 'min', None, None]
    """
    words = WORD_SPLIT.split(CAMEL.sub(" ", name.strip()).lower())
    found = [UNIT_OF_WORD[word] for word in words if word in UNIT_OF_WORD]
    return found[-1] if found else None


def looks_like_time(name: str) -> bool:
    """True when ``name`` is made of time words and units, at least one a time word.

    Examples
    --------
    >>> [looks_like_time(n) for n in ("Time [s]", "Date/Time", "Zeit", "time_s", "T_in", "u1")]
    [True, True, True, True, False, False]
    """
    words = _words(name)
    return any(w in TIME_WORDS for w in words) and all(w in TIME_WORDS or w in UNIT_WORDS for w in words)


def period_kind(name: str) -> str | None:
    """"period" or "rate" when ``name`` names a sampling period or rate column, else None.

    Examples
    --------
    >>> period_kind("Ts"), period_kind("Fs [Hz]"), period_kind("sampling rate"), period_kind("u")
    ('period', 'rate', 'rate', None)
    """
    # no match reaches past the last closing bracket; searching there from each opening
    # one would make the search quadratic in a name of many unclosed brackets
    closed = max(name.rfind("]"), name.rfind(")")) + 1
    plain = " ".join(_words(BRACKETS.sub(" ", name[:closed]) + name[closed:]))
    return "period" if plain in PERIOD_NAMES else "rate" if plain in RATE_NAMES else None


def _one_value(values: np.ndarray, decimal: str) -> tuple[float, bool] | None:
    """The one positive number every filled cell holds, and whether only the first is filled."""
    numbers, bad = parse_numbers(values, decimal)
    filled = np.flatnonzero(~np.isnan(numbers)) if bad is None else np.zeros(0, int)
    if filled.size == 0 or not np.isfinite(numbers[filled]).all():
        return None
    first = float(numbers[filled[0]])
    same = np.abs(numbers[filled] - first) <= PERIOD_AGREEMENT * abs(first)
    if first <= 0 or not same.all():
        return None
    return first, filled.size == 1 and filled[0] == 0 and len(values) > 1


def _times(values: np.ndarray, decimal: str, time_format: str | None) -> tuple[np.ndarray, bool] | None:
    """A column as times, and whether they are date-times; None when it holds neither."""
    if values.dtype.kind in "mM":
        return datetimes_to_seconds(values), True
    if time_format is None:
        numbers, bad = parse_numbers(values, decimal)
        if bad is None:
            return numbers, False
    if values.dtype.kind not in "OUS":
        return None
    stamps, bad_stamp = iso_to_seconds(values, time_format)
    return (stamps, True) if bad_stamp is None else None


def _increasing(times: np.ndarray) -> bool:
    return times.size > 1 and bool(np.all(np.isfinite(times))) and bool(np.all(np.diff(times) > 0))


def _even(times: np.ndarray, tolerance: float) -> bool:
    """Steps all within ``tolerance`` of their median, and not a count of samples."""
    steps = np.diff(times)
    median = float(np.median(steps))
    counter = median == 1.0 and times[0] in (0.0, 1.0) and np.all(times == np.round(times))
    return not counter and bool(np.all(np.abs(steps - median) <= tolerance * median))


def _period(columns: Mapping[str, np.ndarray], names: Sequence[str], channels: set[str],
            decimal: str) -> tuple[tuple[str, float, str] | None, list[str]]:
    passed = []
    for name in names:
        kind = period_kind(name)
        if kind is None or name in channels or name not in columns:
            continue
        found = _one_value(np.asarray(columns[name]).ravel(), decimal)
        if found is None:
            passed.append(f"column {name!r} (named like a sampling {kind}, but it does not hold "
                          "one positive number)")
            continue
        value, first_only = found
        where = ", its first row" if first_only else ""
        if kind == "rate":
            return (name, 1.0 / value, f"1/{value:g}, the rate in column {name!r}{where}"), passed
        return (name, value, f"the period in column {name!r}{where}"), passed
    return None, passed


def find_clock(
    columns: Mapping[str, np.ndarray], names: Sequence[str], channels: Sequence[str],
    time_column: str | bool | None, time_format: str | None, decimal: str, *, tolerance: float,
) -> Clock:
    """The time column and the period column of a table whose columns come in ``names`` order.

    Rules in the module's docstring. ``time_column`` a name: that column (checked by
    the caller); False: no time column.
    """
    taken = set(channels)
    period, passed = _period(columns, names, taken, decimal)
    if period is not None:
        taken.add(period[0])
    if time_column is False:
        return Clock(None, period=period, passed=tuple(passed))
    if isinstance(time_column, str):
        return Clock(time_column, "named", period, tuple(passed))
    free = [name for name in names if name in columns and name not in taken]
    exact = next((name for name in free if name.strip().lower() in TIME_COLUMNS), None)
    if exact is not None:
        return Clock(exact, "standard", period, tuple(passed))
    for name in filter(looks_like_time, free):
        times = _times(np.asarray(columns[name]).ravel(), decimal, time_format)
        if times is not None and _increasing(times[0]):
            return Clock(name, "by its name", period, tuple(passed))
        passed.append(f"column {name!r} (named like time, but it does not hold increasing "
                      "numbers or date-times)")
    first = names[0] if names else None
    if first is not None and first in free and not looks_like_time(first):
        times = _times(np.asarray(columns[first]).ravel(), decimal, time_format)
        label = first.strip().lower()
        generic = label in GENERIC_NAMES or UNNAMED.match(label) is not None
        if times is not None and _increasing(times[0]) and (
                times[1] or (generic and _even(times[0], tolerance))):
            return Clock(first, "as the first column, which holds "
                         + ("date-times" if times[1] else "evenly increasing numbers"),
                         period, tuple(passed))
    return Clock(None, period=period, passed=tuple(passed))


def stated_period(given: float | None, stored: float | None, clock: Clock, source: str,
                  tolerance: float) -> tuple[float | None, str]:
    """The period given, else stored in the file, else in a period column, and where it
    was stated; every one stated must agree with it within ``tolerance``."""
    stored_as = [(stored, f"stored in {source}", "")] if stored is not None else []
    if clock.period is not None:
        stored_as.append((clock.period[1], f"stored in {source} as {clock.period[2]}",
                          f" as {clock.period[2]}"))
    if given is None and not stored_as:
        return None, ""
    Ts, where = (given, "given") if given is not None else stored_as[0][:2]
    for other, _, how in stored_as:
        if abs(other - Ts) > tolerance * Ts:
            raise DataError(f"{source} stores Ts = {other:g}{how}, but Ts = {Ts:g} was {where}; "
                            "drop Ts to use the file's, or correct it")
    return Ts, where


def period_notice(source: str, clock: Clock, Ts: float, unit: str) -> SamplingPeriodWarning | None:
    """Where a period the caller did not give came from, when moli had to choose it: a
    period column, a time column found by its content (rule 3), or Ts = 1 assumed.

    None for a time column the caller named, or one found by its name (rules 1 and 2:
    ``time``, ``Time [s]``, ``Zeit``...): its period is what the file plainly says, and
    a warning on every read of such a file would drown the warnings that matter.
    """
    state = "; give Ts= (--ts) to state it"
    if clock.period is not None:
        agrees = f"; the time column {clock.time!r} agrees" if clock.time else ""
        return SamplingPeriodWarning(f"{source}: Ts = {Ts:g} from {clock.period[2]}{agrees}{state}")
    if clock.time is not None:
        if clock.how in ("named", "standard", "by its name"):
            return None
        return SamplingPeriodWarning(
            f"{source}: Ts = {Ts:g}{unit} from the time column {clock.time!r} (found "
            f"{clock.how}; the median step of its time stamps){state}, or time_column= "
            "(--time-column) to choose the column")
    passed = "; passed over: " + "; ".join(clock.passed) if clock.passed else ""
    return SamplingPeriodWarning(
        f"{source}: no time column and no sampling period found{passed}; Ts = 1 is assumed "
        "(one time unit per sample): set it with Ts= in Python or --ts on the command line, "
        "or name the time column with time_column= (--time-column)")
