"""The stabilization diagram: the modes of the model of every order tried, marked where they persist.

A physical mode persists as the order grows: its natural frequency, damping ratio and
shape change little from one order to the next, while the modes that fit noise wander.
Each mode of an order is paired with the mode of the previous order (the path's step
before it) nearest in natural frequency, and marked stable

- in frequency, where ``|f - f_prev| <= 1 %`` of ``f_prev``;
- in damping, where also ``|zeta - zeta_prev| <= 5 %`` of ``|zeta_prev|``;
- in shape, where also the modal assurance criterion of the output shapes,
  ``MAC = |phi' phi_prev|^2 / (|phi|^2 |phi_prev|^2)``, is at least 0.98,

the tolerances of the stabilization diagrams of experimental modal analysis (PolyMAX,
stochastic subspace identification). Damping and shape are compared only where the
frequency is stable: without it the pairing is no same mode. With one output every shape
is a scalar and the MAC is 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from ..errors import DataError
from ..models.modal import Mode, modes
from .figures import new_figure

__all__ = ["StabilizationPoint", "stabilization", "mac", "stabilization_figure", "FREQUENCY_TOLERANCE",
           "DAMPING_TOLERANCE", "MAC_THRESHOLD", "LEGEND"]

FREQUENCY_TOLERANCE = 0.01
DAMPING_TOLERANCE = 0.05
MAC_THRESHOLD = 0.98
# Each status: its legend entry, marker and colour (the closed markers drawn hollow, so that they overlap legibly).
LEGEND = {
    "new": (f"new (no mode of the previous order within {FREQUENCY_TOLERANCE:.0%} in frequency)", "+", "0.55"),
    "frequency": (f"stable in frequency ({FREQUENCY_TOLERANCE:.0%})", "x", "C0"),
    "damping": (f"stable in frequency and damping ({DAMPING_TOLERANCE:.0%})", "^", "C2"),
    "shape": (f"stable in frequency and shape (MAC ≥ {MAC_THRESHOLD})", "s", "C1"),
    "all": ("stable in frequency, damping and shape", "o", "C3"),
}


@dataclass(frozen=True)
class StabilizationPoint:
    """One mode of one order, and what of it the previous order confirms.

    Attributes
    ----------
    order : int
        The model's number of states.
    mode : Mode
    frequency, damping, shape : bool
        Stable in natural frequency, in damping ratio and in shape against the previous order
        (damping and shape only where the frequency is).
    """

    order: int
    mode: Mode
    frequency: bool
    damping: bool
    shape: bool

    @property
    def status(self) -> str:
        """A key of :data:`LEGEND`: ``"new"``, ``"frequency"``, ``"damping"``, ``"shape"`` or ``"all"``."""
        if not self.frequency:
            return "new"
        if self.damping and self.shape:
            return "all"
        return "damping" if self.damping else "shape" if self.shape else "frequency"


def mac(first: np.ndarray, second: np.ndarray) -> float:
    """The modal assurance criterion of two complex shapes: 1 for parallel shapes, 0 for orthogonal ones.

    Examples
    --------
    >>> mac(np.array([1.0, 2j]), np.array([-2.0, -4j]))
    1.0
    >>> mac(np.array([1.0, 0.0]), np.array([0.0, 1.0]))
    0.0
    """
    first, second = np.asarray(first, complex), np.asarray(second, complex)
    scale = np.vdot(first, first).real * np.vdot(second, second).real
    return float(abs(np.vdot(first, second)) ** 2 / scale) if scale > 0 else 0.0


def _compared(order: int, mode: Mode, previous: Sequence[Mode]) -> StabilizationPoint:
    if not previous:
        return StabilizationPoint(order, mode, False, False, False)
    match = min(previous, key=lambda other: abs(other.natural_frequency - mode.natural_frequency))
    frequency = abs(mode.natural_frequency - match.natural_frequency) <= FREQUENCY_TOLERANCE * match.natural_frequency
    damping = frequency and bool(abs(mode.damping - match.damping) <= DAMPING_TOLERANCE * abs(match.damping))
    shape = frequency and mac(mode.shape, match.shape) >= MAC_THRESHOLD
    return StabilizationPoint(order, mode, bool(frequency), damping, bool(shape))


def stabilization(models: Sequence[Any]) -> list[StabilizationPoint]:
    """Every mode of every model, compared with the modes of the model before it.

    Parameters
    ----------
    models : sequence of StateSpaceModel or ContinuousModel
        One model per order, by increasing order (``FrequencyResult.path_models``); the
        first one's modes are all new.

    Returns
    -------
    list of StabilizationPoint
        By order, then by natural frequency.
    """
    points: list[StabilizationPoint] = []
    previous: tuple[Mode, ...] = ()
    for model in models:
        try:
            found = modes(model)
        except DataError:       # a sampled model with a pole at z = 0 has no continuous-time modes: none shown
            found = ()
        points += [_compared(model.n, mode, previous) for mode in found]
        previous = found
    return points


def stabilization_figure(points: Sequence[StabilizationPoint], selected_order: int,
                         band_hz: tuple[float, float]) -> Figure:
    """Natural frequency (Hz) against order, each mode marked by its status; the selected order a line.

    Modes outside ``band_hz`` (the measured lines) are left out: the data say nothing of them.
    """
    fig = new_figure(7.0, 4.6)
    ax = fig.subplots()
    low, high = band_hz
    for status, (label, marker, colour) in LEGEND.items():
        shown = [(pt.mode.frequency_hz, pt.order) for pt in points
                 if pt.status == status and low <= pt.mode.frequency_hz <= high]
        hz, order = np.array(shown).T if shown else (np.empty(0), np.empty(0))
        style = {"facecolors": "none", "edgecolors": colour} if marker in "s^o" else {"color": colour}
        ax.scatter(hz, order, marker=marker, s=28, label=label, linewidths=1.0, **style)
    ax.axhline(selected_order, color="0.3", lw=0.8, ls="--", label=f"selected order ({selected_order})")
    ax.set_xscale("log")
    ax.set_xlim(low, high)
    orders = sorted({pt.order for pt in points} | {selected_order})
    ax.set_ylim(orders[0] - 0.5, orders[-1] + 0.5 + 0.45 * len(orders))     # room for the legend above the top order
    ax.set_xlabel("natural frequency (Hz)")
    ax.set_ylabel("order (states)")
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=7, ncols=2, framealpha=0.95)
    return fig
