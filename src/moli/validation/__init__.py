"""How good is a model: VAF, NRMSE fit and the simulation comparison on a record; what the
data say on their own: the empirical frequency response, dead times and feedback."""

from .comparison import Comparison, compare, estimate_initial_state
from .delays import estimate_delays
from .feedback import FeedbackCheck, feedback_check
from .frequency import EmpiricalResponse, empirical_frequency_response
from .metrics import cost_j, nrmse_fit, vaf

__all__ = [
    "Comparison", "compare", "estimate_initial_state", "cost_j", "nrmse_fit", "vaf",
    "EmpiricalResponse", "empirical_frequency_response", "estimate_delays", "FeedbackCheck",
    "feedback_check",
]
