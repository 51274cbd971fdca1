"""How good is a model: VAF, NRMSE fit, simulation and k-step prediction on a record, residual tests, bands."""

from .bands import simulation_bands
from .comparison import Comparison, compare, estimate_initial_state
from .metrics import cost_j, nrmse_fit, vaf
from .prediction import predict
from .residuals import ResidualAnalysis, residual_analysis

__all__ = [
    "Comparison", "compare", "estimate_initial_state", "cost_j", "nrmse_fit", "vaf", "predict",
    "ResidualAnalysis", "residual_analysis", "simulation_bands",
]
