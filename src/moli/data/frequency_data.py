"""FrequencyData: a measured frequency response G(omega) of shape (F, p, m), its lines, their variance and coherence."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import DataError, wrong_type
from .arguments import name_list, period, real_array

__all__ = ["FrequencyData", "FREQUENCY_UNITS"]

# How the caller states the frequencies: stored in rad per time unit either way.
FREQUENCY_UNITS = ("rad/s", "Hz")
# A discrete-time response repeats past Nyquist (pi / Ts); a line above it by more than
# this relative round-off (a frequency column printed with a few digits) is an error.
NYQUIST_SLACK = 1e-9


def _frequencies(frequencies: object, unit: object) -> np.ndarray:
    if unit not in FREQUENCY_UNITS:
        raise DataError(f"unit must be one of {FREQUENCY_UNITS}, got {unit!r}")
    values = real_array("frequencies", frequencies, ndim=1, finite=False)
    if values.size == 0:
        raise DataError("frequencies must hold at least one line, got none")
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise DataError(f"frequencies must be finite: frequency {bad[0] + 1} (from 1) is {values[bad[0]]!r}")
    negative = np.flatnonzero(values < 0)
    if negative.size:
        raise DataError(f"frequencies must be zero or positive: frequency {negative[0] + 1} (from 1) is "
                        f"{values[negative[0]]:g} {unit}")
    steps = np.flatnonzero(np.diff(values) <= 0)
    if steps.size:
        k = steps[0]
        raise DataError(f"frequencies must increase strictly: frequency {k + 2} (from 1; {values[k + 1]:g} {unit}) "
                        f"does not exceed frequency {k + 1} ({values[k]:g} {unit}); sort the lines and drop "
                        "repeated ones")
    return values * (2 * np.pi if unit == "Hz" else 1.0)


def _response(G: object, lines: int, shape: tuple[int, int] | None) -> np.ndarray:
    if G is None or isinstance(G, (str, bytes)):
        raise wrong_type(DataError)(f"G must be an array of complex responses, got {G!r}")
    try:
        response = np.array(G, dtype=complex, copy=True)
    except (TypeError, ValueError) as exc:
        raise DataError(f"G must be an array of complex numbers: {exc}") from None
    if response.ndim == 1:                       # one output, one input
        response = response[:, None, None]
    if response.ndim != 3 or response.shape[0] != lines:
        raise DataError(f"G must have shape (F, p, m) with F = {lines} lines (one per frequency), "
                        f"got shape {response.shape}")
    if shape is not None and response.shape[1:] != shape:
        raise DataError(f"G has {response.shape[1]} outputs and {response.shape[2]} inputs, but the names give "
                        f"{shape[0]} outputs and {shape[1]} inputs")
    if 0 in response.shape[1:]:
        raise DataError(f"G must have at least one output and one input, got shape {response.shape}")
    return response


def _averages(averages: object) -> int | None:
    if averages is None:
        return None
    if isinstance(averages, (bool, np.bool_)) or not isinstance(averages, (int, np.integer)) or averages < 1:
        raise DataError(f"averages must be a positive integer (the spectra averaged per line), got {averages!r}")
    return int(averages)


def _first_bad_line(values: np.ndarray) -> int | None:
    bad = ~np.isfinite(values.reshape(values.shape[0], -1)).all(axis=1)
    return int(np.argmax(bad)) if bad.any() else None


class FrequencyData:
    """A multivariable frequency response measured on ``F`` lines: ``G[k]`` is the (p, m)
    matrix at frequency ``omega[k]``.

    Parameters
    ----------
    frequencies : array_like, shape (F,)
        The lines, strictly increasing, zero or positive, in ``unit``.
    G : array_like, shape (F, p, m) or (F,)
        The complex response, ``G[k, i, j]`` from input ``j`` to output ``i`` (1-D: one
        input, one output).
    unit : {"rad/s", "Hz"}
        The unit of ``frequencies`` (rad or cycles per time unit; stored as rad).
    Ts : float, optional
        Sampling period of a discrete-time system (``G[k] = H(exp(1j omega_k Ts))``, every
        line at most the Nyquist frequency ``pi / Ts``); None: a continuous-time system
        (``G[k] = H(1j omega_k)``).
    variance : array_like, shape (F, p, m) or (F,), optional
        Variance ``E|G_measured - G_true|^2`` of each line's complex response (1-D: the
        same for every channel pair of a line); positive and finite. None: every line
        and channel counts the same.
    output_names, input_names : sequence of str, optional
        Default ``y1, y2, ...`` and ``u1, u2, ...``.

    Examples
    --------
    >>> import numpy as np
    >>> f = np.array([0.1, 1.0, 10.0])
    >>> data = FrequencyData(f, 1 / (1 + 2j * np.pi * f), unit="Hz")
    >>> data.F, data.p, data.m, data.Ts is None
    (3, 1, 1, True)
    >>> bool(np.isclose(data.omega[1], 2 * np.pi))
    True
    """

    def __init__(
        self,
        frequencies: object,
        G: object,
        *,
        unit: str,
        Ts: float | None = None,
        variance: object | None = None,
        output_names: Sequence[str] | None = None,
        input_names: Sequence[str] | None = None,
        coherence: object | None = None,
        averages: int | None = None,
    ) -> None:
        omega = _frequencies(frequencies, unit)
        named = None
        if output_names is not None and input_names is not None:
            named = (len(output_names), len(input_names))
        response = _response(G, omega.size, named)
        p, m = response.shape[1:]
        bad = _first_bad_line(response)
        if bad is not None:
            raise DataError(f"G has NaN or inf at frequency {bad + 1} (from 1; {omega[bad]:g} rad/s): drop the "
                            "line or fill it before building FrequencyData")
        self.Ts = None if Ts is None else period(Ts)
        if self.Ts is not None and omega[-1] > np.pi / self.Ts * (1 + NYQUIST_SLACK):
            above = int(np.argmax(omega > np.pi / self.Ts * (1 + NYQUIST_SLACK)))
            raise DataError(f"line {above} ({omega[above]:g} rad/s) lies above the Nyquist frequency "
                            f"pi / Ts = {np.pi / self.Ts:g} rad/s of Ts = {self.Ts:g}: a sampled system's "
                            "response repeats there; drop those lines or give the right Ts")
        self.output_names = (tuple(f"y{i + 1}" for i in range(p)) if output_names is None
                             else name_list("output_names", output_names, p))
        self.input_names = (tuple(f"u{j + 1}" for j in range(m)) if input_names is None
                            else name_list("input_names", input_names, m))
        self._omega = omega
        self._G = response
        self._coherence = None if coherence is None else self._checked_coherence(coherence)
        self.averages = _averages(averages)
        if self.averages is not None and (self._coherence is None or variance is not None):
            raise DataError("averages turns a coherence into a variance: give it with coherence and without "
                            f"variance (got coherence={'None' if self._coherence is None else 'given'}, "
                            f"variance={'None' if variance is None else 'given'})")
        if self.averages is not None:
            variance = self._variance_from_coherence()
        self._variance = None if variance is None else self._checked_variance(variance)
        for array in (self._omega, self._G, self._variance, self._coherence):
            if array is not None:
                array.flags.writeable = False

    def _checked_variance(self, variance: object) -> np.ndarray:
        values = self._per_pair("variance", variance)
        low = np.flatnonzero((values <= 0).reshape(self.F, -1).any(axis=1))
        if low.size:
            raise DataError(f"variance must be positive: line {low[0]} ({self._omega[low[0]]:g} rad/s) has "
                            f"{values[low[0]].min():g}; leave variance out to weigh every line the same")
        return values

    def _per_pair(self, name: str, given: object) -> np.ndarray:
        values = real_array(name, given, finite=False)
        if values.ndim == 1 and values.shape == (self.F,):
            values = np.repeat(values[:, None, None], self.p, axis=1).repeat(self.m, axis=2)
        if values.shape != self._G.shape:
            raise DataError(f"{name} must have shape {self._G.shape} (like G) or ({self.F},), got {values.shape}")
        bad = _first_bad_line(values)
        if bad is not None:
            raise DataError(f"{name} has NaN or inf at frequency {bad + 1} (from 1; {self._omega[bad]:g} rad/s)")
        return values

    def _checked_coherence(self, coherence: object) -> np.ndarray:
        values = self._per_pair("coherence", coherence)
        outside = np.flatnonzero(((values < 0) | (values > 1)).reshape(self.F, -1).any(axis=1))
        if outside.size:
            k = outside[0]
            worst = values[k].min() if values[k].min() < 0 else values[k].max()
            raise DataError(f"coherence must lie in [0, 1] (the magnitude-squared coherence): frequency {k + 1} "
                            f"(from 1; {self._omega[k]:g} rad/s) has {worst:g}")
        return values

    def _variance_from_coherence(self) -> np.ndarray:
        """The H1 estimate's variance ``(1 - gamma^2) |G|^2 / (n gamma^2)`` (Bendat and Piersol: twice the
        variance of ``|G|``, the error being circular)."""
        coherence = self._coherence
        edge = np.flatnonzero(((coherence <= 0) | (coherence >= 1)).reshape(self.F, -1).any(axis=1))
        if edge.size:
            k = edge[0]
            raise DataError(f"coherence {coherence[k].min() if coherence[k].min() <= 0 else coherence[k].max():g} "
                            f"at frequency {k + 1} (from 1; {self._omega[k]:g} rad/s) gives no variance (0 or "
                            "infinite): drop the line, or give variance instead of averages")
        return (1.0 - coherence) * np.abs(self._G) ** 2 / (self.averages * coherence)

    @property
    def omega(self) -> np.ndarray:
        """The lines in rad per time unit, shape (F,) (read-only)."""
        return self._omega

    @property
    def hz(self) -> np.ndarray:
        """The lines in cycles per time unit, shape (F,)."""
        return self._omega / (2 * np.pi)

    @property
    def G(self) -> np.ndarray:
        """The complex response, shape (F, p, m) (read-only)."""
        return self._G

    @property
    def variance(self) -> np.ndarray | None:
        """Each line's and channel pair's variance, shape (F, p, m), or None (read-only)."""
        return self._variance

    @property
    def coherence(self) -> np.ndarray | None:
        """Each line's and channel pair's magnitude-squared coherence, shape (F, p, m), or None (read-only)."""
        return self._coherence

    @property
    def F(self) -> int:
        """Number of lines."""
        return self._G.shape[0]

    @property
    def p(self) -> int:
        """Number of outputs."""
        return self._G.shape[1]

    @property
    def m(self) -> int:
        """Number of inputs."""
        return self._G.shape[2]

    @property
    def points(self) -> np.ndarray:
        """Where the transfer function is evaluated: ``1j omega`` (continuous) or ``exp(1j omega Ts)``."""
        return 1j * self._omega if self.Ts is None else np.exp(1j * self._omega * self.Ts)

    def __len__(self) -> int:
        return self.F

    def __repr__(self) -> str:
        kind = "continuous" if self.Ts is None else f"Ts={self.Ts:g}"
        return (f"FrequencyData(F={self.F}, p={self.p}, m={self.m}, {kind}, "
                f"omega={self._omega[0]:g}..{self._omega[-1]:g} rad/s, variance={self._variance is not None}"
                + ("" if self._coherence is None else ", coherence=True") + ")")

    def lines(self, index: object) -> "FrequencyData":
        """The lines picked by ``index`` (a slice, a boolean mask or increasing integer positions)."""
        picked = np.arange(self.F)[index]
        if np.ndim(picked) == 0 or np.size(picked) == 0:
            raise DataError(f"lines needs an index that keeps at least one of the {self.F} lines, got {index!r}")
        return self.pairs(picked, range(self.p), range(self.m))

    def pairs(self, lines: object, outputs: Sequence[int], inputs: Sequence[int]) -> "FrequencyData":
        """The ``lines`` (any index of the lines) of the pairs of ``outputs`` and ``inputs`` (positions),
        with their variance and coherence (the variance derived again where it came from the coherence)."""
        rows, columns = list(outputs), list(inputs)

        def part(values: np.ndarray | None) -> np.ndarray | None:
            return None if values is None else values[lines][:, rows][:, :, columns]

        return FrequencyData(
            self._omega[lines], part(self._G), unit="rad/s", Ts=self.Ts,
            variance=None if self.averages is not None else part(self._variance),
            output_names=[self.output_names[i] for i in rows], input_names=[self.input_names[j] for j in columns],
            coherence=part(self._coherence), averages=self.averages,
        )
