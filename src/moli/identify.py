"""The one-call entry point: structure search, filter tuning, estimation, order rule."""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace
from typing import Any, Callable

import numpy as np

from .data import IOData
from .errors import DataError, OptionError
from .estimation import check_sample_count
from .model import StateSpaceModel
from .selection import PathStep, StructureSearch, greedy_path, select_order
from .tuning import (
    FEEDTHROUGH_CHOICES, TUNING_METHODS, check_omega, check_trend_degree, default_omega,
)
from .refine import MAX_RADIUS
from .refine import refine as refine_model
from .validation import X0_CHOICES, compare

# Share of the record held out for the order rule when no validation data are given.
HOLDOUT_FRACTION = 0.3


@dataclass
class IdentificationResult:
    """What :func:`identify` found.

    Attributes
    ----------
    model : StateSpaceModel
        The selected model (acts on deviations from ``model.u_offset``/``y_offset``).
    path : list of PathStep
        One record per order along the greedy path.
    selected_index : int
        Position of the selected model in ``path``.
    estimation, validation : IOData
        The centred records used.
    validation_source : str
        Where the validation data came from (given, or held out from the tail).
    options : dict
        The options the search ran with.
    seconds : float
        Total wall time.
    interrupted : bool
        True when the search was stopped by Ctrl-C; the path holds what was done.
    """

    model: StateSpaceModel
    path: list[PathStep]
    selected_index: int
    estimation: IOData = field(repr=False)
    validation: IOData = field(repr=False)
    validation_source: str
    options: dict[str, Any]
    seconds: float
    interrupted: bool = False

    @property
    def selected(self) -> PathStep:
        """The path step of the selected model."""
        return self.path[self.selected_index]

    def summary(self) -> str:
        """A readable table of the greedy path and the selection."""
        names = self.estimation.output_names
        # long channel names (e.g. DaISy's) would break the columns: number them and list them
        head = f"{'n':>3}  {'indices':<16}{'J':>8}  " + "".join(f"{f'VAF y{i + 1}':>11}" for i in range(len(names)))
        head += f"{'mean VAF':>10}{'wc':>9}{'zeta':>7}{'stable':>8}{'sec':>8}"
        lines = [
            f"moli identification: {self.estimation.p} outputs, {self.estimation.m} inputs, "
            f"Ts = {self.estimation.Ts:g}",
            f"estimation: {self.estimation.N} samples; validation: {self.validation.N} samples "
            f"({self.validation_source})",
            f"VAF: validation, simulation from {self.options['x0']} initial state, percent"
            + "".join(f"; y{i + 1} = {nm}" for i, nm in enumerate(names) if nm != f"y{i + 1}"),
            f"options: preset {self.options.get('preset', 'paper')}, tuning "
            f"{self.options['tuning']}, s = {self.options['s']:g}, feedthrough "
            f"{self.options.get('feedthrough', False)}, max pole radius "
            f"{self.options.get('max_radius') or 'none'}, J trend degree "
            f"{self.options.get('trend_degree', 0)}, per-output filters "
            f"{self.options.get('output_filters', False)}, refinement "
            f"{self.options.get('refine', 'none')}",
            head,
        ]
        for i, st in enumerate(self.path):
            mark = "  <- selected" if i == self.selected_index else ""
            lines.append(
                f"{st.order:>3}  {str(list(st.indices)):<16}{st.J:>8.4f}  "
                + "".join(f"{v:>11.2f}" for v in st.vaf)
                + f"{st.mean_vaf:>10.2f}{st.eta[0]:>9.4g}{st.eta[1]:>7.3f}{str(st.stable):>8}"
                + f"{st.seconds:>8.3f}{mark}"
            )
        lines.append(
            f"selected: indices {list(self.selected.indices)} (n = {self.selected.order}), "
            f"lowest order within {self.options['order_tolerance']:g} point of the best mean "
            f"validation VAF; total {self.seconds:.2f} s"
            + (" (interrupted: partial path)" if self.interrupted else "")
        )
        if self.selected.output_etas is not None:
            lines.append("its filters per output (wc, zeta): " + ", ".join(
                f"y{j + 1} ({wc:.4g}, {zeta:.3g})" for j, (wc, zeta) in enumerate(self.selected.output_etas)
            ))
        return "\n".join(lines)


