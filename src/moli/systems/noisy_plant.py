"""A linear model run sample by sample with additive output noise, for closed-loop records.

:class:`LinearPlant` wraps a :class:`~moli.StateSpaceModel` in the
:class:`~moli.systems.SampledPlant` protocol, so that :func:`moli.control.closed_loop`
and :func:`moli.systems.experiment` drive it like the twin rotor, and a closed-loop
record of any linear plant has a known truth. :func:`pi_loop_plant` and
:func:`pi_loop_gains` are the 2x2 plant and PI loops of the closed-loop benchmark.
"""

from __future__ import annotations

import numpy as np

from ..data.arguments import integer, real_array, real_number
from ..errors import DataError, wrong_type
from ..models.statespace import StateSpaceModel

__all__ = ["LinearPlant", "pi_loop_plant", "pi_loop_gains"]


class LinearPlant:
    """A discrete-time linear plant whose measured outputs carry additive noise.

    ``x[k+1] = A x[k] + B (u[k] - u_offset)`` from ``x[0] = 0`` (the operating point),
    and the measurement ``y[k] = C x[k] + y_offset + v[k]``. Each output's noise is a
    stationary first-order autoregression ``v[k] = a v[k-1] + sqrt(1 - a^2) sd w[k]``
    with ``w`` standard normal and ``v[0] ~ N(0, sd^2)``: white for ``a = 0``, and of
    standard deviation ``sd`` at every sample for any ``a``. The outputs' noises are
    independent of one another.

    At sample ``k`` the outputs are measured first (``measure`` may be called any
    number of times and returns the same values), then ``step(u)`` holds ``u`` over
    the period and draws the next noise sample.

    Parameters
    ----------
    model : StateSpaceModel
        Discrete-time and strictly proper (``D = 0``: the output is measured before
        the input is applied); input delays are kept as shift-register states.
    noise_sd : float or array_like, shape (p,)
        Standard deviation of each output's noise (one number: all outputs), >= 0.
    noise_pole : float, default 0.0
        The autoregression's pole ``a``, in (-1, 1).
    seed : int, optional
        Seed of the noise; :meth:`reset` reuses it unless given another. None: fresh
        entropy at each reset (not reproducible).

    Raises
    ------
    DataError
        A model that is not a strictly proper StateSpaceModel, a negative or
        non-finite ``noise_sd`` or one with the wrong number of entries, a
        ``noise_pole`` outside (-1, 1), a negative ``seed``.

    Examples
    --------
    >>> from moli import StateSpaceModel
    >>> plant = LinearPlant(StateSpaceModel([[0.5]], [[1.0]], [[1.0]]), noise_sd=0.0)
    >>> plant.reset()
    >>> plant.step([1.0]); plant.step([1.0])
    >>> plant.measure()
    array([1.5])
    """

    def __init__(self, model: StateSpaceModel, noise_sd: object, noise_pole: float = 0.0,
                 seed: int | None = None) -> None:
        if not isinstance(model, StateSpaceModel):
            raise wrong_type(DataError)(f"model must be a StateSpaceModel, got {type(model).__name__}")
        if np.any(model.D != 0):
            raise DataError(
                "model must be strictly proper (D = 0): the plant is measured before its input "
                "is applied, so an output cannot depend on the same sample's input"
            )
        self.model = model.delays_as_states()
        sd = real_array("noise_sd", noise_sd)
        if sd.ndim > 1 or sd.size not in (1, model.p):
            raise DataError(f"noise_sd must be one number or {model.p} (one per output), got shape {sd.shape}")
        if np.any(sd < 0):
            raise DataError(f"noise_sd must be >= 0, got {sd.tolist()}")
        self.noise_sd = np.broadcast_to(sd.reshape(-1), (model.p,)).copy()
        self.noise_pole = real_number("noise_pole", noise_pole, low=-1.0, low_open=True)
        if self.noise_pole >= 1.0:
            raise DataError(f"noise_pole must be in (-1, 1) (a stationary noise), got {noise_pole!r}")
        self.seed = None if seed is None else integer("seed", seed, low=0)
        self.Ts = model.Ts
        self.output_names = model.output_names
        self.input_names = model.input_names
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        """Return to the operating point and restart the noise.

        Parameters
        ----------
        seed : int, optional
            Noise seed; the constructor's ``seed`` by default.
        """
        chosen = self.seed if seed is None else integer("seed", seed, low=0)
        self._rng = np.random.default_rng(chosen)
        self._state = np.zeros(self.model.n)
        # v[0] from the stationary distribution, so the noise's variance never changes
        self._noise = self.noise_sd * self._rng.standard_normal(self.model.p)

    def measure(self) -> np.ndarray:
        """The outputs now, in absolute units (model output, operating point and noise)."""
        return self.model.C @ self._state + self.model.y_offset + self._noise

    def step(self, u: object) -> None:
        """Hold the absolute input ``u`` (shape (m,)) for one period."""
        uu = real_array("u", u).reshape(-1)
        if uu.shape != (self.model.m,):
            raise DataError(f"u must have {self.model.m} entries (one per input), got shape {np.shape(u)}")
        self._state = self.model.A @ self._state + self.model.B @ (uu - self.model.u_offset)
        a = self.noise_pole
        innovation = np.sqrt(1.0 - a * a) * self.noise_sd * self._rng.standard_normal(self.model.p)
        self._noise = a * self._noise + innovation


