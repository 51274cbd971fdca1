"""``moli.identify_kernel``: a state-space model from the regularized impulse response, its order
chosen on validation data by the paired rule of the MOLI path (docs/regularization.md).

The impulse response of the estimation record (:func:`.impulse.impulse_response`) is realized
at every order up to ``nmax`` (:mod:`.realization`); each realization is simulated on the
validation record, and the lowest order whose error is within one paired standard error of the
best is kept (:func:`moli.method.selection.order_rules.select_by_shares`). Its covariance is the
impulse response's posterior pushed through the realization, so ``magnitude_bands`` and
``step_bands`` work on it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...data.iodata import IOData
from ...models.statespace import StateSpaceModel
from .impulse import ImpulseResponse, impulse_response
from .realization import hankel_blocks, hankel_realization, realization_covariance
from .validated_orders import KernelStep, checked_records, order_bound, order_table, validated_orders, warn_order_cap
from ...numerics.blas_threads import limited_blas

__all__ = ["KernelResult", "identify_kernel"]


@dataclass
class KernelResult:
    """What :func:`identify_kernel` returns: the selected model, the impulse response it realizes,
    every order's realization, the records (as given) and where the validation record came from."""

    model: StateSpaceModel
    impulse: ImpulseResponse
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
        return order_table(f"kernel model: {self.impulse.kernel} prior, impulse response of {len(self.impulse.lags)} "
                           f"lags, validation {self.validation_source}", self.path, self.selected_index)


def identify_kernel(data: IOData, validation: IOData | None = None, *, kernel: str = "TC", nmax: int | None = None,
                    length: int | None = None, feedthrough: bool = False, x0: str = "zero",
                    center: bool = True) -> KernelResult:
    """A state-space model realizing the regularized impulse response, its order chosen on validation.

    Parameters
    ----------
    data : IOData
        Estimation record.
    validation : IOData, optional
        Validation record for the order; default: the last 30 % of ``data``.
    kernel : {"TC", "DC", "SS", "none"}, default "TC"
    nmax : int, optional
        Largest order tried; default ``max(10, p + 4)``, at most what the Hankel matrix holds.
    length : int, optional
        Lags of the impulse response (:func:`moli.impulse_response`).
    feedthrough : bool, default False
    x0 : {"zero", "estimate"}, default "zero"
        Initial state of the validation simulations.
    center : bool, default True
        Identify deviations from the estimation record's means (the model's operating point).

    Returns
    -------
    KernelResult

    Examples
    --------
    >>> import numpy as np, moli
    >>> data = moli.example_data(N=300, seed=1)
    >>> result = moli.identify_kernel(data, nmax=6)
    >>> result.model.n == result.selected.order <= 6
    True
    """
    with limited_blas():
        estimation, validation, source = checked_records(data, validation, x0)
        last = order_bound(nmax, data.p)
        fit = impulse_response(estimation, kernel, length, feedthrough=feedthrough, center=center)
        markov = fit.coefficients[int(feedthrough):]
        rows, cols = hankel_blocks(markov.shape[0])
        top = min(last, rows * data.p, cols * data.m)
        warn_order_cap(nmax, top, f"the Hankel matrix of the impulse response's {markov.shape[0]} lags has no more "
                                  "independent rows or columns; give a longer length= or record")
        D = fit.coefficients[0] if feedthrough else np.zeros((data.p, data.m))
        # the operating point the fit removed
        means = (estimation.y.mean(axis=0), estimation.u.mean(axis=0)) if center else (None, None)
        path, selected = validated_orders(
            ((order, StateSpaceModel(*hankel_realization(markov, order), D, data.Ts, output_names=data.output_names,
                                     input_names=data.input_names, y_offset=means[0], u_offset=means[1]))
             for order in range(1, top + 1)), validation, x0)
        chosen = path[selected].model
        directions = [_direction(fit, j, column) for j, factor in enumerate(fit.cov_factors) for column in factor.T]
        info = {"method": "kernel", "kernel": kernel, "impulse_lags": len(fit.lags),
                "validation_vaf": path[selected].vaf.tolist(),
                **({} if data.time_unit is None else {"time_unit": data.time_unit})}
        model = StateSpaceModel(chosen.A, chosen.B, chosen.C, chosen.D, data.Ts, output_names=data.output_names,
                                input_names=data.input_names, y_offset=means[0], u_offset=means[1], info=info,
                                cov_factor=realization_covariance(markov, chosen.n, directions, feedthrough))
        path[selected] = KernelStep(path[selected].order, model, path[selected].vaf)
        return KernelResult(model, fit, path, selected, estimation=estimation, validation=validation,
                            validation_source=source)


def _direction(fit: ImpulseResponse, j: int, column: np.ndarray) -> np.ndarray:
    """One column of output ``j``'s posterior factor as a perturbation of the whole impulse response."""
    n, p, m = fit.coefficients.shape
    direction = np.zeros((n, p, m))
    direction[:, j, :] = column.reshape(m, n).T
    return direction