def _default_nmax(p: int) -> int:
    return max(10, p + 4)


PRESETS: dict[str, dict[str, Any]] = {
    # default: grid barycenter, per-output feedthrough where the estimation data call
    # for it, J blind to a quadratic drift of the error (chosen on the 11 evaporator
    # windows, docs/benchmarks.md), and unstable candidates scored worst: a slightly
    # unstable model can fit a finite record well and still diverge on the next one
    "improved": {"tuning": "grid", "s": 2.0, "feedthrough": "auto", "max_radius": 1.0,
                 "criterion_x0": "zero", "trend_degree": 2, "output_filters": True,
                 "refine": False},
    # filter candidates with modes slower than a tenth of the estimation record ruled
    # out, and wider root spacing: for plants known to be that fast (with the bound,
    # the trend-blind J measured worse on the evaporator windows)
    "bounded": {"tuning": "grid", "s": 3.0, "feedthrough": "auto", "max_radius": "auto",
                "criterion_x0": "zero", "trend_degree": 0, "output_filters": False,
                "refine": False},
    # the paper's MOLI-ZOFT: randomized barycenter, s = 2, no feedthrough, J alone
    "paper": {"tuning": "random", "s": 2.0, "feedthrough": False, "max_radius": None,
              "criterion_x0": "zero", "trend_degree": 0, "output_filters": False,
              "refine": False},
}
REFINE_CHOICES = ("none", "selected", "path")
# "auto" stability bound: a mode whose time constant exceeds a tenth of the estimation
# record (radius exp(-10/N)) cannot be told from drift in that record.
AUTO_RADIUS_SPAN = 10.0


def _resolve(preset: str, given: dict[str, Any]) -> dict[str, Any]:
    if preset not in PRESETS:
        raise OptionError(f"preset must be one of {tuple(PRESETS)}, got {preset!r}")
    chosen = dict(PRESETS[preset])
    chosen.update({k: v for k, v in given.items() if v is not None})
    if chosen["tuning"] not in TUNING_METHODS:
        raise OptionError(f"tuning must be one of {TUNING_METHODS}, got {chosen['tuning']!r}")
    if chosen["criterion_x0"] not in X0_CHOICES:
        raise OptionError(f"criterion_x0 must be one of {X0_CHOICES}, got {chosen['criterion_x0']!r}")
    refine_ = chosen["refine"]
    if refine_ is True:
        refine_ = "selected"
    elif refine_ is False:
        refine_ = "none"
    if refine_ not in REFINE_CHOICES:
        raise OptionError(f"refine must be True, False or one of {REFINE_CHOICES}, got {refine_!r}")
    chosen["refine"] = refine_
    radius = chosen["max_radius"]
    if radius == "none":
        chosen["max_radius"] = radius = None
    if not (radius is None or radius == "auto" or (
        isinstance(radius, (int, float)) and not isinstance(radius, bool) and 0 < radius <= 1
    )):
        raise OptionError(f"max_radius must be 'none', 'auto' or a number in (0, 1], got {radius!r}")
    chosen["trend_degree"] = check_trend_degree(chosen["trend_degree"])
    if not isinstance(chosen["output_filters"], bool):
        raise OptionError(f"output_filters must be True or False, got {chosen['output_filters']!r}")
    if not any(chosen["feedthrough"] is v or chosen["feedthrough"] == "auto" for v in (True, False)):
        raise OptionError(f"feedthrough must be one of {FEEDTHROUGH_CHOICES}, got {chosen['feedthrough']!r}")
    return chosen


