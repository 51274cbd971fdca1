"""MOLI-ZOFT: structure lists, filters, least squares, filter tuning, structure search.

The stages in the order the data meet them (docs/method.md): :mod:`.structure` (lists
of observability indices), :mod:`.filters` (the filter α and its divisors),
:mod:`.estimation` (least squares for a fixed structure, realization),
:mod:`.regression` and :mod:`.scoring` (the shared factors and the criterion J),
:mod:`.tuning` (the barycenter filter search), :mod:`.output_filters`,
:mod:`.search` (greedy path, order rule), :mod:`.refinement` (on the parameters of
:mod:`.observer_form`), :mod:`.prediction_error` and :mod:`.reference_projection` (the
direct and two-stage methods for closed-loop records), :mod:`.noise_model`
(Kalman gain from the residuals), :mod:`.covariance` and :mod:`.uncertainty` (the
covariance of the parameters and of the matrices), :mod:`.options` and :mod:`.identification` (the
one-call entry point). :mod:`.continuous` is the same method in continuous time
(docs/continuous.md). Many records at once: :mod:`moli.fleets`.
"""

from .continuous import ContinuousResult, ContinuousStep
from .least_squares.estimation import estimate, realize
from .structure.filters import divisor, divisors, filter_polynomial
from .identification import IdentificationResult, identify
from .uncertainty.noise_model import estimate_noise_model
from .options import IdentifyOptions
from .refinement.prediction_error import prediction_error_refine
from .closed_loop.reference_projection import ReferenceProjection, fit_projection
from .refinement.levenberg_marquardt import RefineResult, refine, refine_each
from .search.greedy_path import PathStep, exhaustive
from .tuning.barycenter import TuningResult, default_omega, tune_filter
from .uncertainty.matrix_covariance import estimate_covariance

__all__ = [
    "estimate", "realize", "divisor", "divisors", "filter_polynomial", "IdentificationResult",
    "identify", "IdentifyOptions", "estimate_noise_model", "RefineResult", "refine", "refine_each", "PathStep", "exhaustive",
    "TuningResult", "default_omega", "tune_filter", "estimate_covariance",
    "ContinuousResult", "ContinuousStep", "prediction_error_refine", "ReferenceProjection", "fit_projection",
]
