"""The covariance of a MOLI model's matrices, from its least-squares problems on a record.

:func:`estimate_covariance` rebuilds each output's problem with the model's structure
and filters, takes the sandwich covariance of the parameters and propagates it to
``A, B, C, D`` (:mod:`moli.method.least_squares.sandwich`, docs/uncertainty.md).
"""

from __future__ import annotations

import copy

import numpy as np

from ...data.iodata import IOData
from ...errors import DataError
from ...models.statespace import StateSpaceModel
from ...validation.prediction import deviations
from ..least_squares.sandwich import matrix_covariance
from ..least_squares.estimation import output_regressors, regressor_blocks
from ..least_squares.row_blocks import WHOLE_ROWS
from ..structure.rows import check_regression_rows, regression_rows, row_breaks, row_count
from ..structure.filters import divisors
from ..refinement.observer_form import ObserverForm, observer_form
from ..closed_loop.reference_projection import FirstStage
from ..refinement.levenberg_marquardt import is_refined
from .refined_covariance import refined_covariance
from ...numerics.blas_threads import limited_blas

__all__ = ["estimate_covariance"]


def _feedthrough_rows(model: StateSpaceModel, form: ObserverForm) -> np.ndarray:
    """Which outputs' problems have the current inputs as regressors.

    The regression's feedthrough is ``F = (I - G) D`` (docs/method.md §8). An output
    whose feedthrough was left out by the F-test has ``F_j = 0``, recomputed here up to
    the round-off of ``D = (I - G)^-1 F``: rows within that bound were not estimated.
    """
    F = model.D - form.G @ model.D
    bound = 64 * np.finfo(float).eps * (np.abs(model.D) + np.abs(form.G) @ np.abs(model.D))
    return np.any(np.abs(F) > bound, axis=1)


def estimate_covariance(model: StateSpaceModel, data: IOData, first_stage: FirstStage | None = None) -> StateSpaceModel:
    """A copy of ``model`` with the covariance of its matrices from its least-squares problems on ``data``.

    Each output's problem is rebuilt with the model's structure and filters, its
    parameters' joint covariance is the sandwich with a Newey-West long-run
    covariance of the scores, and it is propagated to ``A, B, C, D`` through the
    observer-form realization (first order). The copy carries it as
    ``cov_factor`` (``Cov(vec[A, B, C, D]) = cov_factor @ cov_factor.T``), which
    :meth:`StateSpaceModel.magnitude_bands`, :meth:`StateSpaceModel.step_bands` and
    :func:`moli.simulation_bands` use; ``info["covariance"]`` records how it was
    computed (docs/uncertainty.md). :func:`moli.identify` and :func:`moli.estimate`
    attach it already.

    Parameters
    ----------
    model : StateSpaceModel
        A MOLI model: it carries ``indices`` and its filters (``alpha`` or
        ``divisors``). For a refined model (:func:`moli.method.refinement.levenberg_marquardt.is_refined`)
        the problem is its output-error refinement's, and the
        covariance is the Gauss-Newton sandwich at its own parameters
        (:func:`moli.method.uncertainty.refined_covariance.refined_covariance`).
    data : IOData
        The estimation record, raw or centred (offsets handled as :func:`moli.compare`);
        each segment's problems start from zero filter states, and the long-run
        covariance takes no lag across a boundary.

    first_stage : FirstStage, optional
        For a model of the two-stage closed-loop method: its first stage on ``data``'s
        samples; the covariance is then the refinement's sandwich with the FIR's
        estimation error included (docs/closed_loop.md §3).

    Returns
    -------
    StateSpaceModel
        A new model; ``model`` is not modified.

    Raises
    ------
    DataError
        ``model`` is not a MOLI model, ``data`` does not match it or is too short, or a
        problem is rank deficient.

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(400)
    >>> y = moli.StateSpaceModel([[0.8]], [[0.5]], [[1.0]]).simulate(u) + 0.1 * rng.standard_normal((400, 1))
    >>> model = moli.estimate(moli.IOData(y, u), [1], moli.filter_polynomial(1.0, 1.0, [1]))
    >>> again = estimate_covariance(model, moli.IOData(y, u))
    >>> again.cov_factor.shape      # rows: A, B, C, D entries; columns: the 2 parameters
    (4, 2)
    >>> bool(np.allclose(again.cov_factor, model.cov_factor))
    True
    """
    with limited_blas():
        if not isinstance(model, StateSpaceModel):
            raise DataError(f"model must be a StateSpaceModel, got {type(model).__name__}")
        if model.indices is None or (model.alpha is None and model.divisors is None):
            raise DataError("the covariance needs a MOLI model that carries its indices and filter polynomials "
                            "(from moli.estimate or moli.identify)")
        if first_stage is not None and not isinstance(first_stage, FirstStage):
            raise DataError(f"first_stage must be None or the FirstStage of a two-stage closed-loop fit, "
                            f"got {type(first_stage).__name__}")
        u, y = deviations(model, data)
        if is_refined(model) or first_stage is not None:
            factor, record = refined_covariance(model, data, first_stage)
            attached = copy.deepcopy(model)
            attached.cov_factor, attached.info["covariance"] = factor, record
            return attached
        form = observer_form(model)
        through = _feedthrough_rows(model, form)
        check_regression_rows(data.bounds, model.indices, model.m, bool(through.any()))
        filters = model.divisors if model.divisors is not None else divisors(model.alpha, model.indices)
        z, starts, skip = np.concatenate([y, u], axis=1), data.segment_starts, max(model.indices)
        if row_count(data.bounds, skip) <= WHOLE_ROWS:
            problems = (output_regressors(z, model.indices, filters, through, starts),
                        regression_rows(z, skip, starts)[:, : model.p])
        else:                       # a long record: its problems in row blocks, in bounded memory
            problems = lambda: regressor_blocks(z, model.indices, filters, through, starts)  # noqa: E731
        factor, record = matrix_covariance(problems, model.indices, model.C, model.D, through, form.D,
                                           breaks=row_breaks(starts, z.shape[0], skip))
        attached = copy.deepcopy(model)
        attached.cov_factor, attached.info["covariance"] = factor, record
        return attached
