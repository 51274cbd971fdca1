"""The values each field of :class:`IdentifyOptions` accepts, and what the named presets change."""

from __future__ import annotations

__all__ = ["REFINE_CHOICES", "EVAPORATOR_CHOICES", "ORDER_RULES", "FAST_CHOICES", "PRESETS", "TIMES", "INPUT_HOLDS",
           "CLOSED_LOOP_METHODS", "METHODS", "KERNEL_METHODS", "KERNELS", "MIN_SEARCH_SAMPLES", "FREQUENCY_STARTS"]

REFINE_CHOICES = ("none", "selected", "path", "guarded")
# What the earlier presets share and the default no longer does (chosen on the
# evaporator windows; docs/accuracy.md shows what they cost elsewhere).
EVAPORATOR_CHOICES = {"order_tolerance": 1.0, "filter_grid": "paper", "refine": "none", "refine_ridge": 1.0}
ORDER_RULES = ("tolerance", "paired", "refined")
# The fast preset: screened greedy steps (one filter tuning per step), a path that stops three
# orders after its best validation fit, no sibling lists refined, the generic list taken to its
# optimum only where it is kept, at most five Levenberg-Marquardt steps per refinement, no orders
# below the selected one, and the selected model's early stop kept; ahead of the best subspace
# peer on every seed of the generalization benchmark (docs/accuracy.md, "The fast preset").
FAST_CHOICES = {"screen_lists": True, "path_patience": 3, "refine_siblings": False, "screen_generic": True,
                "refine_iterations": 5, "lower_orders": False, "polish_selected": False}
PRESETS = ("default", "fast", "improved", "bounded", "paper")
TIMES = ("discrete", "continuous")
INPUT_HOLDS = ("zoh", "foh")
CLOSED_LOOP_METHODS = ("open", "two-stage", "direct")
# Shortest search window: a few hundred samples still rank the filters and lists of
# small plants; below that a window says too little about the record.
MIN_SEARCH_SAMPLES = 500
# What estimates the model: the MOLI path, the realization of a regularized impulse response, or
# the balanced reduction of a regularized ARX model (docs/regularization.md); the last two are the
# kernel methods.
METHODS = ("moli", "kernel", "kernel-arx")
KERNEL_METHODS = ("kernel", "kernel-arx")
# The priors of the kernel method's impulse responses (moli.method.kernel.kernels): tuned-correlated,
# diagonal-correlated, stable spline, or none (plain least squares; docs/regularization.md).
KERNELS = ("TC", "DC", "SS", "none")
# The starts of each order's model from frequency data: the subspace method alone, or it and the
# MOLI start on the frequency grid, the better on the held-out lines kept (docs/frequency.md §2b).
FREQUENCY_STARTS = ("subspace", "both")
