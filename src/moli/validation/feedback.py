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

3. A controller whose output carries no added noise makes each input an exact linear
   function of the outputs and its own past wherever its references hold still. In
   windows of the record a little longer than that regression has columns, each input
   is fitted on an intercept, ``u[k-1..k-L]`` and ``y[k..k-L]``: where the outputs
   reproduce what the input's own past leaves to 1e-5 in more than one window, the
   input is a controller's output (docs/diagnostics.md §4). The F-test cannot see such
   a loop where set-point steps crowd the input's changes onto a few samples.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.special

from ..data.iodata import IOData, require_one_segment
from ..errors import ClosedLoopWarning, DataError
from ..numerics.blas_threads import limited_blas

__all__ = ["FeedbackCheck", "feedback_check", "DEFAULT_LAGS"]

DEFAULT_LAGS = 10
# The full regression keeps at least this many residual degrees of freedom per column.
ROWS_PER_COLUMN = 3
# The exactness test (step 3). An exact fit is evidence only where the window has more
# distinct rows than its regression has independent columns: SURPLUS_ROWS more. Outputs
# that carry noise meet all of them to EXACT_SHARE with a chance of order
# EXACT_SHARE ** SURPLUS_ROWS; a controller's output computed in double precision is met
# to about 1e-14, and one logged with 6 significant digits to about 1e-6.
SURPLUS_ROWS = 10
# "Exact": the outputs leave at most this share of the rms that the input's own past
# leaves in the window (the share measurement noise 100 dB below the input would leave).
EXACT_SHARE = 1e-5
# Windows that must fit exactly: a relation that holds in two stretches of the record,
# not one stretch of odd data.
EXACT_WINDOWS = 2


