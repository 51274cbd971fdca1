"""Physical parameters, names and limits of the simulated twin rotor (see :mod:`.twin_rotor`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from ..errors import MoliError

__all__ = [
    "OUTPUT_NAMES", "INPUT_NAMES", "PITCH_LIMITS", "YAW_LIMITS", "DEFAULT_QUANTIZATION",
    "TwinRotorError", "RigLimitWarning", "TwinRotorParameters",
]

OUTPUT_NAMES = ("pitch", "yaw")
INPUT_NAMES = ("main", "tail")
# Angle box (rad from the rest position) of the Rotondo et al. MPC example; no
# mechanical stops are documented, so leaving it is flagged, never clamped.
PITCH_LIMITS = (-0.5, 1.0)
YAW_LIMITS = (-1.7, 1.2)
# 1024-line encoder read in quadrature.
DEFAULT_QUANTIZATION = 2 * math.pi / 4096


class TwinRotorError(MoliError):
    """Invalid twin rotor settings (parameters, operating point, inputs)."""


class RigLimitWarning(UserWarning):
    """A simulated experiment left the rig's documented angle envelope."""


@dataclass(frozen=True)
class TwinRotorParameters:
    """Physical parameters of the twin rotor (SI units; defaults: Profile B).

    Attributes
    ----------
    I1, I2 : float
        Pitch and yaw moments of inertia, kg m^2.
    a1, b1, a2, b2 : float
        Rotor characteristics ``M = a tau^2 + b tau`` (main, tail), N m.
    Mg : float
        Gravity moment, N m.
    B1psi, B2psi, B1phi, B2phi : float
        Viscous (N m s/rad) and Coulomb (N m) friction of pitch and yaw.
    Kgy : float
        Gyroscopic coefficient, s/rad.
    k1, T11, T10, k2, T21, T20 : float
        Rotor lags ``tau = k / (T_1 s + T_0) u`` (main, tail).
    Tp, T0, kc : float
        Reaction torque ``M_R = kc (T0 s + 1) / (Tp s + 1) tau1``.
    K_cab, phi_c : float
        Cable stiffness (N m/rad) and neutral yaw angle (rad).
    u_max : float
        Input saturation, V (symmetric).
    """

    I1: float = 6.8e-2
    I2: float = 5.0e-2
    a1: float = 0.0135
    b1: float = 0.0924
    a2: float = 0.02
    b2: float = 0.09
    Mg: float = 0.32
    B1psi: float = 6e-3
    B2psi: float = 1e-3
    B1phi: float = 0.0236
    B2phi: float = 0.0
    Kgy: float = 0.05
    k1: float = 1.1
    T11: float = 1.1
    T10: float = 1.0
    k2: float = 0.8
    T21: float = 1.0
    T20: float = 1.0
    Tp: float = 2.0
    T0: float = 3.5
    kc: float = -0.017
    K_cab: float = 0.0258
    phi_c: float = 0.0
    u_max: float = 2.5

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not math.isfinite(value):
                raise TwinRotorError(f"parameter {f.name} must be finite, got {value!r}")
        positive = ("I1", "I2", "Mg", "k1", "T11", "T10", "k2", "T21", "T20", "Tp", "u_max")
        for name in positive:
            if getattr(self, name) <= 0:
                raise TwinRotorError(f"parameter {name} must be positive, got {getattr(self, name)!r}")

    @classmethod
    def manufacturer(cls) -> "TwinRotorParameters":
        """The manufacturer's table ("Profile A"): no cable, yaw is an integrator.

        Examples
        --------
        >>> TwinRotorParameters.manufacturer().K_cab
        0.0
        """
        return cls(I2=2e-2, B1phi=0.1, B2phi=1e-2, kc=-0.2, K_cab=0.0)
