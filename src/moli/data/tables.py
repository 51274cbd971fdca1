"""From named columns to a record: pick the channels, check every cell, find the period.

Every file reader and the in-memory sources (a mapping of columns, a pandas data
frame) produce a :class:`Table`; :func:`record` turns it into an :class:`IOData`. So
a cell that is not a number, a missing sample or an irregular time axis is reported
the same way whatever the format, naming the file, the line (or row) and the column.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Mapping, Sequence

import numpy as np

from .cells import is_missing, parse_numbers
from .clocks import find_clock, looks_like_time, named_unit, period_kind, period_notice, stated_period
from .iodata import IOData
from .timing import (
    TIME_TOLERANCE, check_period, check_tolerance, datetimes_to_seconds,
    gap_starts, irregular_warning, iso_to_seconds, sampling_period,
)
from ..errors import DataError, IrregularSamplingWarning, OptionError, SamplingPeriodWarning

if TYPE_CHECKING:  # pandas is optional
    import pandas as pd

__all__ = ["from_columns", "from_dataframe"]

# An error listing a file's columns names at most this many.
LISTED_COLUMNS = 30


def _data_row(index: int) -> str:
    return f"row {index + 1}"


@dataclass(frozen=True)
class Table:
    """Named columns read from one source, before the channels are picked.

    ``columns`` maps names to 1-D arrays of one length (numbers, text or date-times);
    ``row(k)`` says where sample ``k`` sits in the source (``"line 12"``); ``Ts`` is a
    period the source stores; ``inputs``/``outputs`` are channels the source itself
    marks as such (a MATLAB iddata, ``u``/``y`` arrays); ``decimal`` is the decimal mark
    of numbers stored as text; ``names`` lists every column of the source in its order
    when only those a request needs were read (:func:`needed_columns`).
    """

    columns: Mapping[str, np.ndarray]
    source: str
    row: Callable[[int], str] = _data_row
    Ts: float | None = None
    inputs: tuple[str, ...] | None = None
    outputs: tuple[str, ...] | None = None
    decimal: str = "."
    names: tuple[str, ...] = ()


@dataclass(frozen=True)
class Request:
    """What the caller asked of a table, checked before any file is opened."""

    inputs: tuple[str, ...] | None
    outputs: tuple[str, ...] | None
    Ts: float | None
    time_column: str | bool | None
    time_format: str | None
    tolerance: float


def _names(value: object, what: str) -> tuple[str, ...] | None:
    if value is None:
        return None
    example = {"inputs": "u1", "outputs": "y1"}.get(what, "c1")
    accepted = f"{what} must be a sequence of column names such as ['{example}']"
    if isinstance(value, str) or not hasattr(value, "__iter__"):
        raise DataError(f"{accepted}, got {value!r}")
    names = tuple(value)  # type: ignore[arg-type]
    if not names or not all(isinstance(name, str) for name in names) or len(set(names)) < len(names):
        raise DataError(f"{accepted}, each named once, got {value!r}")
    return names


def check_request(
    inputs: object, outputs: object, Ts: object, time_column: object, time_format: object,
    tolerance: object,
) -> Request:
    """The caller's channel names, period and time options, or an error saying what is accepted."""
    if time_column is not None and time_column is not False and not isinstance(time_column, str):
        raise OptionError(f"time_column must be a column name, None (find it) or False (none), "
                          f"got {time_column!r}")
    if time_format is not None and not isinstance(time_format, str):
        raise OptionError(f"time_format must be a strftime format such as '%d/%m/%Y %H:%M:%S', "
                          f"got {time_format!r}")
    request = Request(_names(inputs, "inputs"), _names(outputs, "outputs"),
                      None if Ts is None else check_period(Ts), time_column, time_format,
                      check_tolerance(tolerance))
    both = set(request.inputs or ()) & set(request.outputs or ())
    if both:
        raise DataError(f"columns {sorted(both)} are named both as input and as output")
    return request


def check_header(names: Sequence[object], source: str) -> None:
    """Refuse a table whose column names are all numbers: its header row is missing."""
    if names and parse_numbers([str(name) for name in names])[1] is None:
        raise DataError(f"{source}: the first row holds numbers, not column names; add a header "
                        "row naming the columns (e.g. time, u1, y1)")


