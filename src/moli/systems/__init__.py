"""Simulated plants to run identification and control experiments on."""

from .twin_rotor import RigLimitWarning, TwinRotor, TwinRotorError, TwinRotorParameters

__all__ = ["RigLimitWarning", "TwinRotor", "TwinRotorError", "TwinRotorParameters"]