def identify(
    data: IOData,
    validation: IOData | None = None,
    *,
    nmax: int | None = None,
    omega: object | None = None,
    seed: int = 0,
    preset: str = "improved",
    tuning: str | None = None,
    iterations: int = 5,
    s: float | None = None,
    feedthrough: bool | None = None,
    max_radius: float | str | None = None,
    criterion_x0: str | None = None,
    trend_degree: int | None = None,
    output_filters: bool | None = None,
    refine: bool | str | None = None,
    refine_iterations: int = 10,
    refine_ridge: float = 1.0,
    center: bool = True,
    x0: str = "zero",
    order_tolerance: float = 1.0,
    progress: Callable[[PathStep], None] | None = None,
    **unknown: Any,
) -> IdentificationResult:
    """Identify a multivariable state-space model with MOLI-ZOFT.

    Parameters
    ----------
    data : IOData
        Estimation record.
    validation : IOData, optional
        Validation record, used only by the order rule. When omitted, the last
        30 % of ``data`` is held out for it (``result.validation_source`` says so).
    nmax : int, optional
        Largest McMillan degree on the greedy path; default ``max(10, p + 4)``.
    omega : array_like, shape (R, 2), optional
        Filter candidates ``(wc, zeta)``, wc in rad per time unit of ``Ts``; default
        :func:`moli.tuning.default_omega` (the paper's grid scaled to ``Ts``).
    seed : int, default 0
        Seed of the randomized filter search.
    preset : {"improved", "bounded", "paper"}
        Defaults of the options below that are left as None. ``"improved"``: grid
        barycenter, ``s = 2``, ``feedthrough="auto"``, ``max_radius=1`` (unstable
        candidates score the worst J), ``trend_degree=2``, per-output filters, no refinement. ``"bounded"``: as improved with
        ``s = 3``, ``max_radius="auto"`` and ``trend_degree=0``, for plants whose time constants are well below a tenth
        of the estimation record (it rules out the slow, nearly unstable models that
        fit the estimation record's drift).
        ``"paper"``: the paper's MOLI-ZOFT (randomized barycenter, ``s = 2``, no
        feedthrough, the paper's J, one shared filter, no refinement).
    tuning : {"grid", "random", "zoom"}, optional
        Filter search (see :func:`moli.tuning.tune_filter`).
    iterations : int, default 5
        Steps of the randomized or zoom filter search.
    s : float, optional
        Root spacing factor of the filter polynomial.
    feedthrough : {True, False, "auto"}, optional
        Estimate a direct feedthrough ``D`` (the current inputs join the regressors).
        ``"auto"`` keeps it per output only where a nested F-test on the estimation
        data finds it significant (level 0.001); elsewhere ``D`` is exactly zero.
    max_radius : float, "auto" or "none", optional
        Filter candidates whose model has a pole of this modulus or more score the
        worst J, so neither tuning nor the path prefers them. ``"auto"``:
        ``exp(-10/N)`` for ``N`` estimation samples (time constants up to a tenth
        of the record); ``"none"``: the paper's J alone, whatever the poles (None
        leaves the preset's choice).
    criterion_x0 : {"zero", "estimate"}, optional
        Initial state of the estimation-data simulations behind J.
    trend_degree : int, optional
        J ignores the least-squares polynomial trend of this degree in each output's
        simulation error (0: only its mean, the paper's J). A slow mode that follows
        the estimation record's drift then earns nothing, so neither the filter
        search nor the path prefers it; the order rule still scores the plain
        simulation. At most 5.
    output_filters : bool, optional
        Give each path model's outputs filters of their own: each output's cutoff
        is re-tuned on J from the shared filter's damping row of ``omega``
        (:func:`moli.output_filters.tune_output_cutoffs`), kept where J drops. The
        greedy path still compares lists with the shared filter.
    refine : bool or {"none", "selected", "path"}, optional
        Output-error refinement (:func:`moli.refine.refine`) on the estimation data,
        with the initial state estimated jointly and poles kept inside
        ``max_radius`` (or ``1 - 1e-3``): of the selected model only (``True`` or
        ``"selected"``), or of every path model before the order rule (``"path"``).
    refine_iterations : int, default 10
        Most Levenberg-Marquardt steps of the refinement.
    refine_ridge : float, default 1.0
        Penalty of the refinement toward the MOLI estimate, relative to each
        parameter's curvature.
    center : bool, default True
        Remove the estimation record's means from both records (the model stores them).
    x0 : {"zero", "estimate"}
        Initial state of the validation simulations.
    order_tolerance : float, default 1.0
        Order rule: lowest order within this many points of the best mean validation VAF.
    progress : callable, optional
        Called with each :class:`PathStep` as the path grows.

    Returns
    -------
    IdentificationResult

    Examples
    --------
    >>> import moli
    >>> est, val = moli.example_data(N=600, seed=1).split(400)
    >>> result = moli.identify(est, val, nmax=6)
    >>> result.selected.order <= 6
    True
    >>> paper = moli.identify(est, val, nmax=6, preset="paper")
    >>> paper.options["feedthrough"]
    False
    """
    if unknown:
        raise OptionError(
            f"unknown option(s) {sorted(unknown)}; identify accepts nmax, omega, seed, preset, "
            "tuning, iterations, s, feedthrough, max_radius, criterion_x0, trend_degree, "
            "output_filters, refine, "
            "refine_iterations, refine_ridge, center, x0, order_tolerance, progress"
        )
    chosen = _resolve(preset, {"tuning": tuning, "s": s, "feedthrough": feedthrough,
                               "max_radius": max_radius, "criterion_x0": criterion_x0,
                               "trend_degree": trend_degree, "output_filters": output_filters,
                               "refine": refine})
    tuning, s = chosen["tuning"], float(chosen["s"])
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    if x0 not in X0_CHOICES:
        raise OptionError(f"x0 must be one of {X0_CHOICES}, got {x0!r}")
    if validation is None:
        estimation, validation = data.split(1.0 - HOLDOUT_FRACTION)
        source = f"held out: last {HOLDOUT_FRACTION:.0%} of the record"
    else:
        if not isinstance(validation, IOData):
            raise DataError(f"validation must be an IOData, got {type(validation).__name__}")
        if (validation.p, validation.m) != (data.p, data.m):
            raise DataError(
                f"validation has {validation.p} outputs and {validation.m} inputs, "
                f"data have {data.p} and {data.m}"
            )
        estimation, source = data, "given"
    if center:
        estimation = estimation.remove_means()
        validation = validation.remove_means(estimation.y_offset, estimation.u_offset)
    p = estimation.p
    nmax = _default_nmax(p) if nmax is None else nmax
    if int(nmax) != nmax or nmax < p:
        raise OptionError(f"nmax must be an integer >= p = {p}, got {nmax!r}")
    grid = default_omega(estimation.Ts) if omega is None else check_omega(omega)
    radius = chosen["max_radius"]
    if radius == "auto":
        radius = float(np.exp(-AUTO_RADIUS_SPAN / estimation.N))
    search = StructureSearch(
        estimation, validation, grid, tuning, iterations, s, int(seed), x0,
        chosen["criterion_x0"], chosen["feedthrough"], radius, chosen["trend_degree"],
        chosen["output_filters"],
    )
    check_sample_count(estimation.N, (1,) * p, estimation.m)
    options = {"nmax": int(nmax), "omega": grid.tolist(), "seed": int(seed), "preset": preset,
               "tuning": tuning, "iterations": iterations, "s": s,
               "feedthrough": chosen["feedthrough"], "max_radius": radius,
               "criterion_x0": chosen["criterion_x0"], "trend_degree": chosen["trend_degree"],
               "output_filters": chosen["output_filters"],
               "refine": chosen["refine"],
               "refine_iterations": refine_iterations, "refine_ridge": refine_ridge,
               "center": center, "x0": x0, "order_tolerance": order_tolerance}
    start = time.perf_counter()
    path: list[PathStep] = []
    interrupted = False

    def record(step: PathStep) -> None:
        path.append(step)
        if progress:
            progress(step)

    with warnings.catch_warnings():
        # unstable candidates are expected while searching; the selected model is checked below
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            greedy_path(search, int(nmax), record)
        except KeyboardInterrupt:
            if not path:
                raise
            interrupted = True
    bound = MAX_RADIUS if radius is None else min(radius, MAX_RADIUS)

    def refined(step: PathStep) -> PathStep:
        started = time.perf_counter()
        result = refine_model(step.model, estimation, iterations=refine_iterations,
                              ridge=refine_ridge, max_radius=bound)
        vaf = compare(result.model, validation, x0).vaf
        return replace(step, model=result.model, vaf=vaf,
                       seconds=step.seconds + time.perf_counter() - started)

    if chosen["refine"] == "path" and not interrupted:
        path[:] = [refined(st) for st in path]
    selected = select_order(path, order_tolerance)
    if chosen["refine"] == "selected":
        path[selected] = refined(path[selected])
    model = path[selected].model
    model.warn_if_unstable(stacklevel=2)
    return IdentificationResult(
        model=model, path=path, selected_index=selected, estimation=estimation,
        validation=validation, validation_source=source, options=options,
        seconds=time.perf_counter() - start, interrupted=interrupted,
    )
