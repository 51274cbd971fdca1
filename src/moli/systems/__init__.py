"""Simulated plants to run identification and control experiments on."""

from .experiment import SampledPlant, experiment
from .plant import example_data, example_plant
from .twin_rotor import TwinRotor, identification_experiment
from .twin_rotor_parameters import (
    RigLimitWarning, TwinRotorError, TwinRotorParameters,
)

__all__ = [
    "SampledPlant", "experiment", "example_data", "example_plant",
    "RigLimitWarning", "TwinRotor", "TwinRotorError", "TwinRotorParameters", "identification_experiment",
]