def pi_loop_plant() -> StateSpaceModel:
    """The 2x2 plant of the closed-loop benchmark: two coupled first-order channels, Ts = 1.

    ``x1[k+1] = 0.9 x1 + 0.1 u1 + 0.03 u2``, ``x2[k+1] = 0.85 x2 + 0.02 u1 + 0.15 u2``,
    ``y = x``: poles 0.9 and 0.85, static gains ``[[1, 0.3], [0.133, 1]]``.

    Returns
    -------
    StateSpaceModel

    Examples
    --------
    >>> pi_loop_plant().frequency_response([0.0])[0].real.round(3)
    array([[1.   , 0.3  ],
           [0.133, 1.   ]])
    """
    return StateSpaceModel(
        [[0.9, 0.0], [0.0, 0.85]], [[0.1, 0.03], [0.02, 0.15]], np.eye(2), Ts=1.0,
        output_names=("y1", "y2"), input_names=("u1", "u2"),
    )


def pi_loop_gains() -> tuple[tuple[float, float], tuple[float, float]]:
    """PI gains ``(kp, ki)`` of the benchmark's two loops (y1 from u1, y2 from u2).

    Each loop alone, with ``u[k] = kp e[k] + ki sum_{j<k} e[j]`` (the discrete PI of
    :class:`moli.control.DecentralizedPID` with ``Ts = 1``), has the characteristic
    polynomial ``z^2 - (1 + a - b kp) z + a - b kp + b ki`` for the channel
    ``b / (z - a)``. The gains put both roots at 0.8: critically damped, a time
    constant of 4.5 samples against the open loop's 9.5 (0.9) and 6.2 (0.85), so the
    loops act well inside the record's set-point holds and the feedback shapes the
    inputs. With the couplings (0.03 and 0.02) the four closed-loop poles are
    0.71, 0.83 and 0.83 +- 0.05j (damping ratio 0.96).

    Returns
    -------
    ((kp1, ki1), (kp2, ki2))

    Examples
    --------
    >>> pi_loop_gains()
    ((3.0, 0.4), (1.6666666666666667, 0.26666666666666666))
    """
    # 1 + a - b kp = 1.6 and a - b kp + b ki = 0.64 for (a, b) = (0.9, 0.1), (0.85, 0.15)
    return (3.0, 0.4), (5.0 / 3.0, 4.0 / 15.0)
