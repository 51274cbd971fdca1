"""Does an input depend on the outputs? A test for feedback in a record.

In open loop the inputs are made without looking at the outputs, so they are
independent of the output noise. Under feedback (a controller acting on measured
outputs) the noise reaches the inputs. The check (docs/diagnostics.md §4):

1. Output innovations ``e``: residuals of the ARX model of each output on an
   intercept, ``y[k-1..k-L]`` and ``u[k-1..k-L]``. In open loop they are the noise.
2. For each input ``u_j``, the F-test of ``e[k], e[k-1], ..., e[k-L]`` (every output)
   added to the regression of ``u_j[k]`` on an intercept and ``u[k-1..k-L]`` (every
   input). Regressing on the inputs' own past whitens them, so this tests the
   correlation between each input's innovation and the output innovations.

Lag 0 is where a controller that computes ``u[k]`` from ``y[k]`` shows (a PI loop
whose reference is white is visible nowhere else); it is also where a plant with
direct feedthrough shows, which ``lag_zero=False`` leaves out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.special

from ..data.iodata import IOData, require_one_segment
from ..errors import DataError

__all__ = ["FeedbackCheck", "feedback_check", "DEFAULT_LAGS"]

DEFAULT_LAGS = 10
# The full regression keeps at least this many residual degrees of freedom per column.
ROWS_PER_COLUMN = 3


@dataclass(frozen=True)
class FeedbackCheck:
    """Outcome of :func:`feedback_check`.

    Attributes
    ----------
    detected : bool
        True when some input's p-value is below ``level / m`` (Bonferroni: ``level``
        bounds the chance of a false alarm on open-loop data, whatever ``m``).
    pvalues : ndarray, shape (m,)
        Per input, the p-value of "the output innovations do not help predict this
        input"; NaN where the input changes too rarely to test (its innovation is
        spread over fewer samples than the test has columns, e.g. a binary signal that
        switches a few times in the record).
    lags : int
        Past samples of every channel in the regressions.
    level : float
        Family-wise false-alarm level.
    input_names : tuple of str
    lag_zero : bool
        Whether the current output innovations were tested too.
    """

    detected: bool
    pvalues: np.ndarray
    lags: int
    level: float
    input_names: tuple[str, ...]
    lag_zero: bool = True

    @property
    def flagged(self) -> tuple[str, ...]:
        """Names of the inputs whose p-value is below ``level / m``."""
        bound = self.level / len(self.pvalues)
        return tuple(name for name, pv in zip(self.input_names, self.pvalues) if pv < bound)

    def summary(self) -> str:
        """One line: the verdict and the p-values that decide it."""
        values = ", ".join(f"{name} p = {pv:.2g}" if np.isfinite(pv) else f"{name} untested (too few changes)"
                           for name, pv in zip(self.input_names, self.pvalues))
        if self.detected:
            verdict = "feedback detected: the output noise reaches " + ", ".join(self.flagged)
        else:
            verdict = "no feedback detected"
        return (f"{verdict} ({values}; lags {0 if self.lag_zero else 1}-{self.lags}, level {self.level:g} "
                f"over {len(self.pvalues)} input{'s' if len(self.pvalues) > 1 else ''})")


def usable_lags(N: int, p: int, m: int, lags: int = DEFAULT_LAGS) -> int:
    """The most lags, up to ``lags``, that a record of ``N`` samples supports (0: none)."""
    for L in range(lags, 0, -1):
        if N - 2 * L >= ROWS_PER_COLUMN * (1 + (p + m) * L + p + m):
            return L
    return 0


def feedback_check(
    data: IOData, lags: int | None = None, level: float = 0.01, *, lag_zero: bool = True
) -> FeedbackCheck:
    """Test whether the inputs of a record depend on its outputs (feedback).

    For each input, the F-test of the output innovations (ARX residuals) at lags
    0 to ``lags`` in a least-squares regression of the input on its own and the
    other inputs' past. Output-error identification from data with feedback is
    biased unless the noise is white: the noise reaches the inputs through the
    controller.

    Parameters
    ----------
    data : IOData
        The record.
    lags : int, optional
        Past samples of each channel; default 10, or fewer when the record is too
        short (each regression keeps three rows per column).
    level : float, default 0.01
        False-alarm probability on open-loop data, shared by the inputs (each input
        is tested at ``level / m``).
    lag_zero : bool, default True
        Test the current innovations too. A controller that reacts within the
        sample shows only there; so does a plant with direct feedthrough (``D``
        not zero), which lag 0 cannot tell from feedback: pass False for such a plant.

    Returns
    -------
    FeedbackCheck

    Raises
    ------
    DataError
        ``data`` not an IOData, a bad ``lags``, ``level`` or ``lag_zero``, or a
        record too short.

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(0)
    >>> r, v = rng.standard_normal(2000), 0.3 * rng.standard_normal(2000)
    >>> x, y, u = 0.0, np.empty(2000), np.empty(2000)
    >>> for k in range(2000):              # y = 0.5 u / (q - 0.9) + v, u = r - 0.5 y
    ...     y[k] = x + v[k]
    ...     u[k] = r[k] - 0.5 * y[k]
    ...     x = 0.9 * x + 0.5 * u[k]
    >>> moli.feedback_check(moli.IOData(y, u)).detected
    True
    >>> moli.feedback_check(moli.IOData(y, r)).detected    # r is open loop
    False
    """
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    require_one_segment(data, "feedback_check (lagged regressions)")
    if isinstance(level, bool) or not isinstance(level, (int, float)) or not 0 < level < 1:
        raise DataError(f"level must be a number in (0, 1), got {level!r}")
    if not isinstance(lag_zero, bool):
        raise DataError(f"lag_zero must be True or False, got {lag_zero!r}")
    N, p, m = data.N, data.p, data.m
    if lags is None:
        L = usable_lags(N, p, m)
    elif isinstance(lags, (bool, np.bool_)) or not isinstance(lags, (int, np.integer)) or lags < 1:
        raise DataError(f"lags must be a positive integer, got {lags!r}")
    else:
        L = int(lags) if usable_lags(N, p, m, int(lags)) == int(lags) else 0
    if L == 0:
        wanted = "one lag" if lags is None else f"lags = {lags}"
        raise DataError(
            f"{N} samples are too few for the feedback check with {wanted}: its regression "
            f"needs {ROWS_PER_COLUMN} rows per column ({1 + (p + m) * max(L, lags or 1) + m} columns)"
        )
    pvalues = _pvalues(data, L, lag_zero)
    return FeedbackCheck(bool(np.any(pvalues < level / m)), pvalues, L, float(level),
                         data.input_names, lag_zero)


def _lagged(signal: np.ndarray, lags: range, start: int) -> list[np.ndarray]:
    """``signal[k - l]`` for ``k = start .. N-1``, one block per lag ``l``."""
    N = signal.shape[0]
    return [signal[start - l : N - l] for l in lags]


def _innovations(data: IOData, L: int) -> np.ndarray:
    """Output innovations: residuals of the ARX model of every output on 1, y[k-1..k-L], u[k-1..k-L].

    Row ``i`` is sample ``L + i``. In open loop they hold the noise, not the inputs,
    however coloured the inputs are: a test on the raw outputs would find the inputs'
    distant past in them (through the plant's memory) and mistake it for feedback.
    """
    X = np.column_stack([np.ones(data.N - L), *_lagged(data.y, range(1, L + 1), L),
                         *_lagged(data.u, range(1, L + 1), L)])
    target = data.y[L:]
    return target - X @ np.linalg.lstsq(X, target, rcond=None)[0]


def _pvalues(data: IOData, L: int, lag_zero: bool) -> np.ndarray:
    """Per input, the F-test p-value of the output innovations, from one QR shared by all inputs."""
    m = data.m
    innovations = _innovations(data, L)                       # samples L .. N-1
    start = 2 * L                                              # L lags of the innovations
    u = data.u[L:]                                             # aligned with them
    rows = data.N - start
    own = _lagged(u, range(1, L + 1), L)
    tested = _lagged(innovations, range(0 if lag_zero else 1, L + 1), L)
    # column order: intercept and the inputs' past (restricted model), the
    # innovations (full model), then the current inputs, so that one triangular
    # factor gives both residual sums of every input
    X = np.column_stack([np.ones(rows), *own, *tested, u[L:]])
    norms = np.linalg.norm(X, axis=0)
    norms[norms == 0] = 1.0                 # a zero column adds nothing either way
    R = scipy.linalg.qr(X / norms, mode="r", check_finite=False)[0]
    restricted = 1 + m * L
    added = data.p * len(tested)
    full = restricted + added
    dof = rows - full
    spread = _spread(u[L:])
    pvalues = np.ones(m)
    for j in range(m):
        column = R[:, full + j]
        rss_full = float(column[full:] @ column[full:])
        rss_restricted = float(column[restricted:] @ column[restricted:])
        # an input its own past predicts exactly (a constant, a sine) is not driven
        # by anything else, feedback included: p = 1
        if not (rss_full > 1e-12 * rss_restricted and rss_restricted > 0):
            continue
        if spread[j] < added:  # too few changes to test
            pvalues[j] = np.nan
            continue
        F = (rss_restricted - rss_full) / added / (rss_full / dof)
        pvalues[j] = scipy.special.fdtrc(added, dof, F)  # F survival function
    return pvalues


def _spread(u: np.ndarray) -> np.ndarray:
    """Per input, over how many samples its changes ``du = u[k] - u[k-1]`` are spread.

    ``(sum du^2)^2 / sum du^4``: about N / 3 for Gaussian noise, the number of switches
    for a binary signal. The F-test needs the input's changes spread over at least as
    many samples as it tests columns: its statistic otherwise hangs on a few samples (an
    input that switched twice in a short open-loop record gave p = 1e-150).
    """
    squares = np.diff(u, axis=0) ** 2
    fourth = np.sum(squares**2, axis=0)
    return np.sum(squares, axis=0) ** 2 / np.where(fourth > 0, fourth, np.inf)
