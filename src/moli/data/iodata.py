"""The input-output data container."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import DataError
from .arguments import name_list, period, real_array

__all__ = ["as_signal", "stack_signals", "IOData"]


def as_signal(name: str, values: object, channels: int | None = None) -> np.ndarray:
    """Copy ``values`` into a finite float array of shape (N, channels), time along axis 0.

    A 1-D array is one channel. Raises :class:`DataError` naming ``name`` and the
    expected shape when the values are not numeric, not finite or not of that shape.
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
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        raise DataError(
            f"{name} contains NaN or inf (first at sample {bad[0]}, channel {bad[1]}); "
            "remove or interpolate those samples first"
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
    output_names, input_names : sequence of str, optional
        Channel names; default ``y1, y2, ...`` and ``u1, u2, ...``.

    Notes
    -----
    The arrays are copied: later changes to the caller's arrays do not reach the
    container, and nothing moli does modifies the caller's arrays.

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
        Ts: float = 1.0,
        output_names: Sequence[str] | None = None,
        input_names: Sequence[str] | None = None,
    ) -> None:
        y_arr = as_signal("y", y)
        u_arr = as_signal("u", u)
        if y_arr.shape[0] != u_arr.shape[0]:
            raise DataError(
                f"y and u must have the same number of samples along axis 0: "
                f"y has {y_arr.shape[0]}, u has {u_arr.shape[0]} "
                "(time runs along axis 0; transpose if channels are along it)"
            )
        if y_arr.shape[0] == 0:
            raise DataError("y and u hold no samples: a record needs at least one (shape (N, channels), N >= 1)")
        Ts = period(Ts)
        self._y = y_arr
        self._u = u_arr
        self._y.flags.writeable = False
        self._u.flags.writeable = False
        self.Ts = float(Ts)
        self.output_names = _names(output_names, y_arr.shape[1], "y", "output_names")
        self.input_names = _names(input_names, u_arr.shape[1], "u", "input_names")
        self.y_offset = np.zeros(self.p)
        self.u_offset = np.zeros(self.m)

    @property
    def y(self) -> np.ndarray:
        """Outputs, shape (N, p) (read-only view)."""
        return self._y

    @property
    def u(self) -> np.ndarray:
        """Inputs, shape (N, m) (read-only view)."""
        return self._u

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

    def __len__(self) -> int:
        return self.N

    def __repr__(self) -> str:
        return (
            f"IOData(N={self.N}, p={self.p}, m={self.m}, Ts={self.Ts:g}, "
            f"outputs={list(self.output_names)}, inputs={list(self.input_names)})"
        )

    def _with(self, y: np.ndarray, u: np.ndarray, y_offset: np.ndarray, u_offset: np.ndarray) -> "IOData":
        new = IOData(y, u, self.Ts, self.output_names, self.input_names)
        new.y_offset = np.array(y_offset, dtype=float)
        new.u_offset = np.array(u_offset, dtype=float)
        return new

    def __getitem__(self, index: slice) -> "IOData":
        """Samples selected by a slice, e.g. ``data[100:600]``."""
        if not isinstance(index, slice):
            raise DataError("IOData is indexed by a slice of samples, e.g. data[0:500]")
        y, u = self._y[index], self._u[index]
        if y.shape[0] == 0:
            raise DataError(f"slice {index} selects no samples of {self.N}")
        return self._with(y, u, self.y_offset, self.u_offset)

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
            at = int(round(at * self.N))
        at = int(at)
        if not 0 < at < self.N:
            raise DataError(f"split point must lie in 1..{self.N - 1}, got {at}")
        return self[:at], self[at:]

    def time(self) -> np.ndarray:
        """Sample times ``k * Ts``, shape (N,)."""
        return np.arange(self.N) * self.Ts

    def remove_means(self, y_offset: np.ndarray | None = None, u_offset: np.ndarray | None = None) -> "IOData":
        """Subtract offsets (by default this record's means) and remember them.

        Parameters
        ----------
        y_offset, u_offset : array_like, optional
            Offsets to subtract, e.g. the means of an estimation record applied to a
            validation record. Default: this record's own means.

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
