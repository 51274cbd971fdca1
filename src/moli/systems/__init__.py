"""Simulated plants to run identification and control experiments on."""

from .twin_rotor import (
    RigLimitWarning, TwinRotor, TwinRotorError, TwinRotorParameters, identification_experiment,
)

__all__ = [
    "RigLimitWarning", "TwinRotor", "TwinRotorError", "TwinRotorParameters", "identification_experiment",
]
