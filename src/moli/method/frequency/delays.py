"""A pure delay per input, ``G(s) = G_0(s) diag(exp(-s tau_j))``, fitted where the held-out lines prefer it.

A delay's phase ``-omega tau`` grows without bound, so a rational model only follows it over
a band with extra states. With ``delays="auto"`` the delay-free path runs first; then
(docs/frequency.md §4):

1. Per input ``j``, the single-input lines ``G[:, :, j]`` compensated by each delay of a grid
   (:func:`delay_grid`) are fitted by the subspace start of each order; the grid delay of least
   held-out error starts that order.
2. From one state up to the path's selected order, the whole response is fitted with those
   delays by Levenberg-Marquardt on ``theta`` and the delays together (continuous time;
   :func:`refine_with_delays`) on the estimation lines. The first order whose fit passes the
   paired rule against the best fit known, with or without delays, is taken: a delay must
   save states or lower the error the path reached.
3. Each delay found is compared, at that order, with the fit without it: it is kept only where
   the held-out lines prefer it by more than the paired rule's margin and the share of the
   error the path's rule neglects.
4. The delays kept are refined on every line, and the path runs again on the lines they
   compensate.

The delays fitted are the models' input delays: time units in continuous time, whole samples
for sampled data (a fraction of a sample is left to the rational model, which follows it
with its states). In the compensated frame ``G_k exp(j omega_k tau)`` the residual's modulus
is that of the delayed model's, and its derivative in ``tau_j`` is the data's alone:
``d r_kij / d tau_j = -w_kij j omega_k G_kij exp(j omega_k tau_j)``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ...data.frequency_data import FrequencyData
from ...errors import OptionError
from ...models.continuous import ContinuousModel
from ...models.statespace import StateSpaceModel
from ..selection.order_rules import select_by_shares
from ..selection.paired_test import error_shares, paired_difference
from .fit_error import LINE_CHUNK, FitProblem, cost, response, weighted_jacobian
from .modal_form import ModalLayout, is_stable
from .orders import FitDomain, band_wide_order, problem_on, start_model, subspace_basis
from .refinement import MAX_STEPS, PATH_RELATIVE_DECREASE, PATH_STEPS, RELATIVE_DECREASE, descend, refine_modal
from .settings import FrequencySettings

__all__ = ["DelayFit", "fit_delays", "forced_delays", "compensated", "with_delays", "delay_grid", "refine_with_delays",
           "SEARCHED_PHASE", "GRID_PHASE"]

# The delays searched: up to this phase at the highest line (one turn); a longer delay is beyond
# the search (a rational model would need many states to follow it: the fit shows it plainly).
SEARCHED_PHASE = 2 * np.pi
# Grid spacing in phase at the highest line: the grid delay nearest a true one is at most
# GRID_PHASE / 2 = 0.2 rad off there, a start from which the joint refinement converged in every case
# measured (docs/frequency.md §4).
GRID_PHASE = np.pi / 8


@dataclass(frozen=True)
class DelayFit:
    """The delays the search returns.

    Attributes
    ----------
    delays : tuple of float
        Per input, in time units (continuous) or samples (sampled data, whole numbers).
    estimated : tuple of float
        Per input, the delay fitted on the estimation lines before the held-out lines judged it.
    """

    delays: tuple[float, ...]
    estimated: tuple[float, ...]


@dataclass(frozen=True)
class _Step:
    """One order's fit of the search (``order``, ``stable`` and ``mean_vaf`` as the paired rule reads them)."""

    order: int
    layout: ModalLayout
    theta: np.ndarray
    delays: np.ndarray
    stable: bool
    mean_vaf: float
    shares: np.ndarray


def _seconds(data: FrequencyData, delays: np.ndarray) -> np.ndarray:
    return delays if data.Ts is None else delays * data.Ts


