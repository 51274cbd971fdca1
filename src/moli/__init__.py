"""moli: multivariable linear system identification with MOLI-ZOFT."""

from ._version import __version__
from .data import IOData
from .errors import (
    DataError, FilterError, IllConditionedWarning, ModelFileError, MoliError,
    OptionError, StructureError, UnstableModelWarning,
)
from .estimation import estimate
from .filters import divisor, divisors, filter_polynomial
from .metrics import cost_j, nrmse_fit, vaf
from .model import StateSpaceModel, load_model
from .validation import Comparison, compare
from .identify import IdentificationResult, identify
from .selection import PathStep
from .systems.plant import example_data, example_plant
from .experiment import experiment
from .signals import random_binary_signal
from .recursive import RecursiveMoli
from .chunked import ChunkedEstimator
from .filter_bank import FilterBank
from .datasets import DatasetChecksumError, DatasetUnavailableError, list_daisy, load_daisy
from . import control, datasets, signals, systems, tuning
