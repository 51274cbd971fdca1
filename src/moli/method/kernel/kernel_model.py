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

import warnings
from dataclasses import dataclass

import numpy as np

from ...data.iodata import IOData
from ...errors import DataError, OptionError
from ...models.statespace import StateSpaceModel
from ...validation.comparison import X0_CHOICES, compare, same_period
from ..search.greedy_path import ScoredStep
from ..selection.order_rules import PAIRED_Z, select_by_shares
from ..selection.paired_test import error_shares
from .impulse import ImpulseResponse, impulse_response
from .realization import hankel_blocks, hankel_realization, realization_covariance

__all__ = ["KernelStep", "KernelResult", "identify_kernel"]

# Share of the record held out for the order when no validation record is given, as identify's.
HOLDOUT_FRACTION = 0.3


@dataclass
class KernelStep(ScoredStep):
    """One order's realization and its validation VAF per output (scored as a path step is)."""

    order: int
    model: StateSpaceModel
    vaf: np.ndarray


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
        lines = [f"kernel model: {self.impulse.kernel} prior, impulse response of {len(self.impulse.lags)} lags, "
                 f"validation {self.validation_source}", "  order  mean VAF  stable"]
        lines += [f"{'*' if i == self.selected_index else ' '} {step.order:5d}  {step.mean_vaf:8.2f}  {step.stable}"
                  for i, step in enumerate(self.path)]
        return "\n".join(lines)


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
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    if x0 not in X0_CHOICES:
        raise OptionError(f"x0 must be one of {X0_CHOICES}, got {x0!r}")
    if validation is None:
        estimation, validation = data.split(1.0 - HOLDOUT_FRACTION)
        source = f"held out: last {HOLDOUT_FRACTION:.0%} of the record"
    else:
        if not isinstance(validation, IOData) or (validation.p, validation.m) != (data.p, data.m) \
                or not same_period(validation.Ts, data.Ts):
            raise DataError("validation must be an IOData of the same channels and sampling period as data")
        estimation, source = data, "given"
    fit = impulse_response(estimation, kernel, length, feedthrough=feedthrough, center=center)
    markov = fit.coefficients[int(feedthrough):]
    rows, cols = hankel_blocks(markov.shape[0])
    top = min(nmax if nmax is not None else max(10, data.p + 4), rows * data.p, cols * data.m)
    if isinstance(top, bool) or top < 1:
        raise OptionError(f"nmax must be a positive integer, got {nmax!r}")
    D = fit.coefficients[0] if feedthrough else np.zeros((data.p, data.m))
    # the operating point the fit removed
    means = (estimation.y.mean(axis=0), estimation.u.mean(axis=0)) if center else (None, None)
    path, shares = [], []
    for order in range(1, top + 1):
        A, B, C = hankel_realization(markov, order)
        model = StateSpaceModel(A, B, C, D, data.Ts, output_names=data.output_names, input_names=data.input_names,
                                y_offset=means[0], u_offset=means[1])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)      # an unstable realization diverges
            simulated = compare(model, validation, x0)
            shares.append(error_shares(validation.y, simulated.yhat))
        path.append(KernelStep(order, model, simulated.vaf))
    selected = select_by_shares(path, shares.__getitem__, PAIRED_Z)
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
