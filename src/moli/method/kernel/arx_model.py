"""``moli.identify_kernel_arx``: a state-space model from a regularized ARX model, reduced by
balanced truncation, its order chosen on validation data by the paired rule of the MOLI path
(docs/regularization.md).

The regularized ARX model of the estimation record (:func:`.arx.regularized_arx`) is put in
block observer form (``p n`` states) and balanced (:mod:`.balanced`); its truncation to every
order up to ``nmax`` is simulated on the validation record, and the lowest order whose error is
within one paired standard error of the best is kept
(:func:`moli.method.selection.order_rules.select_by_shares`). The covariance of the kept
model's matrices is the ARX posterior pushed through the truncation's projection: each
direction of each output's posterior factor moves the ARX simulator, and the moved simulator
is projected with the nominal model's balancing (its own change neglected, so the bands speak
of the ARX coefficients' variance in the nominal model's coordinates).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...data.iodata import IOData
from ...errors import DataError
from ...models.statespace import StateSpaceModel
from .arx import RegularizedArx, regularized_arx
from .balanced import balancing
from .validated_orders import KernelStep, checked_records, order_bound, order_table, validated_orders, warn_order_cap
from ...numerics.blas_threads import limited_blas

__all__ = ["KernelArxResult", "identify_kernel_arx"]


@dataclass
class KernelArxResult:
    """What :func:`identify_kernel_arx` returns: the selected model, the regularized ARX model it
    reduces, every order's truncation, the records (as given) and where the validation record
    came from."""

    model: StateSpaceModel
    arx: RegularizedArx
    path: list[KernelStep]
    selected_index: int
    estimation: IOData
    validation: IOData
    validation_source: str

    @property
    def selected(self) -> KernelStep:
        """The selected order's step."""
        return self.path[self.selected_index]

    def summary(self) -> str:
        """The orders' validation VAFs and the selection, as text."""
        return order_table(f"kernel ARX model: {self.arx.kernel} prior, {self.arx.lags} lags per channel, "
                           f"validation {self.validation_source}", self.path, self.selected_index)


def identify_kernel_arx(data: IOData, validation: IOData | None = None, *, kernel: str = "TC",
                        nmax: int | None = None, lags: int | None = None, feedthrough: bool | str = "auto",
                        x0: str = "zero", center: bool = True) -> KernelArxResult:
    """A state-space model reducing the regularized ARX model, its order chosen on validation.

    Parameters
    ----------
    data : IOData
        Estimation record.
    validation : IOData, optional
        Validation record for the order; default: the last 30 % of ``data``.
    kernel : {"TC", "DC", "SS", "none"}, default "TC"
        The prior of every ARX polynomial (:func:`moli.method.regularized_arx`).
    nmax : int, optional
        Largest order tried; default ``max(10, p + 4)``, at most the states the balancing keeps.
    lags : int, optional
        Lags per channel of the ARX model; default 30, fewer on short records or many channels.
    feedthrough : {True, False, "auto"}, default "auto"
        A direct feedthrough ``D``; "auto": per output, where the ARX model's marginal likelihood
        is higher with it.
    x0 : {"zero", "estimate"}, default "zero"
        Initial state of the validation simulations.
    center : bool, default True
        Identify deviations from the estimation record's means (the model's operating point).

    Returns
    -------
    KernelArxResult

    Examples
    --------
    >>> import numpy as np, moli
    >>> data = moli.example_data(N=300, seed=1)
    >>> result = moli.identify_kernel_arx(data, nmax=6)
    >>> result.model.n == result.selected.order <= 6
    True
    """
    with limited_blas():
        estimation, validation, source = checked_records(data, validation, x0)
        last = order_bound(nmax, data.p)
        arx = regularized_arx(estimation, kernel, lags, feedthrough=feedthrough, center=center)
        A, B, C, D = arx.state_space()
        balanced = balancing(A, B, C)
        top = max(balanced.unstable, min(last, balanced.largest_order))
        warn_order_cap(nmax, top, f"the balanced ARX model keeps {balanced.largest_order} states")
        orders = range(max(1, balanced.unstable), top + 1)
        if not orders:
            raise DataError("the regularized ARX model has no response to the inputs (all its Hankel singular "
                            "values are zero): the record does not show the inputs acting on the outputs")
        # the operating point the fit removed
        means = (estimation.y.mean(axis=0), estimation.u.mean(axis=0)) if center else (None, None)

        def truncation(order: int) -> StateSpaceModel:
            V, W = balanced.projection(order)
            return StateSpaceModel(W.T @ A @ V, W.T @ B, C @ V, D, data.Ts, output_names=data.output_names,
                                   input_names=data.input_names, y_offset=means[0], u_offset=means[1])

        path, selected = validated_orders(((order, truncation(order)) for order in orders), validation, x0)
        chosen = path[selected]
        info = {"method": "kernel-arx", "kernel": kernel, "arx_lags": arx.lags, "validation_vaf": chosen.vaf.tolist(),
                **({} if data.time_unit is None else {"time_unit": data.time_unit})}
        cov_factor = _covariance(arx, *balanced.projection(chosen.order))
        model = StateSpaceModel(chosen.model.A, chosen.model.B, chosen.model.C, D, data.Ts,
                                output_names=data.output_names, input_names=data.input_names, y_offset=means[0],
                                u_offset=means[1], info=info, cov_factor=cov_factor)
        path[selected] = KernelStep(chosen.order, model, chosen.vaf)
        return KernelArxResult(model, arx, path, selected, estimation=estimation, validation=validation,
                               validation_source=source)


def _covariance(arx: RegularizedArx, V: np.ndarray, W: np.ndarray) -> np.ndarray:
    """``F`` with ``cov(vec[A, B, C, D]) = F F^T`` of the truncation by ``V, W``: each column of each
    output's posterior factor through the projected simulator. The simulator is at most quadratic
    in the coefficients (``A_k D`` in its ``B``), so the central difference of a unit step is exact."""
    columns = []
    for j, factor in enumerate(arx.cov_factors):
        for direction in factor.T:
            moved = []
            for sign in (1.0, -1.0):
                A, B, C, D = arx.moved(j, sign * direction).state_space()
                moved.append(np.concatenate([(W.T @ A @ V).ravel(), (W.T @ B).ravel(), (C @ V).ravel(), D.ravel()]))
            columns.append((moved[0] - moved[1]) / 2.0)
    return np.column_stack(columns)
