"""Continuous-time MOLI: ``dx/dt = A x + B u`` from sampled records, regular or not.

The discrete pipeline (structure, filters, least squares, tuning, greedy search,
order rule) carried to the s-plane, with the filters' states propagated exactly
between the record's time stamps (docs/continuous.md). Reached through
``moli.identify(..., time="continuous")``.
"""

from .identification import ContinuousResult, identify_continuous
from .search import ContinuousStep

__all__ = ["ContinuousResult", "ContinuousStep", "identify_continuous"]
