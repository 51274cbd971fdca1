"""MOLI-ZOFT: structure lists, filters, least squares, filter tuning, structure search.

Stage packages in the order the data meet them (docs/method.md, whose sections map onto
them): :mod:`.structure` (lists of observability indices, the filter α, regression rows),
:mod:`.least_squares` (one list's problems, the shared factors, realization),
:mod:`.tuning` (the criterion J, the barycenter search, per-output filters),
:mod:`.options` (:class:`IdentifyOptions`), :mod:`.search` (the greedy path),
:mod:`.refinement` (output error, the direct method's prediction error),
:mod:`.closed_loop`, :mod:`.uncertainty` (covariance, noise model), :mod:`.selection`
(order rules, the guarded refinement), :mod:`.continuous` (the same method in continuous
time, docs/continuous.md), :mod:`.frequency` (models from measured frequency responses,
docs/frequency.md) and :mod:`.pipeline` (the steps of :func:`identify`, in
:mod:`.identification`). Many records at once: :mod:`moli.fleets`.
"""

from .continuous import ContinuousResult, ContinuousStep
from .frequency import FrequencyResult, FrequencyStep
from .kernel.impulse import ImpulseResponse, impulse_response
from .kernel.kernel_model import KernelResult, identify_kernel
from .kernel.arx import RegularizedArx, regularized_arx
from .kernel.arx_model import KernelArxResult, identify_kernel_arx
from .least_squares.estimation import estimate
from .least_squares.realization import realize
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
    "ContinuousResult", "ContinuousStep", "FrequencyResult", "FrequencyStep", "prediction_error_refine",
    "ReferenceProjection", "fit_projection", "ImpulseResponse", "impulse_response", "KernelResult", "identify_kernel",
    "RegularizedArx", "regularized_arx", "KernelArxResult", "identify_kernel_arx",
]
