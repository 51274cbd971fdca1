"""The input-output data container."""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..errors import DataError
from .arguments import name_list, period, real_array
from .segments import (check_slice, check_starts, remove_missing_rows, segment_bounds, starts_after_cut,
                       starts_in_slice)
from .stamps import UNSTATED_PERIOD, check_times, irregular_steps, joined_times, median_step

__all__ = ["as_signal", "stack_signals", "IOData", "merge", "longest_segment", "require_one_segment"]

# Relative difference of two sampling periods still taken as the same when records are
# merged: room for a period written with fewer digits, none for a real change.
TS_TOLERANCE = 1e-6


def as_signal(name: str, values: object, channels: int | None = None, missing: bool = False) -> np.ndarray:
    """Copy ``values`` into a finite float array of shape (N, channels), time along axis 0.

    A 1-D array is one channel. Raises :class:`DataError` naming ``name`` and the
    expected shape when the values are not numeric, not finite or not of that shape.
    With ``missing``, NaN (a missing sample) is let through; inf never is.
    """
    array = real_array(name, values, finite=False)
    if array.ndim == 1:
        array = array[:, None]
    expected = "(N, channels)" if channels is None else f"(N, {channels})"
    if array.ndim != 2 or (channels is not None and array.shape[1] != channels) or array.shape[1] == 0:
        raise DataError(
            f"{name} must be 1-D (one channel) or 2-D with shape {expected}, "
            f"time along axis 0, with at least one channel; got an array of shape {array.shape}"
        )
    bad_values = np.isinf(array) if missing else ~np.isfinite(array)
    if bad_values.any():
        bad = np.argwhere(bad_values)[0]
        raise DataError(
            f"{name} contains {'inf' if missing else 'NaN or inf'} (first at sample {bad[0]}, "
            f"channel {bad[1]}); remove or interpolate those samples first"
        )
    return array


def stack_signals(y: object, u: object, p: int, m: int) -> np.ndarray:
    """Outputs then inputs side by side, ``[y, u]`` of shape (N, p + m), checked."""
    yy = as_signal("y", y, p)
    uu = as_signal("u", u, m)
    if yy.shape[0] != uu.shape[0]:
        raise DataError(f"y and u must have the same number of samples, got {yy.shape[0]} and {uu.shape[0]}")
    return np.concatenate([yy, uu], axis=1)


def _names(given: Sequence[str] | None, count: int, prefix: str, what: str) -> tuple[str, ...]:
    if given is None:
        return tuple(f"{prefix}{i + 1}" for i in range(count))
    return name_list(what, given, count)