def needed_columns(request: Request, names: Sequence[str]) -> set[str] | None:
    """The columns of ``names`` that :func:`record` reads for ``request``; None when the
    request does not name both inputs and outputs.

    A reader parses only these: the channels, the time column named or the candidates
    for one (time-like names, the first column) and the period columns
    (moli.data.clocks), so a long record's comment or status column never becomes text
    in memory. None leaves the channels to the file: ``u``/``y`` arrays or an iddata
    (moli.data.array_files); a table, which cannot mark them, then reads no column, and
    the error lists its columns.
    """
    if request.inputs is None or request.outputs is None:
        return None
    channels = {*request.inputs, *request.outputs}
    periods = {name for name in names if period_kind(name) is not None}
    if isinstance(request.time_column, str):
        return channels | periods | {request.time_column}
    if request.time_column is False:
        return channels | periods
    clocks = {name for name in names if looks_like_time(name)}   # the standard names among them
    return channels | periods | clocks | set(names[:1])


def _listing(table: Table) -> str:
    names = list(table.names or table.columns)
    shown = ", ".join(map(repr, names[:LISTED_COLUMNS]))
    return shown + (f" and {len(names) - LISTED_COLUMNS} more" if len(names) > LISTED_COLUMNS else "")


def _shown(cell: object) -> str:
    """A cell as the message quotes it: text in quotes, numbers plain."""
    if isinstance(cell, str):
        return repr(str(cell))
    return repr(cell.item() if isinstance(cell, np.generic) else cell)


def _column(table: Table, name: str) -> np.ndarray:
    if name not in table.columns:
        raise DataError(f"{table.source} has no column {name!r}; columns: {_listing(table)}")
    values = np.asarray(table.columns[name])
    if values.ndim == 2 and 1 in values.shape:
        values = values.ravel()  # MATLAB stores vectors as (N, 1) or (1, N)
    if values.ndim != 1:
        raise DataError(f"column {name!r} of {table.source} has shape {values.shape}, expected (N,)")
    return values


def _numbers(table: Table, name: str) -> np.ndarray:
    """One channel as floats, NaN where a sample is missing; any other bad cell is an error."""
    values = _column(table, name)
    if values.dtype.kind in "mM":
        raise DataError(f"column {name!r} of {table.source} holds time stamps, not numbers; "
                        "name it as the time column or pick another channel")
    numbers, bad = parse_numbers(values, table.decimal)
    if bad is not None:
        raise DataError(f"{table.source}, {table.row(bad)}, column {name!r}: "
                        f"{_shown(values[bad])} is not a number")
    infinite = np.flatnonzero(np.isinf(numbers))
    if infinite.size:
        k = int(infinite[0])
        raise DataError(f"{table.source}, {table.row(k)}, column {name!r}: "
                        f"{_shown(values[k])} is not a finite number")
    return numbers


def _check_missing(table: Table, names: Sequence[str], columns: Sequence[np.ndarray]) -> None:
    """The one place that decides what a missing sample does: it ends a segment.

    An empty or NA cell stays NaN, and :class:`IOData` removes the rows with one and
    starts a new segment after them (docs/data.md, "Gaps and experiments"). Only a
    channel with no value at all, or a table without one complete row, stops the read.
    """
    for name, col in zip(names, columns):
        if np.isnan(col).all():
            raise DataError(f"{table.source}, column {name!r}: no value in any row (empty or NA cells only)")
    if np.isnan(np.column_stack(columns)).any(axis=1).all():
        raise DataError(f"{table.source}: every row lacks a value in one of the columns {list(names)}; "
                        "no complete sample is left")


def _channels(table: Table, request: Request) -> tuple[tuple[str, ...], tuple[str, ...]]:
    if request.inputs is None and request.outputs is None and table.inputs is not None:
        return table.inputs, table.outputs or ()
    if request.inputs is None or request.outputs is None:
        raise DataError(f"name the input and output columns of {table.source}; "
                        f"columns: {_listing(table)}")
    return request.inputs, request.outputs


