"""Simulated plants to run identification and control experiments on."""

from .experiment import SampledPlant, experiment
from .noisy_plant import LinearPlant, pi_loop_gains, pi_loop_plant
from .plant import example_data, example_plant
from .twin_rotor import TwinRotor, identification_experiment
from .twin_rotor_parameters import (
    RigLimitWarning, TwinRotorError, TwinRotorParameters,
)

__all__ = [
    "SampledPlant", "experiment", "LinearPlant", "pi_loop_plant", "pi_loop_gains", "example_data", "example_plant",
    "RigLimitWarning", "TwinRotor", "TwinRotorError", "TwinRotorParameters", "identification_experiment",
]
