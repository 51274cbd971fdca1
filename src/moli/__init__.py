"""moli: multivariable linear system identification with MOLI-ZOFT.

The package follows the pipeline (docs/architecture.md): :mod:`moli.data` (records
in) → :mod:`moli.method` (structure, filters, least squares, filter tuning, structure
search) → :mod:`moli.models` (the state-space model) → :mod:`moli.validation` →
:mod:`moli.streaming`, :mod:`moli.fleets` (many records on many workers),
:mod:`moli.systems`, :mod:`moli.control` and :mod:`moli.app` (command line, reports). The names below are the public API (docs/api.md).

``import moli`` loads only numpy and the error classes; each name's module is
imported the first time the name is used, so the command line and small scripts start
fast.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._version import __version__
from .errors import (
    ClosedLoopWarning, DataError, DataQualityWarning, FilterError, IllConditionedWarning,
    IrregularSamplingWarning, ModelFileError, MoliError, NoFitWarning, OptionError, OrderBoundWarning,
    SamplingPeriodWarning, ShortValidationWarning, StructureError, UnstableModelWarning, WeakReferenceWarning,
    FrequencyConventionWarning,
)

# public name -> the subpackage that defines it
_HOMES = {
    "IOData": "data", "merge": "data", "read_data": "data", "from_dataframe": "data", "to_dataframe": "data", "load_daisy": "data", "list_daisy": "data",
    "DatasetChecksumError": "data", "DatasetUnavailableError": "data",
    "random_binary_signal": "data", "check_data": "data",
    "FrequencyData": "data", "read_frequency_data": "data", "frequency_response": "data",
    "flag_outliers": "data", "remove_outliers": "data", "OutlierReport": "data",
    "StateSpaceModel": "models", "ContinuousModel": "models", "load_model": "models", "modes": "models", "Mode": "models",
    "Comparison": "validation", "compare": "validation", "cost_j": "validation",
    "nrmse_fit": "validation", "vaf": "validation", "predict": "validation",
    "residual_analysis": "validation", "ResidualAnalysis": "validation",
    "EmpiricalResponse": "validation", "empirical_frequency_response": "validation",
    "spectral_frequency_data": "validation",
    "estimate_delays": "validation", "FeedbackCheck": "validation", "feedback_check": "validation", "simulation_bands": "validation",
    "estimate": "method", "divisor": "method", "divisors": "method",
    "filter_polynomial": "method", "IdentificationResult": "method", "identify": "method",
    "IdentifyOptions": "method", "PathStep": "method", "estimate_noise_model": "method",
    "estimate_covariance": "method", "ContinuousResult": "method", "FrequencyResult": "method",
    "impulse_response": "method", "ImpulseResponse": "method", "identify_kernel": "method",
    "KernelResult": "method", "identify_kernel_arx": "method", "KernelArxResult": "method",
    "identify_many": "fleets", "FleetResult": "fleets", "estimate_chunks": "fleets",
    "RecursiveMoli": "streaming", "ChunkedEstimator": "streaming", "FilterBank": "streaming",
    "example_data": "systems", "example_plant": "systems", "experiment": "systems",
}
_SUBPACKAGES = ("data", "models", "validation", "method", "streaming", "fleets", "systems", "control", "app")

__all__ = [
    "__version__", "MoliError", "DataError", "FilterError", "IllConditionedWarning",
    "ModelFileError", "OptionError", "StructureError", "UnstableModelWarning", "DataQualityWarning",
    "OrderBoundWarning", "ClosedLoopWarning", "IrregularSamplingWarning", "SamplingPeriodWarning",
    "ShortValidationWarning", "WeakReferenceWarning", "NoFitWarning", "FrequencyConventionWarning",
    *_HOMES, *_SUBPACKAGES,
]

if TYPE_CHECKING:  # what the lazy names are, for type checkers and IDEs
    from . import app, control, data, fleets, method, models, streaming, systems, validation
    from .data import (
        DatasetChecksumError, DatasetUnavailableError, FrequencyData, IOData, OutlierReport, flag_outliers,
        frequency_response, from_dataframe, read_frequency_data, list_daisy, load_daisy, merge, random_binary_signal, read_data,
        remove_outliers, to_dataframe,
    )
    from .fleets import FleetResult, estimate_chunks, identify_many
    from .method import (
        ContinuousResult, FrequencyResult, IdentificationResult, IdentifyOptions, ImpulseResponse, PathStep, divisor,
        divisors, estimate, estimate_covariance, estimate_noise_model, filter_polynomial, identify, identify_kernel,
        impulse_response, KernelResult, identify_kernel_arx, KernelArxResult,
    )
    from .models import ContinuousModel, Mode, StateSpaceModel, load_model, modes
    from .streaming import ChunkedEstimator, FilterBank, RecursiveMoli
    from .systems import example_data, example_plant, experiment
    from .validation import (
        Comparison, EmpiricalResponse, FeedbackCheck, ResidualAnalysis, compare, cost_j,
        empirical_frequency_response, estimate_delays, feedback_check, nrmse_fit, predict,
        residual_analysis, simulation_bands, spectral_frequency_data, vaf,
    )


def __getattr__(name: str) -> Any:
    if name in _SUBPACKAGES:
        return importlib.import_module(f".{name}", __name__)
    if name not in _HOMES:
        raise AttributeError(f"module 'moli' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