def compensated(data: FrequencyData, delays: np.ndarray) -> FrequencyData:
    """``data`` with column ``j`` times ``exp(j omega tau_j)`` (``delays`` in time units or samples)."""
    turn = np.exp(1j * np.outer(data.omega, _seconds(data, np.asarray(delays, dtype=float))))
    return FrequencyData(data.omega, data.G * turn[:, None, :], unit="rad/s", Ts=data.Ts, variance=data.variance,
                         output_names=data.output_names, input_names=data.input_names)


def with_delays(model: StateSpaceModel | ContinuousModel, delays: tuple[float, ...],
                info: dict[str, Any] | None = None) -> StateSpaceModel | ContinuousModel:
    """``model`` with these input delays (time units, or whole samples for a sampled model) and ``info`` added."""
    if not any(delays) and not info:
        return model
    if isinstance(model, ContinuousModel):
        return replace(model, input_delays=tuple(float(d) for d in delays), info={**model.info, **(info or {})})
    delayed = model.with_input_delays([int(round(d)) for d in delays])
    delayed.info.update(info or {})
    return delayed


def delay_grid(data: FrequencyData) -> np.ndarray:
    """The delays tried per input: steps of :data:`GRID_PHASE` up to :data:`SEARCHED_PHASE` at the highest line
    (continuous), or every whole sample up to that phase (sampled data; at least 10 samples)."""
    top = float(data.omega[-1])
    if data.Ts is None:
        return np.arange(0.0, SEARCHED_PHASE / top * (1 + 1e-12), GRID_PHASE / top)
    return np.arange(0.0, max(10, int(np.ceil(SEARCHED_PHASE / (top * data.Ts)))) + 1.0)


def _problem(data: FrequencyData, domain: FitDomain, delays: np.ndarray) -> FitProblem:
    return problem_on(compensated(data, delays), domain)


def _rows(values: np.ndarray) -> np.ndarray:
    return np.concatenate([values.real, values.imag], axis=1).reshape(values.shape[0], -1)


def _shares(layout: ModalLayout, theta: np.ndarray, delays: np.ndarray, judged: FrequencyData,
            domain: FitDomain) -> np.ndarray:
    """Held-out shares of the delayed model against the lines as measured (as :func:`held_out_shares`).

    The shares are normalized by the data's spread, which compensating the lines changes: judged in the
    measured frame, fits with different delays and the delay-free path compare on one scale."""
    problem = problem_on(judged, domain)
    turn = np.exp(-1j * np.outer(judged.omega, _seconds(judged, delays)))[:, None, :]
    predicted = response(layout, theta, problem.points) * turn
    return error_shares(_rows(problem.weights * problem.G),
                        _rows(problem.weights * predicted))[band_wide_order(judged.F)]


class _Grid:
    """Per input, the single-input lines compensated by each grid delay and their subspace bases (formed once,
    read at every order)."""

    def __init__(self, estimation: FrequencyData, judged: FrequencyData, domain: FitDomain,
                 settings: FrequencySettings) -> None:
        self.delays, self.domain, self.settings = delay_grid(estimation), domain, settings
        self.lines = []
        for j in range(estimation.m):
            columns = (slice(None), range(estimation.p), [j])
            single, held = estimation.pairs(*columns), judged.pairs(*columns)
            self.lines.append([(problem_on(compensated(single, [d]), domain),
                                subspace_basis(compensated(single, [d]), domain, settings.nmax), held)
                               for d in self.delays])

    def starts(self, order: int) -> np.ndarray:
        """Per input, the grid delay whose lines the subspace start of ``order`` states fits best on the
        held-out lines."""
        starts = np.zeros(len(self.lines))
        for j, per_delay in enumerate(self.lines):
            errors = np.full(self.delays.size, np.inf)
            for g, (problem, basis, held) in enumerate(per_delay):
                start = start_model(basis, order, problem, self.settings, self.domain)
                if start is not None:
                    errors[g] = float(np.sum(_shares(*start, self.delays[g:g + 1], held, self.domain)))
            starts[j] = self.delays[int(np.argmin(errors))]
        return starts


