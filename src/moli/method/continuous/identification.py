"""Continuous-time identification: ``identify(..., time="continuous")`` (docs/continuous.md)."""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from ...data.iodata import IOData
from ...errors import DataError, OptionError, OrderBoundWarning
from ...models.continuous import ContinuousModel
from ..options.identify_options import IdentifyOptions
from ..selection.checks import warn_if_no_better_than_mean
from ..selection.order_rules import select_by_shares, select_order
from .covariance import covariance_factor
from .estimation import stamped_record
from .filters import continuous_grid
from .reach import check_continuous_reach
from .search import ContinuousSearch, ContinuousStep, greedy_path

__all__ = ["ContinuousResult", "identify_continuous"]

# What the discrete pipeline adds and the continuous one does not (docs/continuous.md §7).
NOT_CARRIED = ("feedthrough", "refinement", "noise model", "per-output filters", "delays",
               "trend removal in J")
# A loss of validation VAF below this many points passes the paired rule whatever its
# standard error: the reports print VAF to two decimals, and on long records a higher
# order's extra modes buy significant but invisible thousandths of a point
# (docs/continuous.md §5 gives the seeds that chose it).
NEGLIGIBLE_VAF = 0.01
# The options of those steps (and of the discrete search): in continuous time they must
# keep their defaults, so that none is silently ignored.
DISCRETE_ONLY = ("filter_grid", "iterations", "seed", "output_filters", "feedthrough", "max_radius",
                 "criterion_x0", "trend_degree", "refine", "lower_orders", "polish_selected", "refine_iterations",
                 "refine_ridge", "x0", "noise_model", "regularization", "delays", "search_samples", "reference",
                 "closed_loop", "path_patience", "refine_siblings", "screen_generic")


@dataclass
class ContinuousResult:
    """Outcome of a continuous-time identification.

    Attributes
    ----------
    model : ContinuousModel
        The selected model, with its covariance (``cov_factor``).
    path : list of ContinuousStep
        The greedy path, one step per order.
    selected_index : int
    options : IdentifyOptions
    validation_source : str
    seconds : float
    estimation, validation : IOData
        The records as the search used them (centred on the estimation means).
    covariance_note : str or None
        Why the model carries no covariance (a rank-deficient least squares, as on
        noise-free data); None when it does.
    """

    model: ContinuousModel
    path: list[ContinuousStep] = field(repr=False)
    selected_index: int
    options: IdentifyOptions = field(repr=False)
    validation_source: str
    seconds: float
    estimation: IOData = field(repr=False)
    validation: IOData = field(repr=False)
    covariance_note: str | None = None

    @property
    def selected(self) -> ContinuousStep:
        """The selected path step."""
        return self.path[self.selected_index]

    @property
    def selection(self) -> str:
        """How the order was chosen, in words."""
        opts = self.options
        if opts.order is not None:
            return f"fixed order {opts.order}"
        if opts.order_rule in (None, "paired"):
            return (f"paired rule: the lowest order within {opts.order_errors:g} standard errors, or "
                    f"{NEGLIGIBLE_VAF:g} points, of the best")
        return f"tolerance rule: the lowest order within {opts.order_tolerance:g} points of the best VAF"

    def summary(self) -> str:
        """A few lines: path, selected structure, filter, poles and gains."""
        step, model = self.selected, self.model
        lines = [f"continuous-time MOLI: {len(self.path)} lists on the path, selected order "
                 f"{step.order}, indices {list(step.indices)} ({self.selection})",
                 f"filter wc = {step.eta[0]:.4g} rad per time unit, zeta = {step.eta[1]:.3g}; "
                 f"validation: {self.validation_source}",
                 "  order  indices        J        mean VAF"]
        for k, st in enumerate(self.path):
            mark = "*" if k == self.selected_index else " "
            lines.append(f"{mark} {st.order:5d}  {str(list(st.indices)):12s} {st.J:8.4f}  {st.mean_vaf:8.2f}")
        lines += model.pole_table()
        if self.covariance_note is not None:
            lines.append(f"no covariance, so no bands: {self.covariance_note}")
        lines.append("not in continuous time: " + ", ".join(NOT_CARRIED))
        return "\n".join(lines)


