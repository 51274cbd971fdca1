"""Continuous-time models: from a sampled model and back (zero-order hold or Tustin).

A :class:`ContinuousModel` answers what every moli model answers (:mod:`moli.models.protocol`):
simulation on a record's stamps from a given initial state, free responses, poles,
frequency response, bands; its ``Ts`` is None.

A sampled model becomes a :class:`ContinuousModel`, a small class of its own rather
than a flag on :class:`~moli.models.statespace.StateSpaceModel`: simulation, the
filters, structure indices and the refinement of that class are all discrete time,
and a continuous model has none of them (docs/diagnostics.md §2).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..data.arguments import real_array
from ..data.display import angular_unit
from ..data.atomic_files import write_json
from ..errors import DataError, OptionError
from .bands import magnitude_bands, step_bands
from .checks import Dimensions, matrix, stored_names, time_delays, vector
from .frequency import check_omega, frequency_response
from .propagation import propagate
from .sampling import CONVERSION_METHODS, continuous_matrices, discretize
from .statespace import FILE_FORMAT, StateSpaceModel

__all__ = ["ContinuousModel", "CONVERSION_METHODS", "HOLDS", "to_continuous", "discretize"]

# Inter-sample assumptions of the input: held from each sample to the next, or linear.
HOLDS = ("zoh", "foh")


@dataclass(frozen=True, eq=False)
class ContinuousModel(Dimensions):
    """Continuous-time model ``x' = A x + B u(t - tau)``, ``y = C x + D u(t - tau)``.

    Built by :meth:`StateSpaceModel.to_continuous`, or identified directly by
    ``moli.identify(..., time="continuous")`` (docs/continuous.md); acts on deviations
    from the operating point ``(u_offset, y_offset)``.

    Attributes
    ----------
    A, B, C, D : ndarray
        Shapes (n, n), (n, m), (p, n), (p, m).
    output_names, input_names : tuple of str
    y_offset, u_offset : ndarray
    input_delays : tuple of float
        Dead time ``tau_j`` of each input in time units (the sampled model's delay in
        samples times its ``Ts``).
    cov_factor : ndarray, shape (n*n + n*m + p*n + p*m, r), optional
        ``F`` with ``cov(vec[A, B, C, D]) = F F'`` (an identified model carries it; the
        gain and frequency-response bands of :mod:`moli.models.bands` use it).
    input_hold : {"zoh", "foh"}, default "zoh"
        The inputs between samples when the model is simulated on a record (by
        :func:`moli.compare` and the bands): held or linear, as it was identified.
    info : dict
        JSON-serialisable facts about the estimation, as :attr:`StateSpaceModel.info`
        (``moli fit --continuous`` writes the options, warnings and input file there).
    Ts : None
        A continuous model has no sampling period (a :class:`StateSpaceModel`'s ``Ts``).
    K : None
        No noise model: k-step prediction is not defined in continuous time.

    Examples
    --------
    >>> import numpy as np
    >>> sampled = StateSpaceModel([[np.exp(-0.5)]], [[1 - np.exp(-0.5)]], [[1.0]], Ts=0.5)
    >>> model = sampled.to_continuous()
    >>> np.round(model.A, 12), np.round(model.B, 12)
    (array([[-1.]]), array([[1.]]))
    >>> np.allclose(model.to_discrete(0.5).A, sampled.A)
    True
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    output_names: tuple[str, ...]
    input_names: tuple[str, ...]
    y_offset: np.ndarray
    u_offset: np.ndarray
    input_delays: tuple[float, ...]
    cov_factor: np.ndarray | None = None
    input_hold: str = "zoh"
    info: dict[str, Any] = field(default_factory=dict)

    is_continuous = True
    Ts = None
    K = None

    def __post_init__(self) -> None:
        n, m, p = self.A.shape[0], self.B.shape[1], self.C.shape[0]
        shapes = {"A": (n, n), "B": (n, m), "C": (p, n), "D": (p, m)}
        for name, shape in shapes.items():
            if getattr(self, name).shape != shape:
                raise DataError(f"{name} must have shape {shape}, got {getattr(self, name).shape}")
        if (len(self.output_names), len(self.input_names), len(self.input_delays)) != (p, m, m):
            raise DataError(f"need {p} output names, {m} input names and {m} input delays")
        if self.cov_factor is not None:
            rows = n * n + n * m + p * n + p * m
            factor = matrix("cov_factor", self.cov_factor)
            if factor.shape[0] != rows:
                raise DataError(f"cov_factor must have {rows} rows (vec of A, B, C, D), got {factor.shape[0]}")
            object.__setattr__(self, "cov_factor", factor)
        if self.input_hold not in HOLDS:
            raise DataError(f"input_hold must be one of {HOLDS}, got {self.input_hold!r}")
        if not isinstance(self.info, dict):
            raise DataError(f"info must be a dict, got {type(self.info).__name__}")

    def __repr__(self) -> str:
        return f"ContinuousModel(n={self.n}, p={self.p}, m={self.m}, stable={self.is_stable()})"

    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` (continuous time, rad per time unit)."""
        return np.linalg.eigvals(self.A)

    def is_stable(self) -> bool:
        """True when every pole has a negative real part."""
        return bool(self.n == 0 or np.max(self.poles().real) < 0.0)

    def simulate(self, u: object, t: object = None, hold: str = "zoh", x0: object | None = None) -> np.ndarray:
        """Output deviations at the stamps ``t`` for the input deviations ``u``.

        Exact for the stated inter-sample behaviour of the input (docs/continuous.md §2).

        Parameters
        ----------
        u : array_like, shape (N, m)
            Input deviations at the stamps (1-D accepted when m = 1).
        t : array_like, shape (N,)
            Strictly increasing time stamps, any spacing.
        hold : {"zoh", "foh"}, default "zoh"
            The input between stamps: held at each sample, or linear.
        x0 : array_like, shape (n,), optional
            State at ``t[0]``; zero by default.

        Returns
        -------
        ndarray, shape (N, p)

        Examples
        --------
        >>> model = ContinuousModel(np.array([[-1.0]]), np.array([[1.0]]), np.array([[1.0]]),
        ...                         np.zeros((1, 1)), ("y1",), ("u1",), np.zeros(1), np.zeros(1), (0.0,))
        >>> y = model.simulate(np.ones(3), [0.0, 1.0, 3.0])
        >>> np.allclose(y[:, 0], 1 - np.exp(-np.array([0.0, 1.0, 3.0])))
        True
        """
        if t is None:
            raise DataError("a continuous model needs the time stamps t to simulate: simulate(u, t), "
                            "t of shape (N,), increasing")
        if hold not in HOLDS:
            raise OptionError(f"hold must be one of {HOLDS}, got {hold!r}")
        if any(self.input_delays):
            raise DataError(f"the model has input delays {list(self.input_delays)}: simulate its sampled "
                            "form (to_discrete(Ts).simulate) instead")
        inputs = np.array(real_array("u", u, finite=False), ndmin=1)
        inputs = inputs[:, None] if inputs.ndim == 1 else inputs
        stamps = np.array(real_array("t", t, finite=False), ndmin=1)
        if inputs.ndim != 2 or inputs.shape[1] != self.m or not np.all(np.isfinite(inputs)):
            raise DataError(f"u must be finite with shape (N, {self.m}), got shape {np.shape(u)}")
        if np.ndim(t) == 0:
            raise DataError(f"t must be the time stamps, one per row of u, not a sampling period ({t!r}): "
                            f"for samples T apart pass t = T * np.arange({inputs.shape[0]})")
        if stamps.shape != (inputs.shape[0],) or not np.all(np.isfinite(stamps)):
            raise DataError(f"t must be finite with shape ({inputs.shape[0]},) (one stamp per row of u), "
                            f"got shape {np.shape(t)}")
        if np.any(np.diff(stamps) <= 0):
            k = int(np.flatnonzero(np.diff(stamps) <= 0)[0]) + 1
            raise DataError(f"t must increase: t[{k}] = {stamps[k]:g} follows t[{k - 1}] = {stamps[k - 1]:g}")
        start = None
        if x0 is not None:
            start = real_array("x0", x0, finite=False).reshape(-1)
            if start.shape != (self.n,) or not np.all(np.isfinite(start)):
                raise DataError(f"x0 must be {self.n} finite numbers, got shape {np.shape(x0)}")
        with np.errstate(over="ignore", invalid="ignore"):      # an unstable model diverges, as a sampled one
            states = propagate(self.A, self.B, stamps - stamps[0], inputs[:, :, None],
                               np.full((self.m, 1), hold == "foh"), None if start is None else start[:, None])[:, :, 0]
            return states @ self.C.T + inputs @ self.D.T

    def simulate_at(self, u: np.ndarray, t: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
        """Outputs of one segment of a record: input deviations ``u`` (N, m) at its stamps ``t`` (N,).

        The protocol's simulation (:mod:`moli.models.protocol`), with the model's own
        :attr:`input_hold`.
        """
        return self.simulate(u, t, self.input_hold, x0)

    def free_response_at(self, t: np.ndarray, negligible: float | None = None) -> np.ndarray:
        """Outputs at the stamps ``t`` from each unit initial state at ``t[0]``, no input: (N, p, n).

        ``negligible`` is a sampled model's cut of a decayed response; here every stamp is kept.
        """
        stamps = np.asarray(t, dtype=float)
        states = propagate(self.A, np.zeros((self.n, 1)), stamps - stamps[0], np.zeros((stamps.size, 1, self.n)),
                           np.zeros((1, self.n), dtype=bool), np.eye(self.n))
        return np.einsum("pi,kic->kpc", self.C, states)

    def magnitude_bands(
        self, omega: object, confidence: float = 0.95, *, method: str = "gauss", samples: int = 1000,
        seed: int = 0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pointwise confidence bands of the gain ``|H(1j omega)|``, shape (len(omega), p, m) each.

        ``omega`` in rad per time unit; needs ``cov_factor``. See
        :func:`moli.models.bands.magnitude_bands` for the parameters.
        """
        return magnitude_bands(self, omega, confidence, method=method, samples=samples, seed=seed)

    def step_bands(
        self, t: object, confidence: float = 0.95, *, method: str = "gauss", samples: int = 1000,
        seed: int = 0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pointwise confidence bands of the unit-step responses at the times ``t`` after the step.

        ``t`` (shape (N,), increasing, the step at ``t[0]``) takes the place of a
        sampled model's ``n_steps``; the result has shape (N, p, m) each, entry
        ``[k, i, j]`` bounding output ``i`` at ``t[k]`` after a unit step on input ``j``.
        Needs ``cov_factor``; see :func:`moli.models.bands.step_bands`.

        Examples
        --------
        >>> model = ContinuousModel(np.array([[-1.0]]), np.array([[1.0]]), np.array([[1.0]]), np.zeros((1, 1)),
        ...                         ("y1",), ("u1",), np.zeros(1), np.zeros(1), (0.0,),
        ...                         cov_factor=[[0.0], [0.1], [0.0], [0.0]])
        >>> lower, upper = model.step_bands([0.0, 50.0])      # gain b / 1, b = 1 +- 0.1
        >>> np.round([lower[1, 0, 0], upper[1, 0, 0]], 3)
        array([0.804, 1.196])
        """
        return step_bands(self, t, confidence, method=method, samples=samples, seed=seed)

    def static_gain(self) -> np.ndarray:
        """``D - C A^-1 B``, shape (p, m): the steady output change per unit input step."""
        try:
            return self.D - self.C @ np.linalg.solve(self.A, self.B)
        except np.linalg.LinAlgError:
            raise DataError("the model has a pole at s = 0 (an integrator): its static gain is infinite") from None

    def static_gain_interval(self, confidence: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
        """Pointwise ``confidence`` interval of each static gain, first-order propagation of ``cov_factor``.

        ``d(D - C A^-1 B) = dD - dC A^-1 B + C A^-1 dA A^-1 B - C A^-1 dB``.
        """
        if self.cov_factor is None:
            raise DataError("this model carries no covariance (cov_factor is None): identify it with "
                            "moli.identify(..., time='continuous') to get intervals")
        import scipy.special  # only when an interval is asked for

        gain = self.static_gain()
        n, m, p = self.n, self.m, self.p
        ends = np.cumsum([n * n, n * m, p * n])
        dA, dB, dC, dD = (part.T.reshape((-1,) + shape) for part, shape in zip(
            np.split(self.cov_factor, ends, axis=0), ((n, n), (n, m), (p, n), (p, m))))
        to_output = np.linalg.solve(self.A, self.B)                 # A^-1 B
        from_state = np.linalg.solve(self.A.T, self.C.T).T          # C A^-1
        change = dD - dC @ to_output + from_state @ dA @ to_output - from_state @ dB
        # the normal quantile: scipy.stats.norm.ppf is ndtri (scipy.stats is slow to import)
        spread = float(scipy.special.ndtri(0.5 + confidence / 2)) * np.sqrt(np.sum(change**2, axis=0))
        return gain - spread, gain + spread

    def pole_table(self) -> list[str]:
        """Lines describing each pole: time constant, or natural frequency and damping; then the static gains."""
        lines = [f"poles ({angular_unit(self.info.get('time_unit'))}):"]
        for pole in sorted(self.poles(), key=lambda z: (abs(z), z.imag)):
            if pole.imag < 0:
                continue
            if pole.imag == 0:
                kind = f"time constant {-1 / pole.real:.4g}" if pole.real < 0 else "unstable"
                lines.append(f"  s = {pole.real:.5g}: {kind}")
            else:
                wn = abs(pole)
                lines.append(f"  s = {pole.real:.5g} +- {pole.imag:.5g}j: natural frequency {wn:.4g}, "
                             f"damping {-pole.real / wn:.3g}")
        if self.is_stable():
            gain = self.static_gain()
            for j, name in enumerate(self.output_names):
                cells = ", ".join(f"{u}: {gain[j, i]:.4g}" for i, u in enumerate(self.input_names))
                lines.append(f"static gain of {name}: {cells}")
        return lines

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable description (read back by :func:`moli.load_model`)."""
        return {
            "format": FILE_FORMAT, "version": __version__, "time": "continuous",
            "A": self.A.tolist(), "B": self.B.tolist(), "C": self.C.tolist(), "D": self.D.tolist(),
            "output_names": list(self.output_names), "input_names": list(self.input_names),
            "y_offset": self.y_offset.tolist(), "u_offset": self.u_offset.tolist(),
            "input_delays": list(self.input_delays),
            "cov_factor": None if self.cov_factor is None else self.cov_factor.tolist(),
            "input_hold": self.input_hold, "info": self.info,
        }

    @classmethod
    def from_dict(cls, content: dict[str, Any]) -> "ContinuousModel":
        """The model :meth:`to_dict` describes, every field checked as a discrete model's is
        (names a list of distinct strings, offsets finite and one per channel) and its
        delays finite and non-negative."""
        arrays = {name: matrix(name, content[name]) for name in ("A", "B", "C", "D")}
        p, m = arrays["C"].shape[0], arrays["B"].shape[1]
        return cls(
            arrays["A"], arrays["B"], arrays["C"], arrays["D"],
            stored_names("output_names", content["output_names"], p),
            stored_names("input_names", content["input_names"], m),
            vector("y_offset", content["y_offset"], p), vector("u_offset", content["u_offset"], m),
            time_delays(content["input_delays"], m), content.get("cov_factor"),
            content.get("input_hold", "zoh"), content.get("info") or {},
        )

    def save(self, path: str | Path) -> None:
        """Write the model to a JSON file, whole or not at all."""
        # whole or not at all: a failed or interrupted save keeps the previous file
        write_json(path, self.to_dict(), "the model")

    def frequency_response(self, omega: object) -> np.ndarray:
        """``C (j omega I - A)^-1 B + D``, times ``exp(-j omega tau_j)`` per input: shape (F, p, m).

        Parameters
        ----------
        omega : array_like
            Frequencies in rad per time unit.
        """
        w = check_omega(omega)
        return frequency_response(self.A, self.B, self.C, self.D, 1j * w, w, delays=self.input_delays)

    def to_discrete(self, Ts: float, method: str = "zoh") -> StateSpaceModel:
        """The sampled model at period ``Ts`` (see :meth:`StateSpaceModel.from_continuous`).

        The input delays must be whole multiples of ``Ts``; they become delays in samples.
        """
        model = StateSpaceModel.from_continuous(
            self.A, self.B, self.C, self.D, Ts, method, output_names=self.output_names,
            input_names=self.input_names, y_offset=self.y_offset, u_offset=self.u_offset,
        )
        samples = np.asarray(self.input_delays, dtype=float) / model.Ts
        whole = np.round(samples)
        if np.any(np.abs(samples - whole) > 1e-9 * np.maximum(1.0, whole)):
            raise DataError(
                f"input delays {list(self.input_delays)} are not whole multiples of Ts = {model.Ts:g}; "
                "sample at a period that divides them"
            )
        return model.with_input_delays([int(d) for d in whole])

    def to_control(self):  # -> control.StateSpace
        """Convert to a continuous python-control ``StateSpace`` with the channel names.

        Requires the optional dependency ``control``. python-control's state-space
        models have no dead time: a model with input delays raises :class:`DataError`
        (approximate them with ``control.pade`` if needed).
        """
        if any(self.input_delays):
            raise DataError(
                f"the model has input delays {list(self.input_delays)}, which a python-control "
                "StateSpace cannot hold: approximate them with control.pade, or convert the "
                "sampled model (to_control() keeps its delays as states)"
            )
        try:
            import control
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ImportError("to_control() needs python-control: pip install control") from exc
        return control.ss(self.A, self.B, self.C, self.D,
                          inputs=list(self.input_names), outputs=list(self.output_names))


def to_continuous(model: StateSpaceModel, method: str = "zoh") -> ContinuousModel:
    """The continuous model whose sampling by ``method`` at ``model.Ts`` is ``model``.

    "zoh": ``[[Ac, Bc], [0, 0]] = logm([[A, B], [0, I]]) / Ts`` (the inverse of the
    zero-order hold); "tustin": the inverse of the bilinear map ``s = (2/Ts)(z-1)/(z+1)``.
    """
    Ac, Bc, Cc, Dc = continuous_matrices(model, method)
    return ContinuousModel(
        Ac, Bc, Cc, Dc, model.output_names, model.input_names, model.y_offset.copy(),
        model.u_offset.copy(), tuple(float(d * model.Ts) for d in model.input_delays),
    )
