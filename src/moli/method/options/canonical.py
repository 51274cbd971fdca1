"""Each field of :class:`moli.IdentifyOptions` in its canonical form, and the checks that span fields."""

from __future__ import annotations

from typing import Any

from ...validation.comparison import X0_CHOICES
from .choices import (
    CLOSED_LOOP_METHODS, FREQUENCY_STARTS, INPUT_HOLDS, KERNEL_METHODS, KERNELS, METHODS, MIN_SEARCH_SAMPLES,
    ORDER_RULES, REFINE_CHOICES, TIMES,
)
from .value_checks import (
    check_choice, check_delays, check_flag, check_names, check_integer, check_number, check_omega_pairs, check_ridges,
    option_error,
)
from ..least_squares.shared_factors import FEEDTHROUGH_CHOICES
from ..least_squares.regularization import REGULARIZATIONS
from ..tuning.criterion import MAX_TREND_DEGREE
from ..tuning.barycenter import GRIDS, TUNING_METHODS

__all__ = ["canonical_fields"]


def canonical_fields(options: Any) -> dict[str, Any]:
    """Every field of ``options`` (an :class:`moli.IdentifyOptions` being built) checked and in its
    canonical form; an :class:`moli.OptionError` naming the field and what it accepts where one is wrong."""
    radius = options.max_radius
    if radius is None or isinstance(radius, str) and radius == "none":
        radius = None
    elif not (isinstance(radius, str) and radius == "auto"):
        radius = check_number("max_radius", radius, "'auto', None or a number in (0, 1]",
                         lambda r: 0 < r <= 1)
    refine = {True: "selected", False: "none"}.get(options.refine, options.refine) \
        if isinstance(options.refine, bool) else options.refine
    checked = {
        "nmax": None if options.nmax is None else check_integer("nmax", options.nmax, 1),
        "order_rule": None if options.order_rule is None
        else check_choice("order_rule", options.order_rule, ORDER_RULES),
        "order": None if options.order is None else check_integer("order", options.order, 1),
        "order_errors": check_number("order_errors", options.order_errors,
                                "a number >= 0 (paired standard errors)", lambda z: z >= 0),
        "order_tolerance": check_number("order_tolerance", options.order_tolerance,
                                   "a number >= 0 (points of VAF)", lambda t: t >= 0),
        "omega": check_omega_pairs(options.omega),
        "filter_grid": check_choice("filter_grid", options.filter_grid, tuple(GRIDS)),
        "tuning": check_choice("tuning", options.tuning, TUNING_METHODS),
        "iterations": check_integer("iterations", options.iterations, 1),
        "s": check_number("s", options.s, "a number > 1", lambda s: s > 1),
        "seed": check_integer("seed", options.seed, 0),
        "output_filters": check_flag("output_filters", options.output_filters),
        "screen_lists": check_flag("screen_lists", options.screen_lists),
        "path_patience": None if options.path_patience is None
        else check_integer("path_patience", options.path_patience, 1),
        "feedthrough": check_choice("feedthrough", options.feedthrough, FEEDTHROUGH_CHOICES),
        "max_radius": radius,
        "criterion_x0": check_choice("criterion_x0", options.criterion_x0, X0_CHOICES),
        "trend_degree": check_integer("trend_degree", options.trend_degree, 0, MAX_TREND_DEGREE),
        "refine": check_choice("refine", refine, REFINE_CHOICES),
        "refine_siblings": check_flag("refine_siblings", options.refine_siblings),
        "lower_orders": check_flag("lower_orders", options.lower_orders),
        "screen_generic": check_flag("screen_generic", options.screen_generic),
        "polish_selected": check_flag("polish_selected", options.polish_selected),
        "refine_iterations": check_integer("refine_iterations", options.refine_iterations, 1),
        "refine_ridge": check_ridges(options.refine_ridge),
        "center": check_flag("center", options.center),
        "x0": check_choice("x0", options.x0, X0_CHOICES),
        "noise_model": check_flag("noise_model", options.noise_model),
        "regularization": check_choice("regularization", options.regularization, REGULARIZATIONS),
        "delays": check_delays(options.delays),
        "search_samples": None if options.search_samples is None else check_integer(
            "search_samples", options.search_samples, MIN_SEARCH_SAMPLES),
        "time": check_choice("time", options.time, TIMES),
        "input_hold": check_choice("input_hold", options.input_hold, INPUT_HOLDS),
        "reference": check_names("reference", options.reference),
        "closed_loop": None if options.closed_loop is None else check_choice(
            "closed_loop", options.closed_loop, CLOSED_LOOP_METHODS),
        "method": check_choice("method", options.method, METHODS),
        "frequency_start": check_choice("frequency_start", options.frequency_start, FREQUENCY_STARTS),
        "kernel": check_choice("kernel", options.kernel, KERNELS),
    }
    if checked["closed_loop"] == "two-stage" and checked["reference"] is None:
        raise option_error("closed_loop", "'open' or 'direct' without a reference (the two-stage method "
                           "needs reference=[names of the reference channels])", options.closed_loop)
    if checked["order"] is not None and checked["nmax"] is not None and checked["order"] > checked["nmax"]:
        raise option_error("order", f"at most nmax = {checked['nmax']} (the end of the path)", options.order)
    if checked["kernel"] != "TC" and checked["method"] not in KERNEL_METHODS:
        raise option_error("kernel", "'TC' unless method is 'kernel' or 'kernel-arx' (only the kernel methods have "
                           "a prior to choose)", options.kernel)
    return checked
