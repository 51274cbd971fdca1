"""The one-call entry point: structure search, filter tuning, estimation, order rule."""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from .data import IOData
from .errors import DataError, OptionError
from .estimation import check_sample_count
from .model import StateSpaceModel
from .selection import PathStep, StructureSearch, greedy_path, select_order
from .tuning import TUNING_METHODS, check_omega, default_omega
from .validation import X0_CHOICES

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
        head = f"{'n':>3}  {'indices':<16}{'J':>8}  " + "".join(f"{'VAF ' + nm:>11}" for nm in names)
        head += f"{'mean VAF':>10}{'wc':>9}{'zeta':>7}{'stable':>8}{'sec':>8}"
        lines = [
            f"moli identification: {self.estimation.p} outputs, {self.estimation.m} inputs, "
            f"Ts = {self.estimation.Ts:g}",
            f"estimation: {self.estimation.N} samples; validation: {self.validation.N} samples "
            f"({self.validation_source})",
            f"VAF: validation, simulation from {self.options['x0']} initial state, percent",
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
        return "\n".join(lines)


def _default_nmax(p: int) -> int:
    return max(10, p + 4)


def identify(
    data: IOData,
    validation: IOData | None = None,
    *,
    nmax: int | None = None,
    omega: object | None = None,
    seed: int = 0,
    tuning: str = "random",
    iterations: int = 5,
    s: float = 2.0,
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
    tuning : {"random", "grid"}
        Filter search: the paper's randomized barycenter or one grid barycenter.
    iterations : int, default 5
        Steps of the randomized filter search.
    s : float, default 2.0
        Root spacing factor of the filter polynomial.
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
    """
    if unknown:
        raise OptionError(
            f"unknown option(s) {sorted(unknown)}; identify accepts nmax, omega, seed, tuning, "
            "iterations, s, center, x0, order_tolerance, progress"
        )
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    if tuning not in TUNING_METHODS:
        raise OptionError(f"tuning must be one of {TUNING_METHODS}, got {tuning!r}")
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
    search = StructureSearch(estimation, validation, grid, tuning, iterations, s, int(seed), x0)
    check_sample_count(estimation.N, (1,) * p, estimation.m)
    options = {"nmax": int(nmax), "omega": grid.tolist(), "seed": int(seed), "tuning": tuning,
               "iterations": iterations, "s": s, "center": center, "x0": x0,
               "order_tolerance": order_tolerance}
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
    chosen = select_order(path, order_tolerance)
    model = path[chosen].model
    model.warn_if_unstable(stacklevel=2)
    return IdentificationResult(
        model=model, path=path, selected_index=chosen, estimation=estimation,
        validation=validation, validation_source=source, options=options,
        seconds=time.perf_counter() - start, interrupted=interrupted,
    )
