"""The identified state-space model."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .._version import __version__
from ..data.arguments import integer, period, real_array
from ..data.atomic_files import write_json
from ..data.iodata import as_signal
from ..errors import DataError, UnstableModelWarning
from .bands import magnitude_bands, step_bands
from .checks import Dimensions, channel_names, checked_divisors, covariance, indices_of, matrix, vector
from .delays import check_delays, delay_states, shift_inputs
from .frequency import check_omega, frequency_response
from .interop import to_control
from .simulation import free_response, simulate_batch

__all__ = ["StateSpaceModel"]

FILE_FORMAT = "moli-model"


class StateSpaceModel(Dimensions):
    """Discrete-time model ``x[k+1] = A x[k] + B u[k]``, ``y[k] = C x[k] + D u[k]``.

    The model acts on deviations from the operating point ``(u_offset, y_offset)``
    that was removed from the estimation data (zero when none was removed).

    Parameters
    ----------
    A, B, C : array_like
        Shapes (n, n), (n, m), (p, n).
    D : array_like, optional
        Feedthrough, shape (p, m); zero by default (MOLI models have none).
    Ts : float, default 1.0
        Sampling period.
    output_names, input_names : sequence of str, optional
    indices : sequence of int, optional
        List of observability indices the model was estimated with.
    alpha : array_like, optional
        Filter polynomial the model was estimated with (one filter shared by the
        outputs: output ``j``'s divisor is the divisor of degree ``indices[j]``).
    y_offset, u_offset : array_like, optional
        Operating point removed from the data before estimation.
    info : dict, optional
        JSON-serialisable facts about the estimation (filter parameters, J, ...).
    divisors : sequence of array_like, optional
        Per-output filter polynomials when each output had a filter of its own
        (``divisors[j]`` monic, stable, of degree ``indices[j]``); needs ``indices``.
    K : array_like, optional
        Noise model: Kalman gain of the innovations form ``x[k+1] = A x[k] + B u[k] +
        K e[k]``, ``y[k] = C x[k] + D u[k] + e[k]``, shape (n, p) (docs/noise_model.md).
        None (the default): no noise model.
    noise_cov : array_like, optional
        Covariance of the innovations ``e``, shape (p, p), symmetric positive
        semidefinite; given together with ``K``.
    cov_factor : array_like, optional
        Uncertainty of the matrices: ``Cov(vec) = cov_factor @ cov_factor.T`` for
        ``vec = [A.ravel(), B.ravel(), C.ravel(), D.ravel()]``, shape
        (n n + n m + p n + p m, r) (docs/uncertainty.md). :func:`moli.identify` and
        :func:`moli.estimate` attach it; None (the default): no covariance, no bands.

    Examples
    --------
    >>> m = StateSpaceModel([[0.5]], [[1.0]], [[1.0]])
    >>> m.simulate([1.0, 0.0, 0.0]).ravel()
    array([0. , 1. , 0.5])
    """

    is_continuous = False   # the protocol every model answers (moli.models.protocol)

    def __init__(
        self,
        A: object,
        B: object,
        C: object,
        D: object | None = None,
        Ts: float = 1.0,
        *,
        output_names: Sequence[str] | None = None,
        input_names: Sequence[str] | None = None,
        indices: Sequence[int] | None = None,
        alpha: Sequence[float] | None = None,
        y_offset: object | None = None,
        u_offset: object | None = None,
        info: dict[str, Any] | None = None,
        divisors: Sequence[Sequence[float]] | None = None,
        K: object | None = None,
        noise_cov: object | None = None,
        cov_factor: object | None = None,
    ) -> None:
        self.A = matrix("A", A)
        n = self.A.shape[0]
        if self.A.shape != (n, n):
            raise DataError(f"A must be square, got shape {self.A.shape}")
        self.B = matrix("B", B)
        self.C = matrix("C", C)
        if self.B.shape[0] != n or self.C.shape[1] != n:
            raise DataError(f"B needs {n} rows and C {n} columns, got {self.B.shape} and {self.C.shape}")
        p, m = self.C.shape[0], self.B.shape[1]
        self.D = np.zeros((p, m)) if D is None else matrix("D", D, (p, m))
        self.Ts = period(Ts)
        self.output_names = channel_names(output_names, p, "y", "output_names")
        self.input_names = channel_names(input_names, m, "u", "input_names")
        self.indices = indices_of(indices)
        if self.indices is not None and (len(self.indices) != p or sum(self.indices) != self.A.shape[0]):
            raise DataError(f"indices {list(self.indices)} must hold one observability index per output ({p}) "
                            f"summing to the order ({self.A.shape[0]})")
        self.alpha = None if alpha is None else real_array("alpha", alpha, ndim=1)
        self.y_offset, self.u_offset = vector("y_offset", y_offset, p), vector("u_offset", u_offset, m)
        if info is not None and not isinstance(info, dict):
            raise DataError(f"info must be a dict, got {type(info).__name__}")
        self.info = dict(info or {})
        self.divisors = None if divisors is None else checked_divisors(divisors, self.indices, self.p)
        if (K is None) != (noise_cov is None):
            raise DataError("K and noise_cov make the noise model together: give both or neither")
        self.K = None if K is None else matrix("K", K, (n, p))
        self.noise_cov = None if noise_cov is None else covariance(noise_cov, p)
        self.cov_factor = None if cov_factor is None else matrix("cov_factor", cov_factor)
        if self.cov_factor is not None and self.cov_factor.shape[0] != n * n + n * m + p * n + p * m:
            raise DataError(f"cov_factor needs one row per entry of A, B, C and D "
                            f"({n * n + n * m + p * n + p * m}), got {self.cov_factor.shape[0]}")

    def with_matrices(
        self, A: object, B: object, C: object, D: object | None, info: dict[str, Any],
        divisors: Sequence[Sequence[float]] | None,
    ) -> "StateSpaceModel":
        """The same channels, structure and operating point with new matrices and filters.

        ``divisors`` given: per-output filters (``alpha`` dropped); None keeps ``alpha``.
        The copy has no noise model and no covariance: both belong to the matrices
        they were estimated with.
        """
        return StateSpaceModel(
            A, B, C, D, Ts=self.Ts, output_names=self.output_names, input_names=self.input_names,
            indices=self.indices, alpha=self.alpha if divisors is None else None,
            y_offset=self.y_offset, u_offset=self.u_offset, info=info, divisors=divisors,
        ).with_input_delays(self.input_delays)

    def __repr__(self) -> str:
        lists = f", indices={list(self.indices)}" if self.indices else ""
        return f"StateSpaceModel(n={self.n}, p={self.p}, m={self.m}, Ts={self.Ts:g}{lists}, stable={self.is_stable()})"

    def simulate(self, u: object, x0: object | None = None) -> np.ndarray:
        """Simulate the model (deviation variables).

        Parameters
        ----------
        u : array_like, shape (N, m)
            Input deviations, time along axis 0 (1-D accepted when m = 1). With
            :attr:`input_delays`, input ``j`` acts ``input_delays[j]`` samples late
            (zero before the record).
        x0 : array_like, shape (n,), optional
            Initial state; zero by default.

        Returns
        -------
        ndarray, shape (N, p)
        """
        uu = shift_inputs(as_signal("u", u, self.m), self.input_delays)
        if uu.shape[0] == 0:  # no samples in, none out (a stream's empty chunk)
            return np.zeros((0, self.p))
        start = None
        if x0 is not None:
            start = real_array("x0", x0).reshape(-1)
            if start.shape != (self.n,):
                raise DataError(f"x0 must have {self.n} entries, got {np.shape(x0)}")
            start = start[None]
        y = simulate_batch(self.A[None], self.B[None], self.C[None], uu, start)[0]
        return y + uu @ self.D.T

    def simulate_at(self, u: np.ndarray, t: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
        """:meth:`simulate` on one segment of a record; its stamps ``t`` are ``k * Ts`` (checked by the caller)."""
        return self.simulate(u, x0)

    def free_response_at(self, t: np.ndarray, negligible: float | None = None) -> np.ndarray:
        """Outputs ``C A^k e_i`` at the samples ``t`` from each unit initial state, (N, p, n); with
        ``negligible``, cut where they have decayed (:func:`moli.models.simulation.free_response`)."""
        return free_response(self.A, self.C, len(t), negligible)

    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` (discrete time)."""
        return np.linalg.eigvals(self.A)

    def is_stable(self) -> bool:
        """True when every pole lies strictly inside the unit circle."""
        return bool(self.n == 0 or np.max(np.abs(self.poles())) < 1.0)

    def markov(self, count: int) -> np.ndarray:
        """Markov parameters ``D, C B, C A B, ...``: shape (count, p, m), entry k is h_k."""
        out = np.empty((integer("count", count, low=1), self.p, self.m))
        out[0] = self.D
        row = self.C
        for k in range(1, count):
            out[k] = row @ self.B
            row = row @ self.A
        return out

    def magnitude_bands(
        self, omega: object, confidence: float = 0.95, *, method: str = "gauss", samples: int = 1000,
        seed: int = 0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pointwise confidence bands of the gain ``|H(exp(1j omega Ts))|``, shape (len(omega), p, m) each.

        Needs the covariance of the matrices (``cov_factor``, attached by
        :func:`moli.identify` and :func:`moli.estimate`). See
        :func:`moli.models.bands.magnitude_bands` for the parameters.

        Examples
        --------
        >>> m = StateSpaceModel([[0.5]], [[1.0]], [[1.0]], cov_factor=[[0.0], [0.1], [0.0], [0.0]])
        >>> lower, upper = m.magnitude_bands([0.0])     # gain 1 / (1 - 0.5), sd 0.1 / 0.5
        >>> np.round([lower[0, 0, 0], upper[0, 0, 0]], 3)
        array([1.608, 2.392])
        """
        return magnitude_bands(self, omega, confidence, method=method, samples=samples, seed=seed)

    def step_bands(
        self, n_steps: int, confidence: float = 0.95, *, method: str = "gauss", samples: int = 1000,
        seed: int = 0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pointwise confidence bands of the unit-step responses, shape (n_steps, p, m) each.

        Entry ``[k, i, j]`` bounds output ``i`` at sample ``k`` after a unit step on
        input ``j`` at sample 0 (zero initial state, deviations). Needs ``cov_factor``;
        see :func:`moli.models.bands.step_bands` for the parameters.

        Examples
        --------
        >>> m = StateSpaceModel([[0.5]], [[1.0]], [[1.0]], cov_factor=[[0.0], [0.1], [0.0], [0.0]])
        >>> lower, upper = m.step_bands(3)              # responses 0, b, 1.5 b with b = 1 +- 0.1
        >>> np.round(upper[:, 0, 0] - lower[:, 0, 0], 3)
        array([0.   , 0.392, 0.588])
        """
        return step_bands(self, n_steps, confidence, method=method, samples=samples, seed=seed)

    def warn_if_unstable(self, stacklevel: int = 2) -> None:
        """Issue an :class:`UnstableModelWarning` if the model is unstable."""
        if not self.is_stable():
            warnings.warn(f"identified model (indices {list(self.indices or [])}) is unstable: largest pole "
                          f"modulus {np.max(np.abs(self.poles())):.4g}", UnstableModelWarning, stacklevel=stacklevel + 1)

    def to_control(self, noise: bool = False, continuous: bool = False):  # -> control.StateSpace
        """Convert to a python-control ``StateSpace`` with the channel names.

        Requires the optional dependency ``control`` (``pip install control``).
        Input delays become states (:meth:`delays_as_states`).

        Parameters
        ----------
        noise : bool, default False
            False: the deterministic part (inputs ``u``). True: the innovations form,
            with inputs ``[u, e]`` (``e`` named ``e@<output>``, covariance
            ``noise_cov``), ``B = [B, K]`` and ``D = [D, I]``; needs a noise model.
        continuous : bool, default False
            Convert :meth:`to_continuous` (zero-order hold) instead; deterministic part only.
        """
        return to_control(self, noise, continuous)

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable description of the model."""
        return {
            "format": FILE_FORMAT,
            "version": __version__,
            "A": self.A.tolist(), "B": self.B.tolist(), "C": self.C.tolist(), "D": self.D.tolist(),
            "Ts": self.Ts,
            "output_names": list(self.output_names), "input_names": list(self.input_names),
            "indices": None if self.indices is None else list(self.indices),
            "alpha": None if self.alpha is None else self.alpha.tolist(),
            "divisors": None if self.divisors is None else [d.tolist() for d in self.divisors],
            "y_offset": self.y_offset.tolist(), "u_offset": self.u_offset.tolist(),
            "K": None if self.K is None else self.K.tolist(),
            "noise_cov": None if self.noise_cov is None else self.noise_cov.tolist(),
            "cov_factor": None if self.cov_factor is None else self.cov_factor.tolist(),
            "info": self.info, "input_delays": list(self.input_delays),
        }

    def save(self, path: str | Path) -> None:
        """Write the model to a JSON file (read it back with :func:`moli.load_model`)."""
        # whole or not at all: a failed or interrupted save keeps the previous file
        write_json(path, self.to_dict(), "the model")

    # Delays, frequency response and continuous time (docs/diagnostics.md). The delays
    # are set by with_input_delays on a copy, so the constructor keeps its signature.
    _input_delays: tuple[int, ...] | None = None

    @property
    def input_delays(self) -> tuple[int, ...]:
        """Dead time of each input in samples (zeros unless set by :meth:`with_input_delays`)."""
        return self._input_delays if self._input_delays is not None else (0,) * self.m

    def with_input_delays(self, delays: int | Sequence[int]) -> "StateSpaceModel":
        """A copy whose input ``j`` acts ``delays[j]`` samples late (one int: every input).

        Examples
        --------
        >>> m = StateSpaceModel([[0.5]], [[1.0]], [[1.0]]).with_input_delays([2])
        >>> m.input_delays, m.simulate([1.0, 0.0, 0.0, 0.0]).ravel()
        ((2,), array([0., 0., 0., 1.]))
        """
        checked = check_delays(delays, self.m)
        # a copy of every attribute, not a constructor call: nothing the model carries is lost
        copy = StateSpaceModel.__new__(StateSpaceModel)
        copy.__dict__.update(
            {key: value.copy() if isinstance(value, np.ndarray) else value
             for key, value in self.__dict__.items()},
            info=dict(self.info), _input_delays=checked,
        )
        return copy

    def delays_as_states(self) -> "StateSpaceModel":
        """The same input-output model with its delays as shift-register states, no delays.

        The model itself when it has none; the copy has no structure (indices, filters).
        """
        if not any(self.input_delays):
            return self
        A, B, C, D = delay_states(self.A, self.B, self.C, self.D, self.input_delays)
        return StateSpaceModel(A, B, C, D, self.Ts, output_names=self.output_names, input_names=self.input_names,
                               y_offset=self.y_offset, u_offset=self.u_offset, info=dict(self.info))

    def frequency_response(self, omega: object) -> np.ndarray:
        """Frequency response ``C (zI - A)^-1 B + D`` at ``z = exp(1j omega Ts)``, with the delays.

        Parameters
        ----------
        omega : array_like, shape (F,)
            Frequencies in rad per time unit of ``Ts`` (Nyquist: ``pi / Ts``).

        Returns
        -------
        ndarray of complex, shape (F, p, m)
            Entry ``[f, i, j]``: from input ``j`` to output ``i`` at ``omega[f]``.

        Examples
        --------
        >>> m = StateSpaceModel([[0.5]], [[1.0]], [[1.0]])
        >>> m.frequency_response([0.0])     # static gain 1 / (1 - 0.5)
        array([[[2.+0.j]]])
        """
        w = check_omega(omega)
        delays = self.Ts * np.asarray(self.input_delays, dtype=float)
        return frequency_response(self.A, self.B, self.C, self.D, np.exp(1j * w * self.Ts), w, delays=delays)

    def to_continuous(self, method: str = "zoh"):  # -> ContinuousModel
        """The continuous-time model this model samples, by zero-order hold or Tustin.

        Parameters
        ----------
        method : {"zoh", "tustin"}
            "zoh": matrix logarithm of ``[[A, B], [0, I]]``, divided by ``Ts``; needs
            no pole at ``z = 0`` or on the negative real axis. "tustin": inverse of
            ``s = (2/Ts)(z-1)/(z+1)``; needs no pole at ``z = -1``. Otherwise a
            :class:`DataError` names the poles and the ways forward (the other
            method, keeping the discrete model, faster sampling or a lower order).

        Returns
        -------
        moli.models.ContinuousModel
            With the channel names, offsets, and delays in time units.

        Examples
        --------
        >>> round(float(StateSpaceModel([[0.5]], [[1.0]], [[1.0]], Ts=0.1).to_continuous().A[0, 0]), 6)
        -6.931472
        """
        from .continuous import to_continuous

        return to_continuous(self, method)

    @classmethod
    def from_continuous(
        cls, A: object, B: object, C: object, D: object | None = None, Ts: float = 1.0,
        method: str = "zoh", *, output_names: Sequence[str] | None = None,
        input_names: Sequence[str] | None = None, y_offset: object | None = None,
        u_offset: object | None = None,
    ) -> "StateSpaceModel":
        """Sample the continuous model ``x' = A x + B u``, ``y = C x + D u`` at period ``Ts``.

        ``method="zoh"``: ``[[Ad, Bd], [0, I]] = expm([[A, B], [0, 0]] Ts)`` (inputs held
        over each period); ``"tustin"``: the bilinear map. Inverse of :meth:`to_continuous`.

        Examples
        --------
        >>> m = StateSpaceModel.from_continuous([[-1.0]], [[1.0]], [[1.0]], Ts=0.5)
        >>> round(float(m.A[0, 0]), 6), round(float(m.B[0, 0]), 6)     # exp(-0.5), 1 - exp(-0.5)
        (0.606531, 0.393469)
        """
        from .continuous import discretize

        checked = cls(A, B, C, D, Ts)  # the constructor's shape, finiteness and Ts checks
        Ad, Bd, Cd, Dd = discretize(checked.A, checked.B, checked.C, checked.D, checked.Ts, method)
        return cls(Ad, Bd, Cd, Dd, checked.Ts, output_names=output_names, input_names=input_names,
                   y_offset=y_offset, u_offset=u_offset)
