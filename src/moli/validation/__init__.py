"""How good is a model: VAF, NRMSE fit and the simulation comparison on a record."""

from .comparison import Comparison, compare, estimate_initial_state
from .metrics import cost_j, nrmse_fit, vaf

__all__ = ["Comparison", "compare", "estimate_initial_state", "cost_j", "nrmse_fit", "vaf"]