def _seconds(table: Table, name: str, time_format: str | None) -> tuple[np.ndarray, str]:
    """A time column as numbers (its own unit) or date-times (seconds), and the unit."""
    values = _column(table, name)
    if values.dtype.kind in "mM":
        return datetimes_to_seconds(values), " s"
    bad = None
    if time_format is None:
        numbers, bad = parse_numbers(values, table.decimal)
        if bad is None:
            return numbers, "" if (unit := named_unit(name)) is None else f" {unit}"
    stamps, bad_stamp = iso_to_seconds(values, time_format)
    if bad_stamp is None:
        return stamps, " s"
    first = next(k for k, cell in enumerate(values) if not is_missing(cell))
    # numbers that turn into text part way: report the first cell that is not a number;
    # text from the first cell on: the first that is not a date
    k = bad if bad is not None and bad != first else bad_stamp
    expected = (f"not a time in the format {time_format!r}" if time_format else
                "neither a number nor an ISO 8601 time stamp such as 2024-05-01T12:00:00.5")
    raise DataError(
        f"{table.source}, {table.row(k)}, column {name!r}: {_shown(values[k])} is {expected}; "
        "give time_format= for other date formats, or time_column=False to ignore the column"
    )


def _period(table: Table, request: Request, channels: Sequence[str], samples: int) -> tuple[
        float, np.ndarray | None, str, IrregularSamplingWarning | None, SamplingPeriodWarning | None]:
    """The period of the record, its time stamps (None without a time column), their unit (" s",
    "" where unstated), the warning about irregular steps, and the notice of where the period
    came from when the caller gave none."""
    if isinstance(request.time_column, str) and request.time_column not in table.columns:
        raise DataError(f"{table.source} has no time column {request.time_column!r}; "
                        f"columns: {_listing(table)}")
    clock = find_clock(table.columns, list(table.names or table.columns), channels,
                       request.time_column, request.time_format, table.decimal, tolerance=request.tolerance)
    Ts, stated = stated_period(request.Ts, table.Ts, clock, table.source, request.tolerance)
    chosen = request.Ts is None and table.Ts is None      # moli chose the period: say how
    if clock.time is None:
        Ts = 1.0 if Ts is None else Ts
        return Ts, None, "", None, period_notice(table.source, clock, Ts, "") if chosen else None
    name = clock.time
    seconds, unit = _seconds(table, name, request.time_format)
    if len(seconds) != samples:
        raise DataError(f"time column {name!r} of {table.source} has {len(seconds)} values, "
                        f"the channels {samples}")
    missing = np.flatnonzero(np.isnan(seconds))
    if missing.size:
        raise DataError(f"{table.source}, {table.row(int(missing[0]))}, column {name!r}: "
                        "the time stamp is missing")

    def where(k: int) -> str:
        return f"{table.source}, {table.row(k)}, column {name!r}"

    period, gaps = sampling_period(seconds, Ts, request.tolerance, where, stated or "given")
    notice = period_notice(table.source, clock, period, unit) if chosen else None
    if not gaps:
        return period, seconds, unit, None, notice
    return period, seconds, unit, irregular_warning(gaps, period, samples, request.tolerance, table.source,
                                              table.row, unit=unit), notice


def record(table: Table, request: Request) -> IOData:
    """The record a table holds; irregular time steps warn the public function's caller.

    The record carries the time column's stamps as read (seconds since the first sample for
    date-times) and their unit, its segments starting at the gaps. Called straight from each
    public reader, so the warning points at the line that called that reader.
    """
    inputs, outputs = _channels(table, request)
    columns = {name: _numbers(table, name) for name in (*inputs, *outputs)}
    lengths = {len(values) for values in columns.values()}
    if len(lengths) > 1:
        raise DataError(f"the channels of {table.source} differ in length: " + ", ".join(
            f"{name} {len(values)}" for name, values in columns.items()))
    if lengths == {0}:
        raise DataError(f"{table.source} has no data rows")
    _check_missing(table, list(columns), list(columns.values()))
    Ts, times, unit, warning, notice = _period(table, request, list(columns), lengths.pop())
    u = np.column_stack([columns[name] for name in inputs])
    y = np.column_stack([columns[name] for name in outputs])
    # a gap in the clock is a segment boundary, like a missing sample
    starts = None if warning is None else gap_starts(warning.gaps, Ts)
    data = IOData(y, u, Ts, output_names=outputs, input_names=inputs, segment_starts=starts, times=times,
                  time_unit=unit.strip() or None)
    for found in (warning, notice):
        if found is not None:
            warnings.warn(found, stacklevel=3)
    return data


