"""A simulated twin rotor (Feedback Instruments TRMS 33-949S) that stands in for the lab rig.

The model is the manufacturer's phenomenological one: rigid-body pitch and yaw,
first-order rotor lags, quadratic rotor characteristics, gravity, viscous and
Coulomb friction, a gyroscopic term and a lead/lag main-rotor -> yaw reaction.
States ``x = (psi, dpsi, phi, dphi, tau1, tau2, M_R)``: pitch angle and rate, yaw
angle and rate, main and tail rotor momenta, reaction torque. Inputs are the two
rotor voltages, saturated at +-2.5 V; outputs are the two angles, read by
quantising encoders.

The default parameters are "Profile B": the manufacturer's values for pitch and
rotors, and a yaw axis with a cable spring (absent from the manufacturer's
model, whose yaw is a pure integrator and drifts by radians in open loop). The
yaw inertia is the mass-based estimate, spring and viscous friction place the yaw
poles at -0.236 +- 0.678j (the pair the CDC 2015 paper identified on the real
rig), yaw Coulomb friction is dropped (with a spring it would create a +-0.4 rad
dead band) and the reaction gain ``kc`` follows the drag/thrust ratio of the
physical model of Tastemirov et al. (2017). ``TwinRotorParameters.manufacturer()``
gives the unmodified table ("Profile A").
"""

from __future__ import annotations

import math
import warnings
from dataclasses import astuple

import numpy as np

from ..data.arguments import real_array
from ..data.iodata import IOData
from ..data.signals import random_binary_signal
from ..models.statespace import StateSpaceModel
from .experiment import experiment
from .twin_rotor_parameters import (
    DEFAULT_QUANTIZATION, INPUT_NAMES, OUTPUT_NAMES, PITCH_LIMITS, YAW_LIMITS, RigLimitWarning,
    TwinRotorError, TwinRotorParameters,
)

__all__ = ["TwinRotor", "identification_experiment"]

