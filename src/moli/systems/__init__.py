"""Simulated plants to run identification and control experiments on."""

from .plant import example_data, example_plant
from .twin_rotor import (
    RigLimitWarning, TwinRotor, TwinRotorError, TwinRotorParameters, identification_experiment,
)

__all__ = [
    "example_data", "example_plant",
    "RigLimitWarning", "TwinRotor", "TwinRotorError", "TwinRotorParameters", "identification_experiment",
]
