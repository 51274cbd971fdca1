"""identify() on FrequencyData: a model per order, the order from held-out lines, the refined model and its covariance.

Every :data:`HOLD_OUT_EVERY`-th line (from the third on) is held out, interleaved with the
estimation lines over the whole band, so that the held-out lines test every resonance
rather than extrapolate to a band the fit never saw. Each order's model is fitted on the
estimation lines (:mod:`moli.method.frequency.orders`); the paired rule of the time
domain (:func:`moli.method.selection.order_rules.select_by_shares`, the held-out lines in
frequency order taking the samples' place) picks the lowest order within ``order_errors``
paired standard errors of the best; the selected model is then refined on every line, and
its covariance is the sandwich of that refinement (docs/frequency.md).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from ...data.frequency_data import FrequencyData
from ...errors import DataError, OptionError, UnstableModelWarning
from ...models.continuous import ContinuousModel
from ...models.statespace import StateSpaceModel
from ..options import IdentifyOptions
from ..selection.order_rules import select_by_shares
from .delays import DelayFit, compensated, fit_delays, forced_delays, with_delays
from .modal_form import matrices
from .moli_start import with_moli_start
from .orders import FitDomain, FrequencyStep, fit_domain, fit_order, problem_on, subspace_basis
from .refinement import covariance_factor, refine_modal
from .settings import frequency_settings

__all__ = ["FrequencyResult", "identify_frequency", "HOLD_OUT_EVERY"]

# One line in five held out: enough lines to judge each order (400 of 2000), and the
# estimation keeps four in five of every resonance's lines.
HOLD_OUT_EVERY = 5
HOLD_OUT_FIRST = 2
# An order also passes the paired rule when it raises the held-out error by at most this share
# of the best order's: over the 400 x 2pm held-out terms of 2000 lines the error of noise alone
# spreads by sqrt(2 / terms), 2 % of itself at p m = 6, so a 1 % loss is none the lines can
# show, however many paired standard errors it is (nested orders fitting the same noise
# differ very little, and very steadily: a ninth state won 1.7e-5 of a point against a margin
# of the same size on one of the test's seeds).
NEGLIGIBLE_SHARE = 0.01


@dataclass
class FrequencyResult:
    """Outcome of an identification from frequency data.

    Attributes
    ----------
    model : StateSpaceModel or ContinuousModel
        The selected model refined on every line, with its covariance (``cov_factor``)
        where the refinement ran.
    path : list of FrequencyStep
        One model per order tried, fitted on the estimation lines.
    selected_index : int
    options : IdentifyOptions
    held_out : ndarray
        Positions of the held-out lines in the data.
    seconds : float
    covariance_note : str or None
        Why the model carries no covariance; None when it does.
    path_models : list of StateSpaceModel or ContinuousModel
        Each path step's model in the data's units (no covariance), for the poles of every
        order tried (the stabilization diagram of ``moli fit --frequency``).
    """

    model: StateSpaceModel | ContinuousModel
    path: list[FrequencyStep] = field(repr=False)
    selected_index: int
    options: IdentifyOptions = field(repr=False)
    held_out: np.ndarray = field(repr=False)
    seconds: float
    covariance_note: str | None = None
    path_models: list[StateSpaceModel | ContinuousModel] = field(default_factory=list, repr=False)

    @property
    def selected(self) -> FrequencyStep:
        """The path's step the order rule chose."""
        return self.path[self.selected_index]


def _physical(data: FrequencyData, domain: FitDomain, matrices_: tuple[np.ndarray, ...], factor: np.ndarray | None,
              info: dict) -> StateSpaceModel | ContinuousModel:
    A, B, C, D = matrices_
    if not domain.continuous:
        return StateSpaceModel(A, B, C, D, data.Ts, output_names=data.output_names, input_names=data.input_names,
                               info=info, cov_factor=factor)
    n, m = B.shape
    if factor is not None:
        # A and B carry the time scale: s I - A in the fit's units is (s I - omega_c A) / omega_c
        factor = factor.copy()
        factor[: n * n + n * m] *= domain.scale
    return ContinuousModel(A * domain.scale, B * domain.scale, C, D, tuple(data.output_names),
                           tuple(data.input_names), np.zeros(C.shape[0]), np.zeros(m), (0.0,) * m, factor,
                           info=info)


def _delayed(result: FrequencyResult, found: DelayFit, options: IdentifyOptions, start_time: float) -> FrequencyResult:
    """``result`` (of the lines compensated by the delays found) with its models carrying them."""
    info = {"delays_estimated": list(found.estimated)} if options.delays == "auto" else {}
    return replace(result, model=with_delays(result.model, found.delays, info), options=options,
                   path_models=[with_delays(each, found.delays) for each in result.path_models],
                   seconds=time.perf_counter() - start_time)


def _check_size(data: FrequencyData, estimation_lines: int, nmax: int) -> None:
    # the subspace step needs more real columns than rows, the refinement more equations than parameters
    rows = (nmax + 1) * (data.m + data.p)
    parameters = nmax * (1 + data.m + data.p) + data.p * data.m
    if 2 * estimation_lines * data.m <= rows or 2 * estimation_lines * data.p * data.m <= parameters:
        raise DataError(f"{data.F} lines ({estimation_lines} for estimation, one in {HOLD_OUT_EVERY} held out) are "
                        f"too few for models of up to {nmax} states of {data.p} outputs and {data.m} inputs; "
                        "give more lines or a smaller nmax")


