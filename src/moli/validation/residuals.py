"""Residual analysis: whiteness of the prediction errors and their independence of the inputs.

The residuals are the one-step prediction errors of a model with a noise model, else
its simulation errors (docs/noise_model.md §4). A model that has captured the data
leaves residuals that are white (nothing left to predict from past outputs) and
uncorrelated with past inputs (nothing left to explain by the inputs). The tests start
where the estimated initial state's response has fallen to the noise level: before
that, a small error in a slow mode, multiplied by a large start-up state, would be
tested instead of the model's response to the inputs and the noise.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..data.display import figure_label, report_name
from ..data.iodata import IOData, require_one_segment
from ..errors import DataError, OptionError
from ..models.protocol import LinearModel, check_model
from .prediction import X0_CHOICES, deviations, horizon_value, predicted_deviations
from .whitening import fit_ar
from ..numerics.blas_threads import limited_blas

__all__ = ["ResidualAnalysis", "residual_analysis"]

# Samples per lag needed: the correlation estimates at lag L use N - L products, and the
# portmanteau statistics are poor approximations when L approaches N / 4.
SAMPLES_PER_LAG = 4
# Rows per unknown of the inputs' prewhitening AR models, which bounds their order.
ROWS_PER_PARAMETER = 10
# The tests start after the last sample at which the estimated initial state's response exceeds
# this many noise levels (each output's residual scale): a model whose free response is off by
# a share d then leaves at most d noise levels of start-up error in the tested samples.
INITIAL_RESPONSE_LEVELS = 1.0
# The median absolute deviation of normal noise times this is its standard deviation; the median
# is not moved by the start-up samples the scale is meant to judge.
MAD_TO_STD = 1.482602218505602
# An input's name in the figure's column title, beside its p-value: "vs <name>: p = 0.0038"
# at 8 points fits a 2.6-inch panel.
INPUT_TITLE_CHARS = 28


def _correlations(a: np.ndarray, b: np.ndarray, lags: int) -> np.ndarray:
    """``c[i, j, lags + τ] = sum_t a[t, i] b[t - τ, j] / N`` for ``τ = -lags..lags`` (by FFT)."""
    N = a.shape[0]
    size = 1 << int(np.ceil(np.log2(N + lags)))  # zero padding: no wrap-around within the lags
    spectrum = np.fft.rfft(a, size, axis=0)[:, :, None] * np.conj(np.fft.rfft(b, size, axis=0))[:, None, :]
    circular = np.fft.irfft(spectrum, size, axis=0)
    return np.concatenate([circular[size - lags :], circular[: lags + 1]]).transpose(1, 2, 0) / N


@dataclass(frozen=True)
class ResidualAnalysis:
    """Correlation tests of a model's residuals on one record.

    A test rejects (the model misses something) when its p-value is below
    ``1 - confidence``.

    Attributes
    ----------
    residuals : ndarray, shape (N, p)
        Prediction errors (``horizon`` steps ahead) or simulation errors, every sample.
    first_tested : int
        The first sample the correlations and tests use: samples ``first_tested..N-1``
        are tested. The earlier ones carry the estimated initial state's response above
        the noise level (docs/noise_model.md §4); 0 with ``x0="zero"`` or a response
        below it from the start.
    horizon : int or None
        Prediction horizon of the residuals; None: simulation errors.
    lags : int
        Largest lag tested.
    confidence : float
        Confidence level of the bounds and verdicts.
    autocorrelation : ndarray, shape (p, lags + 1)
        Normalized autocorrelation of each output's residual, lags ``0..lags``.
    cross_correlation : ndarray, shape (p, m, 2 lags + 1)
        Normalized correlation of residual ``i`` at ``t`` with input ``j`` at ``t - τ``,
        ``τ = -lags..lags`` (entry ``lags + τ``); positive lags: past inputs.
    whiteness_bound : float
        ``z / sqrt(N - first_tested)``: the autocorrelation band at this confidence for white residuals.
    cross_bound : ndarray, shape (p, m)
        Band of each cross-correlation under independence, widened for the colour of
        the input and of the residual.
    whiteness_pvalue : ndarray, shape (p,)
        Ljung-Box test over lags ``1..lags`` (chi-square, ``lags`` degrees of freedom).
    independence_pvalue : ndarray, shape (p, m)
        Chi-square test of the correlations at lags ``0..lags`` with the prewhitened
        input (``lags + 1`` degrees of freedom); NaN for a constant input.
    verdicts : tuple of str
        One line per output.
    output_names, input_names : tuple of str
    """

    residuals: np.ndarray = field(repr=False)
    first_tested: int
    horizon: int | None
    lags: int
    confidence: float
    autocorrelation: np.ndarray = field(repr=False)
    cross_correlation: np.ndarray = field(repr=False)
    whiteness_bound: float
    cross_bound: np.ndarray = field(repr=False)
    whiteness_pvalue: np.ndarray
    independence_pvalue: np.ndarray
    verdicts: tuple[str, ...]
    output_names: tuple[str, ...]
    input_names: tuple[str, ...]

    @property
    def tests(self) -> int:
        """The tests the verdicts rest on: each output's whiteness and each (output, input) pair's
        independence (a constant input's pair is not tested)."""
        return int(np.count_nonzero(np.isfinite(self.whiteness_pvalue))
                   + np.count_nonzero(np.isfinite(self.independence_pvalue)))

    @property
    def false_alarm_rate(self) -> float:
        """Chance that a correct model fails at least one of the :attr:`tests`: ``1 - confidence**tests``.

        Each test fails a correct model with probability ``1 - confidence``; over a 3x3 model's
        twelve tests at 99 % that is 11 % of records (the tests taken as independent). A
        single failed test is then weak evidence on its own: the example plant itself fails one
        on about a tenth of the records of ``moli.example_data`` (benchmarks/demo_residuals.py).
        """
        return float(1.0 - self.confidence ** self.tests)

    @property
    def tested_samples(self) -> str:
        """Which samples the tests use, as a phrase: ``"samples 37-999 of 1000 (the first 37
        skipped: the initial state's response was above the noise level)"``."""
        N = self.residuals.shape[0]
        skipped = ("" if self.first_tested == 0 else
                   f" (the first {self.first_tested} skipped: the initial state's response was "
                   "above the noise level)")
        return f"samples {self.first_tested}-{N - 1} of {N}{skipped}"

    def plot(self) -> Any:  # -> matplotlib.figure.Figure
        """The correlations with their bands, one row per output (like the toolbox's ``resid``).

        Column 1: the residual's autocorrelation; then one column per input: the
        cross-correlation at lags ``-lags..lags``. The outputs name the rows and the inputs
        the columns; each panel's title is its test's p-value. Needs matplotlib.

        Returns
        -------
        matplotlib.figure.Figure
            Not registered with pyplot (drawn on the Agg canvas).
        """
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        p, m = len(self.output_names), len(self.input_names)
        fig = Figure(figsize=(2.6 * (m + 1) + 0.4, 1.9 * p + 0.6), layout="constrained")
        FigureCanvasAgg(fig)
        # one lag range per column: its tick labels once, under the bottom row
        axes = fig.subplots(p, m + 1, sharex="col", squeeze=False)
        kind = "simulation errors" if self.horizon is None else f"{self.horizon}-step prediction errors"
        N = self.residuals.shape[0]
        fig.suptitle(f"residual analysis ({kind}, samples {self.first_tested}-{N - 1}), "
                     f"{self.confidence:.0%} bands", fontsize=10)
        own = np.arange(self.lags + 1)
        both = np.arange(-self.lags, self.lags + 1)
        # the channels' names once each, as a channel grid has them: the outputs' on the rows,
        # the inputs' over the top row (cut shorter than elsewhere, to share a panel's width
        # with the p-value); a name in every panel's title ran into the next panel's with plant
        # tags of 20-30 characters
        inputs = [figure_label(u, INPUT_TITLE_CHARS) for u in self.input_names]
        for i, name in enumerate(map(figure_label, self.output_names)):
            axes[i, 0].set_ylabel(name)
            panels = [(axes[i, 0], own, self.autocorrelation[i], self.whiteness_bound,
                       f"whiteness p = {self.whiteness_pvalue[i]:.2g}")]
            headings = [f"vs {u}: " if i == 0 else "" for u in inputs]
            panels += [(axes[i, j + 1], both, self.cross_correlation[i, j], self.cross_bound[i, j],
                        f"{heading}p = {self.independence_pvalue[i, j]:.2g}") for j, heading in enumerate(headings)]
            for ax, lag, values, bound, title in panels:
                ax.axhspan(-bound, bound, color="C0", alpha=0.15, linewidth=0)
                ax.vlines(lag, 0.0, values, color="C0", linewidth=1.2)
                ax.plot(lag, values, ".", color="C0", markersize=3)
                ax.axhline(0.0, color="0.5", linewidth=0.8)
                ax.set_title(title, fontsize=8)
                ax.grid(alpha=0.3)
                if i == p - 1:
                    ax.set_xlabel("lag (samples)")
        return fig


def _verdict(name: str, white_p: float, independence_p: np.ndarray, inputs: tuple[str, ...], level: float) -> str:
    name, inputs = report_name(name), tuple(map(report_name, inputs))  # a sentence, not the names' record
    if np.isnan(white_p):
        return f"{name}: residuals constant (an exact fit): not tested"
    white = f"white (Ljung-Box p = {white_p:.2g})" if white_p >= level else \
        f"NOT white (Ljung-Box p = {white_p:.2g}): dynamics left unmodelled"
    tested = ~np.isnan(independence_p)
    if not tested.any():
        return f"{name}: residuals {white}; independence not tested (constant inputs)"
    worst = int(np.nanargmin(independence_p))
    bad = [u for u, q, ok in zip(inputs, independence_p, tested) if ok and q < level]
    independent = (f"correlated with past {', '.join(bad)} (smallest p = {independence_p[worst]:.2g}): "
                   "input dynamics left unmodelled" if bad else
                   f"independent of the inputs (smallest p = {independence_p[worst]:.2g}, {inputs[worst]})")
    return f"{name}: residuals {white}; {independent}"


def residual_analysis(
    model: LinearModel,
    data: IOData,
    lags: int = 25,
    confidence: float = 0.99,
    horizon: int | None = 1,
    x0: str = "estimate",
) -> ResidualAnalysis:
    """Test whether ``model``'s residuals on ``data`` are white and independent of the inputs.

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel
        A continuous model is simulated on the record's stamps (it has no noise model).
    data : IOData
        Preferably a record the model was not estimated on.
    lags : int, default 25
        Largest lag tested; ``data`` needs at least ``4 (lags + 1)`` samples.
    confidence : float, default 0.99
        Level of the bands; a test rejects when its p-value is below ``1 - confidence``.
    horizon : int or None, default 1
        Residuals are the ``horizon``-step prediction errors when the model has a noise
        model (``model.K``); without one, or with ``horizon=None``, the simulation errors.
    x0 : {"estimate", "zero"}, default "estimate"
        Initial state of the predictor (or simulation), as in :func:`moli.predict`.
        With ``"estimate"``, the tests skip the leading samples where this state's
        response exceeds the residuals' noise level (:attr:`ResidualAnalysis.first_tested`),
        leaving at least ``4 (lags + 1)`` samples tested.

    Returns
    -------
    ResidualAnalysis

    Raises
    ------
    OptionError
        ``lags``, ``confidence``, ``horizon`` or ``x0`` invalid.
    DataError
        ``data`` does not match the model or is too short for ``lags``.

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(1000)
    >>> m = moli.StateSpaceModel([[0.8]], [[1.0]], [[1.0]])
    >>> data = moli.IOData(m.simulate(u) + 0.1 * rng.standard_normal((1000, 1)), u)
    >>> result = residual_analysis(m, data)
    >>> result.verdicts[0].startswith("y1: residuals white")
    True
    >>> low = moli.StateSpaceModel([[0.0]], [[1.0]], [[1.0]])  # misses the pole
    >>> bool(residual_analysis(low, data).independence_pvalue[0, 0] < 0.01)
    True
    """
    with limited_blas():
        if isinstance(lags, bool) or not hasattr(lags, "__index__") or int(lags) < 1:  # type: ignore[call-overload]
            raise OptionError(f"lags must be an integer >= 1, got {lags!r}")
        lags = int(lags)  # type: ignore[call-overload]
        if isinstance(confidence, bool) or not isinstance(confidence, (int, float)) or not 0.0 < confidence < 1.0:
            raise OptionError(f"confidence must be a number in (0, 1), got {confidence!r}")
        if not isinstance(x0, str) or x0 not in X0_CHOICES:
            raise OptionError(f"x0 must be one of {X0_CHOICES}, got {x0!r}")
        check_model(model)
        k = horizon_value(horizon)  # checked even when unused
        if isinstance(data, IOData):
            require_one_segment(data, "residual_analysis (correlations over lags)")
        if model.K is None:
            k = None  # no predictor: the simulation errors
        u, y = deviations(model, data)
        N = y.shape[0]
        if N < SAMPLES_PER_LAG * (lags + 1):
            raise DataError(f"data must have at least {SAMPLES_PER_LAG * (lags + 1)} samples for "
                            f"lags={lags}, got {N}; lower lags")
        from scipy.special import chdtrc, ndtri  # slow to import: only when testing

        stamps = data.time()
        yhat, _ = predicted_deviations(model, u, y, k, x0, stamps)
        residuals = y - yhat
        # the predictions are affine in the initial state: its response is what the zero state lacks
        start_response = yhat - predicted_deviations(model, u, y, k, "zero", stamps)[0] if x0 == "estimate" else None
        first = _first_tested(residuals, start_response, N - SAMPLES_PER_LAG * (lags + 1))
        tested, u_tested = residuals[first:], u[first:]
        N = tested.shape[0]
        z = float(ndtri(0.5 + 0.5 * confidence))
        e = tested - tested.mean(axis=0)
        uc = u_tested - u_tested.mean(axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            # constant signals give NaN correlations, reported as untested
            e_scaled, u_scaled = e / e.std(axis=0), uc / uc.std(axis=0)
            auto_e = np.einsum("iil->il", _correlations(e_scaled, e_scaled, lags))[:, lags:]
            auto_u = np.einsum("jjl->jl", _correlations(u_scaled, u_scaled, lags))[:, lags:]
            cross = _correlations(e_scaled, u_scaled, lags)
            steps = np.arange(1, lags + 1)
            ljung_box = N * (N + 2) * np.sum(auto_e[:, 1:] ** 2 / (N - steps), axis=1)
            whiteness = chdtrc(lags, ljung_box)
            # var(r_eu) ~ sum_k r_e(k) r_u(k) / N; the Bartlett taper keeps the truncated sum >= 0
            taper = 1.0 - steps / (lags + 1.0)
            spread = 1.0 + 2.0 * np.einsum("il,jl,l->ij", auto_e[:, 1:], auto_u[:, 1:], taper)
            cross_bound = z * np.sqrt(spread / N)
            independence = _independence(e, uc, auto_e, lags)
        level = 1.0 - confidence
        verdicts = tuple(_verdict(name, whiteness[i], independence[i], data.input_names, level)
                         for i, name in enumerate(data.output_names))
        return ResidualAnalysis(
            residuals=residuals, first_tested=first, horizon=k, lags=lags, confidence=float(confidence),
            autocorrelation=auto_e, cross_correlation=cross, whiteness_bound=z / np.sqrt(N),
            cross_bound=cross_bound, whiteness_pvalue=whiteness, independence_pvalue=independence,
            verdicts=verdicts, output_names=data.output_names, input_names=data.input_names,
        )


def _first_tested(residuals: np.ndarray, start_response: np.ndarray | None, last: int) -> int:
    """The first sample after every one where the initial state's response exceeds
    :data:`INITIAL_RESPONSE_LEVELS` times its output's noise level, at most ``last``.

    The noise level is each output's residual scale from the median absolute deviation, which
    the few start-up samples cannot inflate. An output with constant residuals (an exact fit)
    has no noise level and skips nothing.
    """
    if start_response is None:
        return 0
    centred = residuals - np.median(residuals, axis=0)
    level = MAD_TO_STD * np.median(np.abs(centred), axis=0)
    noisy = level > 0.0
    above = np.flatnonzero(np.any(np.abs(start_response[:, noisy]) > INITIAL_RESPONSE_LEVELS * level[noisy], axis=1))
    return min(int(above[-1]) + 1, last) if above.size else 0


def _independence(e: np.ndarray, u: np.ndarray, auto_e: np.ndarray, lags: int) -> np.ndarray:
    """p-values of ``N r^T T^-1 r ~ chi2(lags + 1)``, ``r`` the correlations of ``e`` with past whitened inputs.

    Each input is whitened by its own AR model, so that under independence the
    correlations at lags ``0..lags`` have covariance ``T / N``, ``T`` the Toeplitz
    matrix of the residual's autocorrelation (the residual need not be white).
    """
    from scipy.special import chdtrc  # slow to import: only when testing

    N, p = e.shape
    m = u.shape[1]
    order = max(min(lags, (N - ROWS_PER_PARAMETER) // (ROWS_PER_PARAMETER + 1)), 0)
    out = np.full((p, m), np.nan)
    for j in range(m):
        if not np.std(u[:, j]) > 0.0:
            continue
        white = fit_ar(u[:, j : j + 1], order)
        v = white.residuals / np.std(white.residuals)
        tail = e[white.start :]
        r = _correlations(tail / tail.std(axis=0), v, lags)[:, 0, lags:]   # (p, lags + 1)
        rows = N - white.start
        gaps = np.abs(np.subtract.outer(np.arange(lags + 1), np.arange(lags + 1)))
        for i in np.flatnonzero(np.isfinite(auto_e[:, 0])):  # constant residuals: untested
            T = auto_e[i][gaps]  # Toeplitz: T[a, b] = r(|a - b|)
            solved = np.linalg.lstsq(T, r[i], rcond=None)[0]
            out[i, j] = chdtrc(lags + 1, rows * float(r[i] @ solved))
    return out