class IOData:
    """Sampled input-output data of a multivariable system.

    Parameters
    ----------
    y : array_like, shape (N, p) or (N,)
        Outputs, time along axis 0. A 1-D array is one output channel.
    u : array_like, shape (N, m) or (N,)
        Inputs, time along axis 0. A 1-D array is one input channel.
    Ts : float, default 1.0
        Sampling period (any time unit; filter frequencies are in rad per that unit).
        With ``times`` and no ``Ts``: the median step between the stamps of the same
        segment.
    output_names, input_names : sequence of str, optional
        Channel names; default ``y1, y2, ...`` and ``u1, u2, ...``.
    segment_starts : sequence of int, optional
        First sample of each segment when the arrays hold several experiments (or the
        stretches between gaps) end to end: increasing, the first 0. Default: one
        segment.
    times : array_like, shape (N,), optional
        Time stamp of each sample in the unit of ``Ts``, kept as given (jitter and
        gaps included, never resampled): finite and strictly increasing within each
        segment; they may restart at a segment's first sample. Default: none, the
        samples are ``Ts`` apart.
    time_unit : str, optional
        The unit of ``Ts`` and ``times`` ("s", "ms", ...: a reader takes it from the time
        column), for axes and tables; None: "time unit".

    Notes
    -----
    The arrays are copied: later changes to the caller's arrays do not reach the
    container, and nothing moli does modifies the caller's arrays.

    Every record made from this one (slices, ``split``, ``drop``, ``segments``,
    ``remove_means``, :func:`merge`) keeps the stamps of the samples it holds.

    A NaN marks a missing sample: every sample with a NaN in any channel is removed,
    and the samples after it start a new segment. The identification restarts its
    filters and simulations at each segment (docs/data.md, "Gaps and experiments").

    Examples
    --------
    >>> import numpy as np
    >>> d = IOData(np.zeros((100, 2)), np.ones(100), Ts=0.5)
    >>> d
    IOData(N=100, p=2, m=1, Ts=0.5, outputs=['y1', 'y2'], inputs=['u1'])
    >>> est, val = d.split(60)
    >>> est.N, val.N
    (60, 40)
    """

    def __init__(
        self,
        y: object,
        u: object,
        Ts: float = UNSTATED_PERIOD,
        output_names: Sequence[str] | None = None,
        input_names: Sequence[str] | None = None,
        *,
        segment_starts: Sequence[int] | None = None,
        times: object = None,
        time_unit: str | None = None,
    ) -> None:
        y_arr = as_signal("y", y, missing=True)
        u_arr = as_signal("u", u, missing=True)
        if y_arr.shape[0] != u_arr.shape[0]:
            raise DataError(
                f"y and u must have the same number of samples along axis 0: "
                f"y has {y_arr.shape[0]}, u has {u_arr.shape[0]} "
                "(time runs along axis 0; transpose if channels are along it)"
            )
        if y_arr.shape[0] == 0:
            raise DataError("y and u hold no samples: a record needs at least one (shape (N, channels), N >= 1)")
        stated = Ts is not UNSTATED_PERIOD
        Ts = period(Ts)
        starts = (0,) if segment_starts is None else check_starts(segment_starts, y_arr.shape[0])
        stamps = None if times is None else check_times(times, y_arr.shape[0], starts)
        if stamps is not None and not stated:
            Ts = median_step(stamps, starts)
        y_arr, u_arr, stamps, self._starts = remove_missing_rows(y_arr, u_arr, starts, stamps)
        for array in (y_arr, u_arr, stamps):
            if array is not None:
                array.flags.writeable = False
        self._y, self._u, self._times = y_arr, u_arr, stamps
        self.Ts = float(Ts)
        self.output_names = _names(output_names, y_arr.shape[1], "y", "output_names")
        self.input_names = _names(input_names, u_arr.shape[1], "u", "input_names")
        self.y_offset = np.zeros(self.p)
        self.u_offset = np.zeros(self.m)
        if time_unit is not None and not isinstance(time_unit, str):
            raise DataError(f"time_unit must be a str such as 's', got {type(time_unit).__name__}")
        self.time_unit = time_unit

    @property
    def y(self) -> np.ndarray:
        """Outputs, shape (N, p) (read-only view)."""
        return self._y

    @property
    def u(self) -> np.ndarray:
        """Inputs, shape (N, m) (read-only view)."""
        return self._u

    @property
    def times(self) -> np.ndarray | None:
        """Time stamp of each sample as given, shape (N,) (read-only view); None when the
        record has none and its samples are ``Ts`` apart."""
        return self._times

    @property
    def N(self) -> int:
        """Number of samples."""
        return self._y.shape[0]

    @property
    def p(self) -> int:
        """Number of outputs."""
        return self._y.shape[1]

    @property
    def m(self) -> int:
        """Number of inputs."""
        return self._u.shape[1]

    @property
    def n_segments(self) -> int:
        """Number of segments (experiments, or stretches between gaps)."""
        return len(self._starts)

    @property
    def segment_starts(self) -> tuple[int, ...]:
        """First sample of each segment in the concatenated record (the first is 0)."""
        return self._starts

    @property
    def bounds(self) -> tuple[tuple[int, int], ...]:
        """``(start, stop)`` sample indices of each segment in the concatenated record."""
        return segment_bounds(self._starts, self.N)

    @property
    def segments(self) -> tuple["IOData", ...]:
        """Each segment as a record of its own (copies; offsets kept)."""
        return tuple(self[start:stop] for start, stop in self.bounds)

    def __len__(self) -> int:
        return self.N

    def __repr__(self) -> str:
        irregular = 0 if self._times is None else irregular_steps(self._times, self._starts, self.Ts)
        return (
            f"IOData(N={self.N}, p={self.p}, m={self.m}, Ts={self.Ts:g}, "
            f"outputs={list(self.output_names)}, inputs={list(self.input_names)}"
            + (f", segments={self.n_segments}" if self.n_segments > 1 else "")
            + (f", times: {irregular} irregular step{'s' if irregular > 1 else ''}" if irregular else "") + ")"
        )

    def _with(
        self, y: np.ndarray, u: np.ndarray, y_offset: np.ndarray, u_offset: np.ndarray,
        starts: tuple[int, ...] | None = None, rows: slice | np.ndarray | None = None,
    ) -> "IOData":
        """A record of these samples with this one's period and names; ``rows`` picks
        this record's stamps of them (all when None)."""
        stamps = None if self._times is None else self._times if rows is None else self._times[rows]
        new = IOData(y, u, self.Ts, self.output_names, self.input_names,
                     segment_starts=self._starts if starts is None else starts, times=stamps, time_unit=self.time_unit)
        new.y_offset = np.array(y_offset, dtype=float)
        new.u_offset = np.array(u_offset, dtype=float)
        return new

    def __getitem__(self, index: slice) -> "IOData":
        """Samples selected by a slice, e.g. ``data[100:600]``; segment boundaries inside it are kept."""
        index = check_slice(index, self.N, self.n_segments, self._times is not None)
        y, u = self._y[index], self._u[index]
        if y.shape[0] == 0:
            raise DataError(f"slice {index} selects no samples of {self.N}")
        starts = starts_in_slice(self._starts, self.N, index) if self.n_segments > 1 else (0,)
        return self._with(y, u, self.y_offset, self.u_offset, starts, index)

    def drop(self, start: int, stop: int) -> "IOData":
        """The record without samples ``start..stop-1``: the two sides become separate segments.

        Parameters
        ----------
        start, stop : int
            Sample indices of the concatenated record, ``0 <= start < stop <= N``;
            at least one sample must remain.

        Returns
        -------
        IOData
        """
        for name, value in (("start", start), ("stop", stop)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise DataError(f"drop: {name} must be a sample index (an integer), got {value!r}")
        if not 0 <= start < stop <= self.N or (start, stop) == (0, self.N):
            raise DataError(f"drop needs 0 <= start < stop <= N = {self.N} and at least one sample "
                            f"left, got start={start}, stop={stop}")
        kept = np.r_[0:start, stop : self.N]
        return self._with(self._y[kept], self._u[kept], self.y_offset, self.u_offset,
                          starts_after_cut(self._starts, self.N, int(start), int(stop)), kept)

    def split(self, at: int | float) -> tuple["IOData", "IOData"]:
        """Split into a head and a tail.

        Parameters
        ----------
        at : int or float
            Sample index where the tail starts, or, if a float in (0, 1), the
            fraction of samples that go to the head.

        Returns
        -------
        head, tail : IOData
        """
        if isinstance(at, bool) or not isinstance(at, (int, float, np.integer, np.floating)) or not np.isfinite(at):
            raise DataError(f"split point must be a sample index or a fraction in (0, 1), got {at!r}")
        if isinstance(at, float) and not at.is_integer():
            if not 0 < at < 1:
                raise DataError(f"a fractional split must lie in (0, 1), got {at}")
            fraction, at = at, int(round(at * self.N))
            if not 0 < at < self.N:
                raise DataError(f"a record of {self.N} sample{'s' if self.N != 1 else ''} cannot be split at "
                                f"the fraction {fraction:g}: one side would be empty")
        at = int(at)
        if not 0 < at < self.N:
            raise DataError(f"split point must lie in 1..{self.N - 1}, got {at}")
        return self[:at], self[at:]

    def time(self) -> np.ndarray:
        """Sample times, shape (N,): the stamps when the record has them, else ``k * Ts``
        counted through the segments end to end (a new array either way)."""
        return np.arange(self.N) * self.Ts if self._times is None else self._times.copy()

    def remove_means(self, y_offset: np.ndarray | None = None, u_offset: np.ndarray | None = None) -> "IOData":
        """Subtract offsets (by default this record's means) and remember them.

        Parameters
        ----------
        y_offset, u_offset : array_like, optional
            Offsets to subtract, e.g. the means of an estimation record applied to a
            validation record. Default: this record's own means, over all its segments
            together (one operating point).

        Returns
        -------
        IOData
            Centred data; ``y_offset``/``u_offset`` hold the total offsets removed
            from the original signals, so ``centred.y + centred.y_offset`` restores them.
        """
        dy = self._y.mean(axis=0) if y_offset is None else \
            real_array("y_offset", y_offset, shape=(self.p,)) - self.y_offset
        du = self._u.mean(axis=0) if u_offset is None else \
            real_array("u_offset", u_offset, shape=(self.m,)) - self.u_offset
        return self._with(self._y - dy, self._u - du, self.y_offset + dy, self.u_offset + du)


def merge(records: Sequence[IOData]) -> IOData:
    """One record whose segments are the given records' segments, in order.

    Parameters
    ----------
    records : sequence of IOData
        Experiments on the same plant: the same output and input names (so the same
        channel counts), sampling period (relative tolerance 1e-6) and offsets; time
        stamps on every record or on none.

    Returns
    -------
    IOData
        Its ``Ts`` and offsets are the first record's; its stamps, if any, each
        record's own, in order.

    Raises
    ------
    DataError
        No records, something that is not an :class:`IOData`, or a record whose
        channels, sampling period or offsets differ from the first one's, or that has
        time stamps where the first has none or the other way round (named by its
        position).

    Examples
    --------
    >>> import numpy as np, moli
    >>> a = moli.IOData(np.zeros(50), np.ones(50))
    >>> both = moli.merge([a, a[:30]])
    >>> both.N, both.n_segments, both.bounds
    (80, 2, ((0, 50), (50, 80)))
    """
    if isinstance(records, IOData) or not isinstance(records, Sequence) or not records:
        raise DataError("merge takes a non-empty list of IOData records")
    first = records[0]
    for i, record in enumerate(records):
        if not isinstance(record, IOData):
            raise DataError(f"merge: record {i} is a {type(record).__name__}, not an IOData")
        differs = []
        if (record.p, record.m) != (first.p, first.m):
            differs.append(f"{record.p} outputs and {record.m} inputs, record 0 has {first.p} and {first.m}")
        elif (record.output_names, record.input_names) != (first.output_names, first.input_names):
            differs.append(f"channels {list(record.output_names)}, {list(record.input_names)}, record 0 has "
                           f"{list(first.output_names)}, {list(first.input_names)}")
        if not math.isclose(record.Ts, first.Ts, rel_tol=TS_TOLERANCE):
            differs.append(f"Ts = {record.Ts:g}, record 0 has Ts = {first.Ts:g}")
        if not (np.array_equal(record.y_offset, first.y_offset) and np.array_equal(record.u_offset, first.u_offset)):
            differs.append("other offsets removed than record 0 (merge the raw records, then remove the means)")
        if differs:
            raise DataError(f"merge: record {i} has " + "; ".join(differs))
    starts, total = [], 0
    for record in records:
        starts.extend(total + s for s, _ in record.bounds)
        total += record.N
    stamps = joined_times([r.times for r in records])
    merged = IOData(np.concatenate([r.y for r in records]), np.concatenate([r.u for r in records]), first.Ts,
                    first.output_names, first.input_names, segment_starts=starts, times=stamps,
                    time_unit=first.time_unit if len({r.time_unit for r in records}) == 1 else None)
    merged.y_offset, merged.u_offset = first.y_offset.copy(), first.u_offset.copy()
    return merged


def longest_segment(data: IOData) -> IOData:
    """The longest segment of ``data`` (the first of equal ones); ``data`` itself when it has one."""
    if data.n_segments == 1:
        return data
    start, stop = max(data.bounds, key=lambda bound: bound[1] - bound[0])
    return data[start:stop]


def require_one_segment(data: IOData, what: str) -> None:
    """Raise :class:`DataError` when ``data`` has several segments: ``what`` needs a record without gaps."""
    if data.n_segments > 1:
        raise DataError(
            f"{what} needs a continuous record, and this one has {data.n_segments} segments "
            f"(gaps or merged experiments, bounds {list(data.bounds)}); pass one of data.segments"
        )
