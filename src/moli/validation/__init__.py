"""How good is a model: VAF, NRMSE fit, simulation and k-step prediction on a record, residual
tests, confidence bands; what the data say on their own: the empirical frequency response,
dead times and feedback."""

from .bands import simulation_bands
from .comparison import Comparison, compare, estimate_initial_state
from .delays import estimate_delays
from .feedback import FeedbackCheck, feedback_check
from .frequency import EmpiricalResponse, empirical_frequency_response, spectral_frequency_data
from .metrics import cost_j, nrmse_fit, vaf
from .prediction import predict
from .residuals import ResidualAnalysis, residual_analysis

__all__ = [
    "Comparison", "compare", "estimate_initial_state", "cost_j", "nrmse_fit", "vaf", "predict",
    "ResidualAnalysis", "residual_analysis", "EmpiricalResponse", "empirical_frequency_response",
    "estimate_delays", "FeedbackCheck", "feedback_check", "simulation_bands", "spectral_frequency_data",
]