def identify_frequency(
    data: FrequencyData, validation: object, options: IdentifyOptions,
    progress: Callable[[FrequencyStep], None] | None = None, phase: Callable[[str], None] | None = None,
) -> FrequencyResult:
    """:func:`moli.identify` for :class:`FrequencyData` (docs/frequency.md)."""
    start_time = time.perf_counter()
    if validation is not None:
        raise OptionError("validation does not apply to frequency data: the order is judged on held-out lines "
                          f"(every {HOLD_OUT_EVERY}th line of data); merge the lines into one FrequencyData")
    for name, hook in (("progress", progress), ("phase", phase)):
        if hook is not None and not callable(hook):
            raise OptionError(f"{name} must be a callable, got {type(hook).__name__}")
    domain = fit_domain(data)
    settings = frequency_settings(options, domain.continuous, data.p)
    forced = forced_delays(data, settings)
    if forced is not None:          # whole samples given: the path runs on the lines they compensate
        return _delayed(identify_frequency(compensated(data, np.array(forced.delays)), None,
                                           options.replace(delays=0), progress, phase), forced, options, start_time)
    held_out = np.arange(HOLD_OUT_FIRST, data.F, HOLD_OUT_EVERY)
    kept = np.setdiff1d(np.arange(data.F), held_out)
    _check_size(data, kept.size, settings.nmax)
    estimation, validation_lines = data.lines(kept), data.lines(held_out)
    problem, judged = problem_on(estimation, domain), problem_on(validation_lines, domain)
    basis = subspace_basis(estimation, domain, settings.nmax)
    orders = [settings.order] if settings.order is not None else range(1, settings.nmax + 1)
    path = []
    for order in orders:
        refine = settings.refine in ("path", "guarded")
        step = fit_order(order, basis, problem, judged, settings, domain, refine=refine)
        if settings.moli_start:
            step = with_moli_start(step, order, problem, judged, settings, domain.continuous, refine=refine)
        if step is not None:
            path.append(step)
            if progress is not None:
                progress(step)
    if not path:
        raise DataError("no order gave a model with distinct poles (a defective A at every order): check that "
                        "the lines hold a response, not noise or a constant")
    eligible = [step for step in path if step.stable] or path       # as select_by_shares takes them
    negligible = NEGLIGIBLE_SHARE * (100.0 - max(step.mean_vaf for step in eligible))
    index = 0 if settings.order is not None else select_by_shares(path, lambda i: path[i].shares, settings.z,
                                                                   negligible)
    found = None
    if settings.delays == "auto":
        if phase is not None:
            phase("delays")
        found = fit_delays(data, domain, settings, held_out, path, index, negligible_share=NEGLIGIBLE_SHARE)
        if any(found.delays):       # docs/frequency.md §4: the path again on the compensated lines
            return _delayed(identify_frequency(compensated(data, np.array(found.delays)), None,
                                               options.replace(delays=0), None, phase), found, options, start_time)
    step = path[index]
    whole = problem_on(data, domain)
    theta, note, factor = step.theta, None, None
    origin = "subspace" if step.start == "subspace" else "MOLI"
    refined = settings.refine != "none" and (settings.refine != "guarded" or step.refined)
    if refined:
        if phase is not None:
            phase("refinement")
        theta = refine_modal(step.layout, step.theta, whole, continuous=domain.continuous,
                             radius=settings.radius).theta
        if phase is not None:
            phase("covariance")
        factor = covariance_factor(step.layout, theta, whole, given_variance=data.variance is not None)
        note = None if factor is not None else "the refinement's Jacobian has no rank to spare beyond its gauge"
    else:
        note = (f"refine='none' keeps the {origin} estimate, which is no minimum of the fit: no sandwich"
                if settings.refine == "none" else f"the held-out lines preferred the {origin} start to its refinement")
    info = {"method": f"frequency-domain {origin} start, weighted FRF refinement",
            "held_out_every": HOLD_OUT_EVERY, "order": step.order, "refined": refined}
    if found is not None:
        info["delays_estimated"] = list(found.estimated)
    model = _physical(data, domain, matrices(step.layout, theta), factor, info)
    if not model.is_stable():          # only with max_radius=None: the refinement keeps the bound otherwise
        worst = (f"largest real part {np.max(model.poles().real):.4g}" if domain.continuous
                 else f"largest pole modulus {np.max(np.abs(model.poles())):.4g}")
        # pointing at the caller of moli.identify: here, identify_frequency, routes.frequency_route, identify
        warnings.warn(UnstableModelWarning(f"the model fitted to the frequency data is unstable ({worst}), as "
                                           "max_radius=None allows"), stacklevel=4)
    return FrequencyResult(model=model, path=path, selected_index=index, options=options, held_out=held_out,
                           seconds=time.perf_counter() - start_time, covariance_note=note,
                           path_models=[_physical(data, domain, matrices(each.layout, each.theta), None,
                                                  {"order": each.order})
                                        for each in path])