class TwinRotor:
    """The twin rotor sampled with a zero-order hold.

    At each sample ``k`` the angles are measured first (``measure``), then the
    input ``u_k`` is held over one period (``step``), so ``y_k`` never depends on
    ``u_k``. Between samples the ODE is integrated by classical Runge-Kutta with a
    fixed step ``Ts / substeps`` (5 ms by default: the fastest linearised pole is
    -1 rad/s and the pitch mode 2.15 rad/s, so the local error is far below the
    encoder's resolution; ``tests/control/test_twin_rotor.py`` checks it against an
    adaptive solver). The discontinuous ``sign(v)`` of Coulomb friction is
    smoothed to ``tanh(v / eps)``.

    Parameters
    ----------
    params : TwinRotorParameters, optional
        Profile B by default.
    Ts : float, default 0.1
        Sampling period, s.
    psi0, phi0 : float, default 0.2, 0.0
        Operating point (rad from the rest position); simulations start at its trim.
    quantization : float, default 2*pi/4096
        Encoder step, rad; 0 disables quantisation.
    noise_std : float, default 0.0
        Standard deviation of white measurement noise added to the quantised angles, rad.
    seed : int, default 0
        Seed of the measurement noise.
    substeps : int, default 20
        Runge-Kutta steps per sampling period.
    eps : float, default 0.01
        Smoothing velocity of the Coulomb terms, rad/s.

    Examples
    --------
    >>> rig = TwinRotor()
    >>> rig.reset()
    >>> rig.measure().round(4)  # the trim pitch 0.2 rad, read by the encoder
    array([0.1994, 0.    ])
    """

    output_names = OUTPUT_NAMES
    input_names = INPUT_NAMES

    def __init__(
        self,
        params: TwinRotorParameters | None = None,
        Ts: float = 0.1,
        psi0: float = 0.2,
        phi0: float = 0.0,
        quantization: float = DEFAULT_QUANTIZATION,
        *,
        noise_std: float = 0.0,
        seed: int = 0,
        substeps: int = 20,
        eps: float = 0.01,
    ) -> None:
        self.params = TwinRotorParameters() if params is None else params
        if not isinstance(self.params, TwinRotorParameters):
            raise TwinRotorError(f"params must be TwinRotorParameters, got {type(params).__name__}")
        for name, value in (("Ts", Ts), ("eps", eps)):
            if not (math.isfinite(value) and value > 0):
                raise TwinRotorError(f"{name} must be positive, got {value!r}")
        for name, value in (("quantization", quantization), ("noise_std", noise_std)):
            if not (math.isfinite(value) and value >= 0):
                raise TwinRotorError(f"{name} must be non-negative, got {value!r}")
        if int(substeps) != substeps or substeps < 1:
            raise TwinRotorError(f"substeps must be a positive integer, got {substeps!r}")
        self.Ts = float(Ts)
        self.quantization = float(quantization)
        self.noise_std = float(noise_std)
        self.seed = seed
        self.substeps = int(substeps)
        self.eps = float(eps)
        self.x_trim, self.u_trim = self.trim(psi0, phi0)
        self.y_trim = self.x_trim[[0, 2]].copy()
        self.reset()

    # -- continuous-time model ------------------------------------------------

    def saturate(self, u: object) -> np.ndarray:
        """Clip the rotor voltages to ``[-u_max, u_max]``."""
        return np.clip(np.asarray(u, dtype=float), -self.params.u_max, self.params.u_max)

    def derivatives(self, x: object, u: object) -> np.ndarray:
        """Right-hand side ``dx/dt`` at state ``x`` and (saturated) input ``u``.

        Parameters
        ----------
        x : array_like, shape (7,)
        u : array_like, shape (2,)

        Returns
        -------
        ndarray, shape (7,)
        """
        uu = self.saturate(u)
        return np.array(self._rhs(tuple(np.asarray(x, dtype=float)), float(uu[0]), float(uu[1])))

    def _rhs(self, x: tuple[float, ...], u1: float, u2: float) -> tuple[float, ...]:
        # Plain floats: the integrator calls this ~10^5 times per experiment.
        (I1, I2, a1, b1, a2, b2, Mg, B1psi, B2psi, B1phi, B2phi, Kgy,
         k1, T11, T10, k2, T21, T20, Tp, T0, kc, K_cab, phi_c, _) = self._p
        psi, dpsi, phi, dphi, tau1, tau2, MR = x
        M1 = a1 * tau1 * tau1 + b1 * tau1
        M2 = a2 * tau2 * tau2 + b2 * tau2
        cos_psi = math.cos(psi)
        ddpsi = (
            M1 - Mg * math.sin(psi) - B1psi * dpsi - B2psi * math.tanh(dpsi / self.eps)
            - Kgy * M1 * dphi * cos_psi
        ) / I1
        ddphi = (
            M2 - B1phi * dphi - B2phi * math.tanh(dphi / self.eps) - MR - K_cab * (phi - phi_c)
        ) / I2
        dtau1 = (k1 * u1 - T10 * tau1) / T11
        dtau2 = (k2 * u2 - T20 * tau2) / T21
        dMR = (kc * (1.0 - T0 * T10 / T11) * tau1 - MR + kc * T0 * k1 * u1 / T11) / Tp
        return (dpsi, ddpsi, dphi, ddphi, dtau1, dtau2, dMR)

    @property
    def _p(self) -> tuple[float, ...]:
        return astuple(self.params)

    def trim(self, psi0: float, phi0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Equilibrium state and input holding the beam at ``(psi0, phi0)``.

        Parameters
        ----------
        psi0, phi0 : float
            Pitch and yaw angles, rad.

        Returns
        -------
        x0 : ndarray, shape (7,)
        u0 : ndarray, shape (2,)

        Raises
        ------
        TwinRotorError
            If no input within the saturation holds that attitude.
        """
        p = self.params
        disc = p.b1**2 + 4 * p.a1 * p.Mg * math.sin(psi0)
        if disc < 0:
            raise TwinRotorError(f"no main-rotor thrust holds pitch {psi0} rad")
        tau1 = (-p.b1 + math.sqrt(disc)) / (2 * p.a1)
        MR = p.kc * tau1
        yaw_torque = MR + p.K_cab * (phi0 - p.phi_c)
        disc = p.b2**2 + 4 * p.a2 * yaw_torque
        if disc < 0:
            raise TwinRotorError(f"no tail-rotor thrust holds yaw {phi0} rad at pitch {psi0} rad")
        tau2 = (-p.b2 + math.sqrt(disc)) / (2 * p.a2)  # the root nearest zero (b2 > 0)
        u0 = np.array([p.T10 * tau1 / p.k1, p.T20 * tau2 / p.k2])
        if np.any(np.abs(u0) > p.u_max):
            raise TwinRotorError(
                f"trim at pitch {psi0}, yaw {phi0} needs inputs {u0} V, beyond +-{p.u_max} V"
            )
        x0 = np.array([psi0, 0.0, phi0, 0.0, tau1, tau2, MR])
        return x0, u0

    def linearize(
        self, x0: object | None = None, u0: object | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Analytic Jacobians of the model without its Coulomb terms.

        Coulomb friction is left out: its smoothed slope ``B2/eps`` is an artefact of
        the smoothing, and the true ``sign`` has no derivative at rest.

        Parameters
        ----------
        x0, u0 : array_like, optional
            Linearisation point; the trim by default.

        Returns
        -------
        A : ndarray, shape (7, 7)
        B : ndarray, shape (7, 2)
        C : ndarray, shape (2, 7)
            Continuous-time ``dx = A x + B u``, ``y = C x`` in deviations.
        """
        x = self.x_trim if x0 is None else np.asarray(x0, dtype=float)
        del u0  # the model is affine in u: the Jacobians do not depend on it
        p = self.params
        psi, _, _, dphi, tau1, tau2, _ = x
        M1 = p.a1 * tau1**2 + p.b1 * tau1
        dM1 = 2 * p.a1 * tau1 + p.b1
        dM2 = 2 * p.a2 * tau2 + p.b2
        c, s = math.cos(psi), math.sin(psi)
        A = np.zeros((7, 7))
        A[0, 1] = A[2, 3] = 1.0
        A[1, 0] = (-p.Mg * c + p.Kgy * M1 * dphi * s) / p.I1
        A[1, 1] = -p.B1psi / p.I1
        A[1, 3] = -p.Kgy * M1 * c / p.I1
        A[1, 4] = dM1 * (1 - p.Kgy * dphi * c) / p.I1
        A[3, 2] = -p.K_cab / p.I2
        A[3, 3] = -p.B1phi / p.I2
        A[3, 5] = dM2 / p.I2
        A[3, 6] = -1.0 / p.I2
        A[4, 4] = -p.T10 / p.T11
        A[5, 5] = -p.T20 / p.T21
        A[6, 4] = p.kc * (1 - p.T0 * p.T10 / p.T11) / p.Tp
        A[6, 6] = -1.0 / p.Tp
        B = np.zeros((7, 2))
        B[4, 0] = p.k1 / p.T11
        B[5, 1] = p.k2 / p.T21
        B[6, 0] = p.kc * p.T0 * p.k1 / (p.T11 * p.Tp)
        C = np.zeros((2, 7))
        C[0, 0] = C[1, 2] = 1.0
        return A, B, C

    def linear_model(self) -> StateSpaceModel:
        """Zero-order-hold discretisation of :meth:`linearize` at the trim.

        Returns
        -------
        StateSpaceModel
            Acts on deviations from the trim, which it stores as ``y_offset`` and
            ``u_offset``.
        """
        A, B, C = self.linearize()
        from scipy.signal import cont2discrete  # slow to import: only when discretizing

        Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, np.zeros((2, 2))), self.Ts, method="zoh")
        return StateSpaceModel(
            Ad, Bd, Cd, Dd, Ts=self.Ts, output_names=OUTPUT_NAMES, input_names=INPUT_NAMES,
            y_offset=self.y_trim, u_offset=self.u_trim, info={"source": "twin rotor linearisation"},
        )

    # -- sampled operation ----------------------------------------------------

    def advance(self, x: object, u: object, duration: float | None = None) -> np.ndarray:
        """State after holding ``u`` for ``duration`` (one period by default), from ``x``.

        Fixed-step RK4 with step ``Ts / substeps`` (the duration is split into a whole
        number of steps no longer than that). Does not touch the rig's own state.
        """
        T = self.Ts if duration is None else float(duration)
        count = max(1, math.ceil(T / (self.Ts / self.substeps) - 1e-9))
        h = T / count
        uu = self.saturate(u)
        u1, u2 = float(uu[0]), float(uu[1])
        state = tuple(float(v) for v in np.asarray(x, dtype=float))
        f = self._rhs
        for _ in range(count):
            k1 = f(state, u1, u2)
            k2 = f(tuple(a + 0.5 * h * b for a, b in zip(state, k1)), u1, u2)
            k3 = f(tuple(a + 0.5 * h * b for a, b in zip(state, k2)), u1, u2)
            k4 = f(tuple(a + h * b for a, b in zip(state, k3)), u1, u2)
            state = tuple(
                a + h / 6.0 * (b1 + 2 * b2 + 2 * b3 + b4)
                for a, b1, b2, b3, b4 in zip(state, k1, k2, k3, k4)
            )
        return np.array(state)

    def reset(self, x0: object | None = None, seed: int | None = None) -> None:
        """Put the rig in state ``x0`` (the trim by default) and reseed its noise.

        Parameters
        ----------
        x0 : array_like, shape (7,), optional
        seed : int, optional
            Noise seed; the constructor's ``seed`` by default.
        """
        state = self.x_trim if x0 is None else real_array("x0", x0, error=TwinRotorError, finite=False).reshape(-1)
        if state.shape != (7,) or not np.all(np.isfinite(state)):
            raise TwinRotorError(f"x0 must be 7 finite numbers, got shape {np.shape(x0)}")
        self.state = state.copy()
        self.rng = np.random.default_rng(self.seed if seed is None else seed)
        self._warned = False

    def measure(self) -> np.ndarray:
        """Encoder readings of pitch and yaw now (quantised, plus optional noise), rad."""
        angles = self.state[[0, 2]]
        if self.quantization > 0:
            angles = self.quantization * np.round(angles / self.quantization)
        if self.noise_std > 0:
            angles = angles + self.noise_std * self.rng.standard_normal(2)
        return angles

    def step(self, u: object) -> None:
        """Hold the voltages ``u`` (saturated) for one period and update the state."""
        uu = np.asarray(u, dtype=float).reshape(-1)
        if uu.shape != (2,) or not np.all(np.isfinite(uu)):
            raise TwinRotorError(f"u must be two finite voltages, got {u!r}")
        self.state = self.advance(self.state, uu)
        self._check_envelope()

    def _check_envelope(self) -> None:
        psi, phi = self.state[0], self.state[2]
        inside = PITCH_LIMITS[0] <= psi <= PITCH_LIMITS[1] and YAW_LIMITS[0] <= phi <= YAW_LIMITS[1]
        if not inside and not self._warned:
            self._warned = True
            warnings.warn(
                f"twin rotor left its angle envelope (pitch {psi:.3f} rad, yaw {phi:.3f} rad; "
                f"box {PITCH_LIMITS} x {YAW_LIMITS}); a real rig may hit its stops",
                RigLimitWarning,
                stacklevel=3,
            )


