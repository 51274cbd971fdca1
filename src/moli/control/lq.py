"""LQ servo with integral action and an observer, designed on an identified model.

The design follows the CDC 2015 twin rotor experiment: state feedback with integral
action, weights from Bryson's rule, a Luenberger observer by pole placement. Gains
come from python-control (``dlqr``, ``place``). Controllers run in absolute units:
they subtract the model's operating point from the measurements and add it back to
the inputs. They respect input bounds and rate limits, with anti-windup per channel
(:mod:`moli.control.limits`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..errors import ControlDesignError
from ..models.statespace import StateSpaceModel
from .limits import input_bounds, integrating, integrator_pairing, rate_bounds

__all__ = [
    "ControlDesignError", "bryson", "continuous_poles", "sector_poles", "ServoController",
    "servo_weights", "lq_servo",
]


def _control():
    try:
        import control
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("moli.control needs python-control: pip install control") from exc
    return control



def _positive_vector(name: str, values: object, size: int) -> np.ndarray:
    array = np.array(values, dtype=float).reshape(-1)
    if array.size == 1:
        array = np.full(size, array[0])
    if array.shape != (size,) or not np.all(np.isfinite(array)) or np.any(array <= 0):
        raise ControlDesignError(f"{name} must be {size} positive numbers, got {values!r}")
    return array



def bryson(max_values: object) -> np.ndarray:
    """Bryson's rule: the diagonal weight ``1 / max_i^2`` for each variable.

    Parameters
    ----------
    max_values : array_like, shape (k,)
        Largest acceptable deviation of each variable.

    Returns
    -------
    ndarray, shape (k, k)

    Examples
    --------
    >>> bryson([0.5, 2.0])
    array([[4.  , 0.  ],
           [0.  , 0.25]])
    """
    array = np.array(max_values, dtype=float).reshape(-1)
    return np.diag(1.0 / _positive_vector("max_values", array, array.size) ** 2)



def continuous_poles(z: object, Ts: float) -> np.ndarray:
    """Map discrete-time poles to continuous time, ``s = log(z) / Ts``.

    Examples
    --------
    >>> continuous_poles([np.exp(-0.1)], 0.1)
    array([-1.+0.j])
    """
    return np.log(np.asarray(z, dtype=complex)) / Ts



def sector_poles(n: int, radius: float, half_angle: float = np.pi / 4) -> np.ndarray:
    """``n`` distinct continuous-time poles of modulus ``radius`` (rad/s) in a sector.

    The angles from the negative real axis are evenly spread over
    ``[-half_angle, half_angle]``, so every pole has damping ratio at least
    ``cos(half_angle)`` (0.71 by default), like the paper's observer poles
    (-8.62 +- 9.4j, -11.45 +- 7.19j, -16.2: damping 0.68 to 1).

    Examples
    --------
    >>> sector_poles(3, 2.0).round(3)
    array([-1.414-1.414j, -1.414+1.414j, -2.   +0.j   ])
    """
    if int(n) != n or n < 1 or not (np.isfinite(radius) and radius > 0) or not 0 < half_angle < np.pi / 2:
        raise ControlDesignError(f"need n >= 1, radius > 0, 0 < half_angle < pi/2; got {n}, {radius}, {half_angle}")
    n = int(n)
    angles = np.linspace(-half_angle, half_angle, n) if n > 1 else np.zeros(1)
    # Build the upper half and mirror it, so conjugates are exact (pole placement
    # rejects pairs that differ by round-off).
    upper = -radius * np.exp(-1j * angles[: n // 2])
    real = [-float(radius)] if n % 2 else []
    return np.concatenate([upper, upper.conj(), np.array(real, dtype=complex)])



@dataclass
class ServoController:
    """Discrete LQ servo with integral action, a current observer and actuator limits.

    At each sample, with ``y`` and ``r`` the measured outputs and set-points
    (deviations from the model's operating point):

    - observer update ``xh = xb + M (y - C xb)``;
    - control ``u_free = -K xh - Ki xi``, clipped to ``u_limits`` and to
      ``rate_limits * Ts`` around the previous input;
    - integrator ``xi <- xi + Ts (y - r)``, except for the integrators whose
      paired input is limited and would be pushed further past its limit
      (conditional integration per channel, see :mod:`moli.control.limits`);
    - prediction ``xb <- A xh + B u`` with the input actually applied.

    Build it with :func:`lq_servo`.

    Attributes
    ----------
    model : StateSpaceModel
    K : ndarray, shape (m, n)
    Ki : ndarray, shape (m, p)
    M : ndarray, shape (n, p)
        Observer gain; the estimation error evolves by ``(I - M C) A``.
    Q, R : ndarray
        LQ weights of the augmented state ``(x, xi)`` and of the inputs.
    u_limits : ndarray, shape (m, 2)
        Absolute input bounds ``(low, high)``.
    rate_limits : ndarray, shape (m,)
        Largest input change per second (``inf``: none). The input before the
        first sample is taken as the model's ``u_offset``.
    pairing : ndarray of int, shape (p,)
        Input paired with each output's integrator (see
        :func:`~moli.control.limits.integrator_pairing`).
    """

    model: StateSpaceModel
    K: np.ndarray
    Ki: np.ndarray
    M: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    u_limits: np.ndarray
    rate_limits: np.ndarray | None = None
    pairing: np.ndarray | None = None
    _xb: np.ndarray = field(init=False, repr=False)
    _xi: np.ndarray = field(init=False, repr=False)
    _u: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        m = self.model.m
        self.u_limits = input_bounds(self.u_limits, m)
        self.rate_limits = rate_bounds(self.rate_limits, m)
        self.pairing = integrator_pairing(self.Ki, self.pairing)
        self.reset()

    def reset(self) -> None:
        """Zero the observer and integrator states; the last input is the operating point."""
        self._xb = np.zeros(self.model.n)
        self._xi = np.zeros(self.model.p)
        self._u = np.clip(self.model.u_offset, self.u_limits[:, 0], self.u_limits[:, 1])

    @property
    def integrator(self) -> np.ndarray:
        """Integrated output errors ``xi`` (output units times seconds), a copy."""
        return self._xi.copy()

    def update(self, y: np.ndarray, r: np.ndarray) -> np.ndarray:
        """Absolute input for measured outputs ``y`` and set-points ``r`` (absolute)."""
        mdl = self.model
        dy = np.asarray(y, float) - mdl.y_offset
        dr = np.asarray(r, float) - mdl.y_offset
        xh = self._xb + self.M @ (dy - mdl.C @ self._xb)
        u_free = mdl.u_offset - self.K @ xh - self.Ki @ self._xi
        move = self.rate_limits * mdl.Ts
        low = np.maximum(self.u_limits[:, 0], self._u - move)
        high = np.minimum(self.u_limits[:, 1], self._u + move)
        u = np.clip(u_free, low, high)
        error = dy - dr
        self._xi = self._xi + mdl.Ts * error * integrating(self.Ki, self.pairing, error, u_free - u)
        self._xb = mdl.A @ xh + mdl.B @ (u - mdl.u_offset)
        self._u = u
        return u

    def augmented(self) -> tuple[np.ndarray, np.ndarray]:
        """Matrices ``(Aa, Ba)`` of the model with the output integrators appended."""
        return _augment(self.model)

    def closed_loop_poles(self) -> np.ndarray:
        """Discrete poles of the state-feedback loop ``Aa - Ba [K, Ki]``."""
        Aa, Ba = self.augmented()
        return np.linalg.eigvals(Aa - Ba @ np.hstack([self.K, self.Ki]))

    def observer_poles(self) -> np.ndarray:
        """Discrete poles of the estimation error, eigenvalues of ``A - M C A``."""
        A, C = self.model.A, self.model.C
        return np.linalg.eigvals(A - self.M @ C @ A)

    def pole_table(self) -> dict[str, np.ndarray]:
        """Continuous-time poles (rad/s) of model, closed loop and observer (paper's Table I).

        By the separation principle the loop closed through the observer has
        the union of the closed-loop and observer poles.
        """
        Ts = self.model.Ts
        table = {
            "model": self.model.poles(),
            "closed loop": self.closed_loop_poles(),
            "observer": self.observer_poles(),
        }
        return {name: _sorted(continuous_poles(z, Ts)) for name, z in table.items()}



def _sorted(poles: np.ndarray) -> np.ndarray:
    return poles[np.lexsort((poles.imag, -poles.real))]



def _augment(model: StateSpaceModel) -> tuple[np.ndarray, np.ndarray]:
    n, p, m = model.n, model.p, model.m
    Aa = np.block([[model.A, np.zeros((n, p))], [model.Ts * model.C, np.eye(p)]])
    Ba = np.vstack([model.B, np.zeros((p, m))])
    return Aa, Ba



def servo_weights(
    model: StateSpaceModel, y_max: object, integral_max: object, u_max: object
) -> tuple[np.ndarray, np.ndarray]:
    """Bryson weights for :func:`lq_servo`.

    The state enters through the outputs it produces (``C' Qy C``), so the weights
    mean the same whatever basis the identified state has.

    Parameters
    ----------
    model : StateSpaceModel
    y_max : array_like, shape (p,)
        Acceptable output deviations.
    integral_max : array_like, shape (p,)
        Acceptable integrated errors (output units times seconds).
    u_max : array_like, shape (m,)
        Acceptable input deviations.

    Returns
    -------
    Q : ndarray, shape (n + p, n + p)
    R : ndarray, shape (m, m)
    """
    Qy = bryson(_positive_vector("y_max", y_max, model.p))
    Qi = bryson(_positive_vector("integral_max", integral_max, model.p))
    R = bryson(_positive_vector("u_max", u_max, model.m))
    Q = np.zeros((model.n + model.p, model.n + model.p))
    Qx = model.C.T @ Qy @ model.C
    # Symmetric in exact arithmetic; python-control rejects round-off asymmetry.
    Q[: model.n, : model.n] = 0.5 * (Qx + Qx.T)
    Q[model.n :, model.n :] = Qi
    return Q, R



def lq_servo(
    model: StateSpaceModel,
    Q: np.ndarray,
    R: np.ndarray,
    observer_poles: Sequence[complex] | None = None,
    observer_bandwidth: float = 12.0,
    u_limits: object = (-2.5, 2.5),
    *,
    rate_limits: object = None,
    pairing: Sequence[int] | None = None,
) -> ServoController:
    """Design an LQ servo (integral action) and a Luenberger observer for ``model``.

    Parameters
    ----------
    model : StateSpaceModel
        Discrete-time model (deviation variables); must have no feedthrough.
    Q : ndarray, shape (n + p, n + p)
        Weight of the state and the output integrators (see :func:`servo_weights`).
    R : ndarray, shape (m, m)
        Input weight.
    observer_poles : sequence of complex, optional
        Continuous-time observer poles (rad/s), ``n`` of them, closed under
        conjugation, as in the paper's Table I; mapped by ``z = exp(s Ts)``.
    observer_bandwidth : float, default 12.0
        If ``observer_poles`` is not given: :func:`sector_poles` of this radius (rad/s).
        The default is the magnitude of the paper's observer poles (12.7-16.2 rad/s),
        several times faster than the closed loop and below the Nyquist frequency
        of Ts = 0.1 s (31 rad/s).
    u_limits : array_like, shape (2,) or (m, 2), default (-2.5, 2.5)
        Absolute input bounds ``(low, high)``, once for all inputs or once per
        input (the default is the twin rotor's +-2.5 V); ``inf`` leaves a side open.
    rate_limits : float or array_like, shape (m,), optional
        Largest change of each input per second (input units per second); none
        by default.
    pairing : sequence of int, shape (p,), optional
        Input paired with each output's integrator for the anti-windup: while
        that input is at a limit, the integrator stops if it would push the input
        further. By default from the relative gain array of the integral gain
        (:func:`~moli.control.limits.integrator_pairing`).

    Returns
    -------
    ServoController

    Examples
    --------
    >>> model = StateSpaceModel([[0.9]], [[0.1]], [[1.0]], Ts=0.1)
    >>> Q, R = servo_weights(model, y_max=[0.1], integral_max=[0.1], u_max=[1.0])
    >>> ctrl = lq_servo(model, Q, R, observer_poles=[-5.0])
    >>> bool(np.all(np.abs(ctrl.closed_loop_poles()) < 1))
    True
    >>> continuous_poles(ctrl.observer_poles(), 0.1).real.round(6)
    array([-5.])
    """
    control = _control()
    n, p, m = model.n, model.p, model.m
    if np.any(model.D != 0):
        raise ControlDesignError("lq_servo needs a model without feedthrough (D = 0)")
    Q = np.asarray(Q, dtype=float)
    R = np.asarray(R, dtype=float)
    if Q.shape != (n + p, n + p) or R.shape != (m, m):
        raise ControlDesignError(
            f"Q must be ({n + p}, {n + p}) and R ({m}, {m}); got {Q.shape} and {R.shape}"
        )
    if observer_poles is None:
        s_poles = sector_poles(n, float(observer_bandwidth))
    else:
        s_poles = np.asarray(observer_poles, dtype=complex).reshape(-1)
    if s_poles.shape != (n,) or np.any(s_poles.real >= 0):
        raise ControlDesignError(f"need {n} observer poles in the open left half plane, got {s_poles}")
    limits = input_bounds(u_limits, m)
    rates = rate_bounds(rate_limits, m)
    if pairing is not None:
        integrator_pairing(np.ones((m, p)), pairing)  # indices checked before the design
    Aa, Ba = _augment(model)
    try:
        gain, _, _ = control.dlqr(Aa, Ba, Q, R)
        # Current estimator: the error obeys e <- (I - M C) A e, whose eigenvalues
        # are those of A' - (C A)' M', a pole-placement problem in the dual form.
        # The robust (YT) algorithm warns when its conditioning refinement stops
        # early; the placement itself is exact, and is checked below instead.
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            M = control.place(model.A.T, (model.C @ model.A).T, np.exp(s_poles * model.Ts)).T
    except (ValueError, np.linalg.LinAlgError, control.ControlArgument) as exc:
        raise ControlDesignError(f"controller design failed: {exc}") from exc
    placed = np.sort_complex(np.linalg.eigvals(model.A - M @ model.C @ model.A))
    wanted = np.sort_complex(np.exp(s_poles * model.Ts))
    if not np.allclose(placed, wanted, atol=1e-6):
        raise ControlDesignError(f"observer poles could not be placed: got {placed}, wanted {wanted}")
    return ServoController(
        model=model, K=gain[:, :n], Ki=gain[:, n:], M=M, Q=Q, R=R, u_limits=limits,
        rate_limits=rates, pairing=pairing,
    )

