"""What :func:`moli.identify` returns: the selected model, the path, and how it was chosen."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..data.display import period_text
from ..data.iodata import IOData
from ..models.statespace import StateSpaceModel
from .options.identify_options import IdentifyOptions
from .search.greedy_path import PathStep

__all__ = ["IdentificationResult"]


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
    options : IdentifyOptions
        The options the search ran with, as given (also in ``model.info["options"]``).
    nmax : int
        The order bound the path ran to (``options.nmax`` or its default).
    omega : ndarray, shape (R, 2)
        The filter candidates searched (``options.omega`` or the default grid).
    max_radius : float or None
        The stability bound applied (``options.max_radius``, "auto" resolved).
    seconds : float
        Total wall time.
    interrupted : bool
        True when the search was stopped by Ctrl-C; the path holds what was done.
    skipped : tuple of str
        The phases after the path that Ctrl-C cut, e.g. ``("covariance", "noise model")``.
    """

    model: StateSpaceModel
    path: list[PathStep]
    selected_index: int
    estimation: IOData = field(repr=False)
    validation: IOData = field(repr=False)
    validation_source: str
    options: IdentifyOptions
    nmax: int
    omega: np.ndarray = field(repr=False)
    max_radius: float | None
    seconds: float
    interrupted: bool = False
    skipped: tuple[str, ...] = ()

    @property
    def selected(self) -> PathStep:
        """The path step of the selected model."""
        return self.path[self.selected_index]

    @property
    def selection(self) -> str:
        """How the selected model was chosen, in words."""
        opts = self.options
        if opts.order is not None and self.selected.order == opts.order:
            return f"the fixed order n = {opts.order} (IdentifyOptions.order)"
        fell_back = "order rule's refinements" in self.skipped or (self.interrupted and not self.skipped)
        if opts.order_rule == "paired" or (opts.order_rule == "refined" and fell_back):
            return "lowest order within one paired standard error of the best validation error"
        if opts.order_rule == "refined":
            return ("lowest order whose best refined list is within one paired standard error of the "
                    "best validation error")
        return f"lowest order within {opts.order_tolerance:g} point of the best mean validation VAF"

    @property
    def loop_method(self) -> str | None:
        """How a closed-loop record was identified and why, in words; None for an open-loop record
        identified as such (docs/closed_loop.md)."""
        loop = self.model.info.get("closed_loop", {})
        if loop.get("method", "open") == "open" and not loop.get("feedback"):
            return None
        if "basis_pole" in loop:
            basis = (f"FIR of lags 0 to {loop['basis_functions']}" if loop["basis_pole"] == 0 else
                     f"each reference and {loop['basis_functions']} Laguerre functions of pole {loop['basis_pole']:g}")
            first = f"; first stage: {basis}, input variance explained " + ", ".join(
                f"{name} {share:.0%}" for name, share in loop["explained_share"].items())
        else:
            first = ""
        return f"{loop['method']} method: {loop['why']}{first}"

    def summary(self) -> str:
        """A readable table of the greedy path and the selection."""
        names = self.estimation.output_names
        opts = self.options
        # long channel names (e.g. DaISy's) would break the columns: number them and list them
        head = f"{'n':>3}  {'indices':<16}{'J':>8}  " + "".join(f"{f'VAF y{i + 1}':>11}" for i in range(len(names)))
        head += f"{'mean VAF':>10}{'wc':>9}{'zeta':>7}{'stable':>8}{'sec':>8}"
        lines = [
            f"moli identification: {self.estimation.p} outputs, {self.estimation.m} inputs, "
            f"Ts = {period_text(self.estimation.Ts, self.estimation.time_unit)}",
            f"estimation: {self.estimation.N} samples{_in_segments(self.estimation)}" + (
                f" (searched on the first {searched})" if (searched := self.model.info.get("search_samples")) else "")
            + f"; validation: {self.validation.N} samples{_in_segments(self.validation)} ({self.validation_source})",
            f"VAF: validation, simulation from {self.options.x0} initial state, percent"
            + "".join(f"; y{i + 1} = {nm}" for i, nm in enumerate(names) if nm != f"y{i + 1}"),
            f"options: tuning {opts.tuning}, s = {opts.s:g}, feedthrough {opts.feedthrough}, "
            f"max pole radius {'none' if self.max_radius is None else f'{self.max_radius:.6g}'}, "
            f"J trend degree {opts.trend_degree}, per-output filters {opts.output_filters}, "
            f"refinement {opts.refine}"
            + (f", input delays {list(self.model.input_delays)}" if any(self.model.input_delays) else ""),
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
            f"{self.selection}, on {self.validation.N} validation samples; total {self.seconds:.2f} s"
            + (f" (interrupted: skipped {', '.join(self.skipped)})" if self.skipped else
               " (interrupted: partial path)" if self.interrupted else "")
        )
        if self.selected.output_etas is not None:
            lines.append("its filters per output (wc, zeta): " + ", ".join(
                f"y{j + 1} ({wc:.4g}, {zeta:.3g})" for j, (wc, zeta) in enumerate(self.selected.output_etas)
            ))
        if self.loop_method is not None:
            lines.append(f"closed loop: {self.loop_method}")
        noise = self.model.info.get("noise_model", {})
        if self.model.K is not None:
            std = ", ".join(f"{v:.4g}" for v in np.sqrt(np.diag(self.model.noise_cov)))
            how = ("K = 0: the simulation error is white (likelihood-ratio test)"
                   if noise.get("start") == "white simulation error"
                   else "Kalman gain K estimated jointly with the model (direct method)"
                   if self.model.info.get("refine_method") == "prediction error"
                   else "Kalman gain K from the estimation residuals")
            lines.append(f"noise model: {how}, innovation std {std}")
        elif noise.get("method") == "none":
            lines.append(f"noise model: none ({noise['reason']})")
        return "\n".join(lines)


def _in_segments(data: IOData) -> str:
    return f" in {data.n_segments} segments" if data.n_segments > 1 else ""