def from_columns(
    table: Mapping[str, object],
    inputs: Sequence[str],
    outputs: Sequence[str],
    Ts: float | None = None,
    source: str = "the table",
    *,
    time_column: str | bool | None = None,
    time_format: str | None = None,
    time_tolerance: float = TIME_TOLERANCE,
) -> IOData:
    """Build an :class:`IOData` from named columns.

    Parameters
    ----------
    table : mapping of str to array_like
        Column name to 1-D values (all of the same length).
    inputs, outputs : sequence of str
        Names of the input and output columns, in channel order.
    Ts : float, optional
        Sampling period; default: a period or rate column, else the median step of the
        time column, else 1.0 (a :class:`~moli.errors.SamplingPeriodWarning` says which).
    source : str
        What to call the table in error messages.
    time_column, time_format, time_tolerance
        As for :func:`moli.read_data`.

    Returns
    -------
    IOData
        With the time column's stamps in ``times`` (seconds since the first sample for
        date-times), or ``times=None`` without a time column.

    Warns
    -----
    IrregularSamplingWarning
        When the time steps are irregular; its ``gaps`` attribute says where.

    Examples
    --------
    >>> from_columns({"t": [0, 0.5, 1.0], "u": [1, 0, 0], "y": [0, 1, 0.5]}, ["u"], ["y"])
    IOData(N=3, p=1, m=1, Ts=0.5, outputs=['y'], inputs=['u'])
    """
    request = check_request(inputs, outputs, Ts, time_column, time_format, time_tolerance)
    columns = {str(name): np.asarray(values) for name, values in table.items()}
    return record(Table(columns, source), request)


def frame_table(frame: "pd.DataFrame", source: str, row: Callable[[int], str] = _data_row) -> Table:
    """The columns of a data frame (and its index, if named); time zones moved to UTC."""
    import pandas as pd

    columns: dict[str, np.ndarray] = {}
    series = [frame.iloc[:, i] for i in range(frame.shape[1])]    # by position: names may repeat
    if frame.index.name is not None:
        series.append(frame.index.to_series())
    for column in series:
        name = str(column.name).strip()
        if name in columns:
            raise DataError(f"{source} has two columns named {name!r}; rename one, so that each has its own name")
        if isinstance(column.dtype, pd.DatetimeTZDtype):
            column = column.dt.tz_convert(None)
        numeric = pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column)
        columns[name] = column.to_numpy(dtype=float, na_value=np.nan) if numeric else column.to_numpy()
    return Table(columns, source, row)


def from_dataframe(
    frame: "pd.DataFrame",
    inputs: Sequence[str],
    outputs: Sequence[str],
    Ts: float | None = None,
    *,
    time_column: str | bool | None = None,
    time_format: str | None = None,
    time_tolerance: float = TIME_TOLERANCE,
) -> IOData:
    """Build an :class:`IOData` from columns of a pandas data frame.

    Parameters
    ----------
    frame : pandas.DataFrame
        One row per sample.
    inputs, outputs : sequence of str
        Column names of the channels.
    Ts : float, optional
        Sampling period; default: a period or rate column, else the median step of a time
        column or a named index (seconds for date-times), else 1.0 (a
        :class:`~moli.errors.SamplingPeriodWarning` says which).
    time_column, time_format, time_tolerance
        As for :func:`moli.read_data`.

    Returns
    -------
    IOData
        With the time column's stamps in ``times`` (seconds since the first sample for
        date-times), or ``times=None`` without a time column.

    Examples
    --------
    >>> import pandas as pd
    >>> frame = pd.DataFrame({"time": [0.0, 0.2, 0.4], "u": [1, 0, 0], "y": [0, 1, 0.5]})
    >>> from_dataframe(frame, ["u"], ["y"])
    IOData(N=3, p=1, m=1, Ts=0.2, outputs=['y'], inputs=['u'])
    """
    request = check_request(inputs, outputs, Ts, time_column, time_format, time_tolerance)
    if not all(hasattr(frame, name) for name in ("columns", "index")):
        raise DataError(f"frame must be a pandas DataFrame, got {type(frame).__name__}")
    return record(frame_table(frame, "the data frame"), request)