@dataclass(frozen=True)
class FeedbackCheck:
    """Outcome of :func:`feedback_check`.

    Attributes
    ----------
    detected : bool
        True when some input's p-value is below ``level / m`` (Bonferroni: ``level``
        bounds the chance of a false alarm on open-loop data, whatever ``m``), or the
        outputs reproduce some input exactly (``exact``).
    pvalues : ndarray, shape (m,)
        Per input, the p-value of "the output innovations do not help predict this
        input"; NaN where the input changes too rarely to test (its innovation is
        spread over fewer samples than the test has columns, e.g. a binary signal that
        switches a few times in the record): the test cannot tell.
    lags : int
        Past samples of every channel in the regressions.
    level : float
        Family-wise false-alarm level.
    input_names : tuple of str
    lag_zero : bool
        Whether the current output innovations were tested too.
    exact : tuple of str
        Inputs that the outputs and the inputs' past reproduce exactly in at least two
        windows of the record: the output of a controller that adds no noise of its own.
    untested : tuple of (str, str)
        Per input with a NaN p-value, its name and why the F-test cannot tell.
    """

    detected: bool
    pvalues: np.ndarray
    lags: int
    level: float
    input_names: tuple[str, ...]
    lag_zero: bool = True
    exact: tuple[str, ...] = ()
    untested: tuple[tuple[str, str], ...] = ()

    @property
    def flagged(self) -> tuple[str, ...]:
        """Names of the inputs whose p-value is below ``level / m`` or that the outputs reproduce exactly."""
        bound = self.level / len(self.pvalues)
        return tuple(name for name, pv in zip(self.input_names, self.pvalues) if pv < bound or name in self.exact)

    @property
    def undecided(self) -> tuple[str, ...]:
        """Names of the inputs the check cannot tell about: untested by the F-test, not reproduced exactly."""
        return tuple(name for name, pv in zip(self.input_names, self.pvalues)
                     if np.isnan(pv) and name not in self.exact)

    def summary(self) -> str:
        """One line: the verdict and the p-values that decide it."""
        values = ", ".join(f"{name} p = {pv:.2g}" if np.isfinite(pv) else f"{name} untested (too few changes)"
                           for name, pv in zip(self.input_names, self.pvalues))
        if self.detected:
            noise = [name for name in self.flagged if name not in self.exact]
            found = ([f"the outputs reproduce {', '.join(self.exact)} exactly (a controller's output)"]
                     if self.exact else []) + ([f"the output noise reaches {', '.join(noise)}"] if noise else [])
            verdict = "feedback detected: " + "; ".join(found)
        elif self.undecided:
            verdict = f"no feedback detected, but cannot tell for {', '.join(self.undecided)}"
        else:
            verdict = "no feedback detected"
        return (f"{verdict} ({values}; lags {0 if self.lag_zero else 1}-{self.lags}, level {self.level:g} "
                f"over {len(self.pvalues)} input{'s' if len(self.pvalues) > 1 else ''})")

    def cannot_tell(self) -> str | None:
        """Why the check cannot tell for the :attr:`undecided` inputs (None where it can tell for every input)."""
        if not self.undecided:
            return None
        one = len(self.undecided) == 1
        reasons = [f"{name}: {why}" for name, why in self.untested if name in self.undecided]
        return (f"the feedback check cannot tell whether {', '.join(self.undecided)} depend{'s' if one else ''} on "
                f"the outputs: {'; '.join(reasons)}; and the outputs do not reproduce {'it' if one else 'them'} "
                f"exactly. {'It counts' if one else 'They count'} as open-loop: if the record is closed-loop, "
                "name its set-points with reference=[...] or identify with closed_loop='direct'")


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

    Each input is also fitted, in windows of the record, on an intercept, the inputs'
    past and the outputs (lags 0 or 1 to ``lags``): an input that the outputs
    reproduce exactly in two windows is a controller's output (``exact``), detected
    whatever the F-test says.

    Returns
    -------
    FeedbackCheck

    Warns
    -----
    ClosedLoopWarning
        Where the check cannot tell for some input (a NaN p-value and no exact fit),
        naming it and why.

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
    >>> for k in range(2000):              # no reference: u made of y alone
    ...     y[k] = x + v[k]
    ...     u[k] = -0.5 * y[k]
    ...     x = 0.9 * x + 0.5 * u[k]
    >>> moli.feedback_check(moli.IOData(y, u)).exact
    ('u1',)
    """
    with limited_blas():
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
        check = checked_feedback(data, L, float(level), lag_zero)
        if (why := check.cannot_tell()) is not None:
            warnings.warn(why, ClosedLoopWarning, stacklevel=2)
        return check


def checked_feedback(data: IOData, lags: int, level: float, lag_zero: bool) -> FeedbackCheck:
    """:func:`feedback_check` with its arguments checked and no warning: the caller says
    what the check could not tell (:meth:`FeedbackCheck.cannot_tell`)."""
    pvalues, untested = _pvalues(data, lags, lag_zero)
    exact = tuple(name for name, windows in zip(data.input_names, _exact_windows(data, lags, lag_zero))
                  if windows >= EXACT_WINDOWS)
    return FeedbackCheck(bool(np.any(pvalues < level / data.m)) or bool(exact), pvalues, lags, level,
                         data.input_names, lag_zero, exact, untested)


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


def _pvalues(data: IOData, L: int, lag_zero: bool) -> tuple[np.ndarray, tuple[tuple[str, str], ...]]:
    """Per input, the F-test p-value of the output innovations, from one QR shared by all inputs;
    and, per input left untested (NaN), why."""
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
    pvalues, untested = np.ones(m), []
    for j in range(m):
        column = R[:, full + j]
        rss_full = float(column[full:] @ column[full:])
        rss_restricted = float(column[restricted:] @ column[restricted:])
        # an input its own past predicts exactly (a constant, a sine) is not driven
        # by anything else, feedback included: p = 1
        if not rss_restricted > 0:
            continue
        # the output innovations explain all the rest of it: the strongest evidence there is
        if not rss_full > 1e-12 * rss_restricted:
            pvalues[j] = 0.0
            continue
        if spread[j] < added:  # too few changes to test
            pvalues[j] = np.nan
            untested.append((data.input_names[j], f"its changes are spread over {spread[j]:.0f} samples, fewer "
                             f"than the {added} columns the F-test adds (set-point steps or rare switches)"))
            continue
        F = (rss_restricted - rss_full) / added / (rss_full / dof)
        pvalues[j] = scipy.special.fdtrc(added, dof, F)  # F survival function
    return pvalues, tuple(untested)


def _exact_windows(data: IOData, L: int, lag_zero: bool) -> np.ndarray:
    """Per input, in how many windows the outputs reproduce it exactly (step 3 of the module's text).

    Windows of :data:`SURPLUS_ROWS` rows more than the regression has columns, side by side;
    a window counts where it has SURPLUS_ROWS more distinct rows than independent columns
    (a stretch of held values repeats one row, a periodic record its periods' rows), the input's own
    past leaves something of it,
    and the outputs leave at most :data:`EXACT_SHARE` of that.
    """
    own = np.column_stack([np.ones(data.N - L), *_lagged(data.u, range(1, L + 1), L)])
    full = np.column_stack([own, *_lagged(data.y, range(0 if lag_zero else 1, L + 1), L)])
    norms = np.linalg.norm(full, axis=0)
    full = full / np.where(norms > 0, norms, 1.0)           # columns of one scale: a rank that means something
    own = full[:, :own.shape[1]]
    targets = data.u[L:]
    width = full.shape[1] + SURPLUS_ROWS
    counts = np.zeros(data.m, dtype=int)
    for start in range(0, targets.shape[0] - width + 1, width):
        rows = slice(start, start + width)
        X, t = full[rows], targets[rows]
        coefficients, _, rank, _ = np.linalg.lstsq(X, t, rcond=None)
        left = np.linalg.norm(t - X @ coefficients, axis=0)
        about_mean = np.linalg.norm(t - t.mean(axis=0), axis=0)
        # the input's own past with the intercept leaves at most its distance from its mean, so an
        # input the outputs leave more than EXACT_SHARE of that is not reproduced (twice the share:
        # the two sums' round-off); most windows of an open-loop record end here, before the dear tests
        if np.all(left > 2.0 * EXACT_SHARE * about_mean):
            continue
        left_own = np.linalg.norm(t - own[rows] @ np.linalg.lstsq(own[rows], t, rcond=None)[0], axis=0)
        exact = (left_own > EXACT_SHARE * about_mean) & (left <= EXACT_SHARE * left_own)
        if not exact.any():
            continue
        # rows seen before prove nothing new (held values, a periodic record's periods), nor do rows
        # apart by less than what an exact fit leaves (a noise-free periodic record's decaying start)
        grain = EXACT_SHARE * np.max(np.abs(X), axis=0)
        distinct = np.unique(np.round(X / np.where(grain > 0, grain, 1.0)), axis=0).shape[0]
        if distinct - rank >= SURPLUS_ROWS:
            counts += exact
    return counts


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