def identification_experiment(
    rig: TwinRotor | None = None,
    seed: int = 0,
    duration: float = 60.0,
    mean_switch_time: float = 8.0,
    amplitudes: tuple[float, float] = (0.25, 0.05),
    switch_within: int | None = 150,
) -> IOData:
    """The CDC 2015 twin rotor experiment on the simulated rig.

    Both rotors are driven at once by independent random binary signals around
    the trim input (mean switching time 8 s) for 60 s, starting at the trim. The
    main-rotor amplitude 0.25 V keeps its voltage above 0.3 V (thrust never
    changes sign) and the tail's 0.05 V keeps the yaw swings comparable to the
    pitch swings, as in the paper's Fig. 7.

    Parameters
    ----------
    rig : TwinRotor, optional
        Default: ``TwinRotor()`` (Profile B, pitch trim 0.2 rad, encoder 2*pi/4096).
    seed : int, default 0
        Seed of the excitation and of the measurement noise.
    duration : float, default 60.0
        Seconds.
    mean_switch_time : float, default 8.0
        Seconds.
    amplitudes : (float, float), default (0.25, 0.05)
        Half the distance between the two levels of each input, V.
    switch_within : int or None, default 150
        Each input switches at least once in its first ``switch_within`` samples
        (the estimation window), see :func:`moli.data.signals.random_binary_signal`.

    Returns
    -------
    IOData
        Deviations from the trim (the trim is stored as ``y_offset``/``u_offset``),
        so a model identified without centring starts, like the rig, at rest.

    Examples
    --------
    >>> data = identification_experiment(seed=3, duration=2.0, switch_within=None)
    >>> data.N, data.output_names
    (20, ('pitch', 'yaw'))
    """
    rig = TwinRotor() if rig is None else rig
    amp = np.asarray(amplitudes, dtype=float)
    levels = np.column_stack([rig.u_trim - amp, rig.u_trim + amp])
    N = int(round(duration / rig.Ts))
    u = random_binary_signal(N, mean_switch_time, rig.Ts, levels, seed=seed, switch_within=switch_within)
    return experiment(rig, u, seed=seed).remove_means(rig.y_trim, rig.u_trim)
