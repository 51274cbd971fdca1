"""moli: multivariable linear system identification with MOLI-ZOFT."""

from ._version import __version__
from .data import IOData
from .errors import (
    DataError, FilterError, HoldoutWarning, IllConditionedWarning, ModelFileError, MoliError,
    OptionError, StructureError, UnstableModelWarning,
)
from .estimation import estimate
from .filters import divisor, divisors, filter_polynomial
from .metrics import cost_j, nrmse_fit, vaf
from .model import StateSpaceModel, load_model
from .validation import Comparison, compare