def _check(opts: IdentifyOptions) -> None:
    if opts.order_rule == "refined":
        raise OptionError("IdentifyOptions.order_rule='refined' needs the output-error refinement, which "
                          "continuous time does not have: use 'tolerance' or 'paired'")
    if opts.tuning != "grid":
        raise OptionError(f"IdentifyOptions.tuning={opts.tuning!r} is discrete only: continuous time "
                          "tunes by the grid and its barycenter ('grid')")
    defaults = IdentifyOptions()
    changed = [name for name in DISCRETE_ONLY if getattr(opts, name) != getattr(defaults, name)]
    if changed:
        raise OptionError(
            "these options do not apply in continuous time (docs/continuous.md §7): "
            + ", ".join(f"{name}={getattr(opts, name)!r}" for name in changed)
            + "; leave them at their defaults")


def identify_continuous(estimation: IOData, validation: IOData, source: str, opts: IdentifyOptions,
                        progress: Callable[[ContinuousStep], None] | None = None,
                        phase: Callable[[str], None] | None = None) -> ContinuousResult:
    """The continuous-time pipeline behind :func:`moli.identify` with ``time="continuous"``.

    Parameters
    ----------
    estimation, validation : IOData
        Records with the same channels (stamps from ``times`` or ``k * Ts``).
    source : str
        Where the validation record came from, for the result.
    opts : IdentifyOptions
    progress : callable, optional
        Called with each :class:`ContinuousStep` as the path grows.
    phase : callable, optional
        Called with "covariance" as the one phase after the path starts.

    Returns
    -------
    ContinuousResult
    """
    _check(opts)
    check_continuous_reach(opts.nmax, opts.order, estimation)
    start = time.perf_counter()
    if opts.center:
        estimation = estimation.remove_means()
        validation = validation.remove_means(estimation.y_offset, estimation.u_offset)
    fitted, scored = stamped_record(estimation), stamped_record(validation)
    p = estimation.p
    omega = continuous_grid(fitted.steps(), fitted.durations()) if opts.omega is None else np.array(opts.omega)
    end = opts.path_end(p)
    search = ContinuousSearch(fitted, scored, omega, opts.s, linear_inputs=opts.input_hold == "foh",
                              names=(estimation.output_names, estimation.input_names),
                              offsets=(estimation.y_offset, estimation.u_offset), largest_order=end)
    path = greedy_path(search, end, progress)
    if not path:
        raise DataError(f"the estimation record has {fitted.rows(1)} usable samples: too few for even "
                        f"the first list (1,)*{p}; give a longer record")
    if opts.order is not None:
        at = [i for i, st in enumerate(path) if st.order == opts.order]
        if not at:
            raise DataError(f"the path stopped at order {path[-1].order}, below the fixed order "
                            f"{opts.order}: the record is too short for it")
        chosen = at[0]
    elif opts.order_rule in (None, "paired"):
        chosen = select_by_shares(path, lambda i: path[i].errors, opts.order_errors, NEGLIGIBLE_VAF)
    else:
        chosen = select_order(path, opts.order_tolerance)
    step = path[chosen]
    if opts.order is None and step.order == end and end > p:
        warnings.warn(
            f"the selected order {step.order} is the end of the path (nmax = {end}): a higher order "
            "may fit better; raise nmax to look", OrderBoundWarning, stacklevel=3)
    if phase:
        phase("covariance")
    try:
        model, note = replace(step.model, cov_factor=covariance_factor(
            fitted, step.eta, step.indices, opts.s, step.thetas, opts.input_hold == "foh")), None
    except DataError as exc:
        model, note = step.model, str(exc)
    # what the sampled pipeline records on its model: the options, the hold to simulate it with
    unit = {} if estimation.time_unit is None else {"time_unit": estimation.time_unit}   # for axes and tables
    model = replace(model, input_hold=opts.input_hold, info={**model.info, "options": opts.to_dict(),
                                                             "validation_vaf": step.vaf.tolist(), **unit})
    warn_if_no_better_than_mean(model, validation, opts.x0, stacklevel=3)
    return ContinuousResult(model, path, chosen, opts, source, time.perf_counter() - start,
                            estimation, validation, note)