def _normal_equations(layout: ModalLayout, theta: np.ndarray, problem: FitProblem, omega: np.ndarray,
                      free: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """``J^T J``, ``J^T r`` and ``|r|^2`` of ``theta`` and the ``free`` inputs' delays, in the compensated frame."""
    size = layout.size + free.size
    curvature, gradient, total = np.zeros((size, size)), np.zeros(size), 0.0
    for start in range(0, problem.points.size, LINE_CHUNK):
        part = slice(start, start + LINE_CHUNK)
        jacobian, residual = weighted_jacobian(layout, theta, problem, part)
        by_delay = np.zeros(residual.shape + (free.size,), dtype=complex)
        for k, j in enumerate(free):
            by_delay[:, :, j, k] = -problem.weights[part, :, j] * 1j * omega[part, None] * problem.G[part, :, j]
        rows = np.concatenate([jacobian, by_delay], axis=-1).reshape(-1, size)
        stacked = np.concatenate([rows.real, rows.imag])
        curvature += stacked.T @ stacked
        flat = residual.ravel()
        gradient += stacked.T @ np.concatenate([flat.real, flat.imag])
        total += float(np.sum(np.abs(residual) ** 2))
    return curvature, gradient, total


def refine_with_delays(layout: ModalLayout, theta: np.ndarray, delays: np.ndarray, free: np.ndarray,
                       lines: FrequencyData, domain: FitDomain, *, radius: float | None,
                       max_steps: int = MAX_STEPS,
                       relative_decrease: float = RELATIVE_DECREASE) -> tuple[np.ndarray, np.ndarray, float]:
    """Levenberg-Marquardt on ``theta`` and the delays of the ``free`` inputs (time units, kept >= 0) together,
    as :func:`moli.method.frequency.refinement.refine_modal` does on ``theta`` alone (which it is without
    free delays); returns ``theta``, the delays and the cost."""
    delays = np.asarray(delays, dtype=float).copy()
    if free.size == 0:
        refined = refine_modal(layout, theta, _problem(lines, domain, delays), continuous=domain.continuous,
                               radius=radius, max_steps=max_steps, relative_decrease=relative_decrease)
        return refined.theta, delays, refined.cost

    def unpacked(point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        point_delays = delays.copy()
        point_delays[free] = point[layout.size:]
        return point[:layout.size], point_delays

    def linearize(point: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        point_theta, point_delays = unpacked(point)
        return _normal_equations(layout, point_theta, _problem(lines, domain, point_delays), lines.omega, free)

    def propose(point: np.ndarray, step: np.ndarray) -> tuple[np.ndarray, float]:
        trial = point + step
        trial[layout.size:] = np.maximum(trial[layout.size:], 0.0)                   # no advance: causal
        trial_theta, trial_delays = unpacked(trial)
        return trial, (cost(layout, trial_theta, _problem(lines, domain, trial_delays))
                       if is_stable(layout, trial_theta, domain.continuous, radius) else np.inf)

    refined = descend(linearize, propose, np.concatenate([theta, delays[free]]), max_steps=max_steps,
                      relative_decrease=relative_decrease)
    return (*unpacked(refined.theta), refined.cost)


def _fitted(order: int, delays: np.ndarray, free: np.ndarray, estimation: FrequencyData, judged: FrequencyData, *,
            domain: FitDomain, settings: FrequencySettings) -> _Step | None:
    """The order's subspace start on the lines compensated by ``delays``, refined with the ``free`` delays."""
    lines = compensated(estimation, delays)
    start = start_model(subspace_basis(lines, domain, settings.nmax), order, problem_on(lines, domain), settings,
                        domain)
    if start is None:
        return None
    layout, theta = start
    theta, delays, _ = refine_with_delays(layout, theta, delays, free, estimation, domain, radius=settings.radius,
                                          max_steps=PATH_STEPS, relative_decrease=PATH_RELATIVE_DECREASE)
    shares = _shares(layout, theta, delays, judged, domain)
    return _Step(order, layout, theta, delays, is_stable(layout, theta, domain.continuous, 1.0),
                 100.0 - float(np.sum(shares)), shares)


def _forced(data: FrequencyData, delays: int | tuple[int, ...]) -> DelayFit:
    values = (delays,) * data.m if isinstance(delays, int) else tuple(delays)
    if len(values) != data.m:
        raise OptionError(f"delays has {len(values)} entries for the {data.m} inputs of the frequency data")
    return DelayFit(tuple(float(d) for d in values), tuple(float(d) for d in values))


def forced_delays(data: FrequencyData, settings: FrequencySettings) -> DelayFit | None:
    """The delays ``settings.delays`` gives (whole samples of sampled data), or None where it gives none or
    asks for the search."""
    return None if settings.delays in (0, "auto") else _forced(data, settings.delays)


def _passes(step: Any, reference: Any, z: float, negligible: float) -> bool:
    """Whether ``step`` loses to ``reference`` on the held-out lines by no more than the paired rule's margin
    (or ``negligible`` points)."""
    worse, margin = paired_difference(step.shares, reference.shares, z)
    return bool(np.isfinite(worse) and worse <= max(margin, negligible))


def fit_delays(data: FrequencyData, domain: FitDomain, settings: FrequencySettings, held_out: np.ndarray,
               path: list[Any], selected: int, *, negligible_share: float) -> DelayFit:
    """The search of ``delays="auto"``, given the delay-free ``path`` (its steps' ``order``, ``mean_vaf``,
    ``stable`` and held-out ``shares``) and its ``selected`` step.

    From one state up to the selected order, each order is fitted with a delay per input; the lowest order
    whose fit passes the paired rule against the best fit known (with or without delays) keeps its delays,
    each only where dropping it loses on the held-out lines by more than the rule's margin and
    ``negligible_share`` of the best fit's error. The delays are then refined on every line. Zero delays:
    none was kept.
    """
    estimation = data.lines(np.setdiff1d(np.arange(data.F), held_out))
    judged = data.lines(held_out)
    grid, free = _Grid(estimation, judged, domain, settings), np.arange(data.m) if data.Ts is None else np.arange(0)
    known = [step for step in path if step.stable] or list(path)
    chosen = None
    for order in range(1, path[selected].order + 1):
        step = _fitted(order, grid.starts(order), free, estimation, judged, domain=domain, settings=settings)
        if step is None:
            continue
        if step.stable:
            known.append(step)
        best = max(known, key=lambda each: each.mean_vaf)
        if _passes(step, best, settings.z, negligible_share * (100.0 - best.mean_vaf)):
            chosen = step
            break
    none = (0.0,) * data.m
    if chosen is None or not np.any(chosen.delays > 0):
        return DelayFit(none, none if chosen is None else tuple(float(d) for d in chosen.delays))
    estimated = tuple(float(d) for d in chosen.delays)
    for j in np.flatnonzero(chosen.delays > 0):
        # the fit without input j's delay (the others free) against the one with it, at the same order
        without = chosen.delays.copy()
        without[j] = 0.0
        rival = _fitted(chosen.order, without, free[(chosen.delays[free] > 0) & (free != j)], estimation, judged,
                        domain=domain, settings=settings)
        pair = [rival, chosen]
        if rival is not None and select_by_shares(pair, lambda i: pair[i].shares, settings.z, negligible_share * (
                100.0 - max(rival.mean_vaf, chosen.mean_vaf))) == 0:
            chosen = rival
    if not np.any(chosen.delays > 0):
        return DelayFit(none, estimated)
    _, delays, _ = refine_with_delays(chosen.layout, chosen.theta, chosen.delays, free[chosen.delays[free] > 0],
                                      data, domain, radius=settings.radius)
    return DelayFit(tuple(float(d) for d in delays), estimated)
