"""Continuous-time models: from a sampled model and back (zero-order hold or Tustin).

A sampled model becomes a :class:`ContinuousModel`, a small class of its own rather
than a flag on :class:`~moli.models.statespace.StateSpaceModel`: simulation, the
filters, structure indices and the refinement of that class are all discrete time,
and a continuous model has none of them (docs/diagnostics.md §2).
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.linalg

from .._version import __version__
from ..data.atomic_files import write_atomic
from ..errors import DataError, OptionError
from .checks import Dimensions, matrix, stored_names, time_delays, vector
from .frequency import check_omega, frequency_response
from .propagation import propagate
from .statespace import FILE_FORMAT, StateSpaceModel

__all__ = ["ContinuousModel", "CONVERSION_METHODS", "HOLDS", "to_continuous", "discretize"]

CONVERSION_METHODS = ("zoh", "tustin")
# Inter-sample assumptions of the input: held from each sample to the next, or linear.
HOLDS = ("zoh", "foh")
# Poles closer than this (relative to the model's scale) to z = 0, or to the negative
# real axis in angle, have no real continuous-time counterpart worth trusting: the
# logarithm there is infinite or complex, and round-off of order sqrt(eps) in a
# computed eigenvalue can move it across the branch cut.
POLE_TOLERANCE = float(np.sqrt(np.finfo(float).eps))


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

    def __repr__(self) -> str:
        return f"ContinuousModel(n={self.n}, p={self.p}, m={self.m}, stable={self.is_stable()})"

    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` (continuous time, rad per time unit)."""
        return np.linalg.eigvals(self.A)

    def is_stable(self) -> bool:
        """True when every pole has a negative real part."""
        return bool(self.n == 0 or np.max(self.poles().real) < 0.0)

    def simulate(self, u: object, t: object = None, hold: str = "zoh") -> np.ndarray:
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
        inputs = np.array(u, dtype=float, ndmin=1)
        inputs = inputs[:, None] if inputs.ndim == 1 else inputs
        stamps = np.array(t, dtype=float, ndmin=1)
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
        states = propagate(self.A, self.B, stamps - stamps[0], inputs[:, :, None],
                           np.full((self.m, 1), hold == "foh"))[:, :, 0]
        return states @ self.C.T + inputs @ self.D.T

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
        lines = ["poles (rad per time unit):"]
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
        )

    def save(self, path: str | Path) -> None:
        """Write the model to a JSON file, whole or not at all."""
        if not isinstance(path, (str, Path)):
            raise DataError(f"path must be a str or Path, got {type(path).__name__}")
        write_atomic(path, json.dumps(self.to_dict(), indent=1))

    def frequency_response(self, omega: object) -> np.ndarray:
        """``C (j omega I - A)^-1 B + D``, times ``exp(-j omega tau_j)`` per input: shape (F, p, m).

        Parameters
        ----------
        omega : array_like
            Frequencies in rad per time unit.
        """
        w = check_omega(omega)
        return frequency_response(self.A, self.B, self.C, self.D, 1j * w, w, self.input_delays)

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


def _method(method: object) -> str:
    if method not in CONVERSION_METHODS:
        raise OptionError(f"method must be one of {CONVERSION_METHODS}, got {method!r}")
    return str(method)


def to_continuous(model: StateSpaceModel, method: str = "zoh") -> ContinuousModel:
    """The continuous model whose sampling by ``method`` at ``model.Ts`` is ``model``.

    "zoh": ``[[Ac, Bc], [0, 0]] = logm([[A, B], [0, I]]) / Ts`` (the inverse of the
    zero-order hold); "tustin": the inverse of the bilinear map ``s = (2/Ts)(z-1)/(z+1)``.
    """
    kind = _method(method)
    inverse = _zoh_inverse if kind == "zoh" else _tustin_inverse
    Ac, Bc, Cc, Dc = inverse(model)
    return ContinuousModel(
        Ac, Bc, Cc, Dc, model.output_names, model.input_names, model.y_offset.copy(),
        model.u_offset.copy(), tuple(float(d * model.Ts) for d in model.input_delays),
    )


def _scale(A: np.ndarray) -> float:
    return max(1.0, float(np.linalg.norm(A, 2))) if A.size else 1.0


def _pole(z: complex) -> str:
    return f"z = {z.real:.4g}" + (f"{z.imag:+.4g}j" if z.imag else "")


def _no_conversion(method: str, problem: str, poles: np.ndarray, tustin_works: bool) -> DataError:
    """The refusal of ``to_continuous(method)``, naming the poles and the ways forward."""
    options = ["method='tustin', the bilinear map, which converts these poles (exact at low "
               "frequency, warped near Nyquist)"] if tustin_works else []
    options += [
        "keep the discrete model: simulate, frequency_response, to_control() and the "
        "controller design all work in discrete time",
        "identify from data sampled faster (a higher sampling rate puts real modes near "
        "z = 1, away from z <= 0), or pick a lower order from result.path: a pole on the "
        "negative real axis is often a mode fitted to noise",
    ]
    listed = "; ".join(f"({k}) {option}" for k, option in enumerate(options, start=1))
    return DataError(
        f"to_continuous(method={method!r}) has no real solution: {problem}: "
        f"{', '.join(_pole(z) for z in poles)}. Options: {listed}"
    )


def _zoh_inverse(model: StateSpaceModel) -> tuple[np.ndarray, ...]:
    A, B, n, m = model.A, model.B, model.n, model.m
    poles = model.poles()
    near_zero = np.abs(poles) <= POLE_TOLERANCE * _scale(A)
    bad = near_zero | (np.abs(np.angle(poles)) >= np.pi - POLE_TOLERANCE)
    logarithm = None
    if not np.any(bad):
        block = np.zeros((n + m, n + m))
        block[:n, :n], block[:n, n:], block[n:, n:] = A, B, np.eye(m)
        with warnings.catch_warnings():
            # scipy notes any error estimate above 1000 eps; the imaginary part is checked below
            warnings.simplefilter("ignore", RuntimeWarning)
            logarithm = scipy.linalg.logm(block) / model.Ts
        size = max(1.0, float(np.max(np.abs(logarithm))))
        if np.max(np.abs(np.imag(logarithm))) > 1e-9 * size:
            # a negative real pole the tolerance let through: its logarithm is complex
            bad = np.abs(np.angle(poles)) == np.max(np.abs(np.angle(poles)))
            logarithm = None
    if logarithm is None:
        raise _no_conversion(
            "zoh", "the model has poles at z = 0 or on the negative real axis, which no "
            "zero-order hold of a continuous system produces", poles[bad],
            tustin_works=not np.any(np.abs(poles + 1.0) <= POLE_TOLERANCE * _scale(A)))
    real = np.real(logarithm)
    return real[:n, :n].copy(), real[:n, n:].copy(), model.C.copy(), model.D.copy()


def _tustin_inverse(model: StateSpaceModel) -> tuple[np.ndarray, ...]:
    A, B, C, D, Ts, n = model.A, model.B, model.C, model.D, model.Ts, model.n
    at_minus_one = np.abs(model.poles() + 1.0) <= POLE_TOLERANCE * _scale(A)
    if np.any(at_minus_one):
        # a pole at -1 is on the negative real axis: the zero-order hold fails as well
        raise _no_conversion(
            "tustin", "the model has poles at z = -1, which the bilinear map sends to "
            "infinity (and which no zero-order hold produces either)",
            model.poles()[at_minus_one], tustin_works=False)
    shifted = A + np.eye(n)
    # Ac = (2/Ts)(A - I)(A + I)^-1 (the factors commute), Bc = (2/Ts)(A + I)^-1 B,
    # Cc = 2 C (A + I)^-1, Dc = D - Cc B / 2: solves, no inverse formed
    Ac = (2.0 / Ts) * np.linalg.solve(shifted.T, (A - np.eye(n)).T).T
    Bc = (2.0 / Ts) * np.linalg.solve(shifted, B)
    Cc = 2.0 * np.linalg.solve(shifted.T, C.T).T
    return Ac, Bc, Cc, D - 0.5 * Cc @ B


def discretize(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, Ts: float, method: str = "zoh"
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sampled matrices of a continuous model: zero-order hold (``expm`` of the block
    matrix ``[[A, B], [0, 0]] Ts``) or Tustin (``s = (2/Ts)(z-1)/(z+1)``)."""
    kind = _method(method)
    n, m = B.shape
    if kind == "zoh":
        block = np.zeros((n + m, n + m))
        block[:n, :n], block[:n, n:] = A * Ts, B * Ts
        exponential = scipy.linalg.expm(block)
        return exponential[:n, :n], exponential[:n, n:], C.copy(), D.copy()
    half = np.eye(n) - 0.5 * Ts * A
    if n and np.linalg.cond(half) > 1.0 / np.finfo(float).eps:
        raise DataError(f"method='tustin' has no solution: A has an eigenvalue at 2/Ts = {2 / Ts:g}")
    Ad = np.linalg.solve(half, np.eye(n) + 0.5 * Ts * A)
    Bd = np.linalg.solve(half, Ts * B)
    Cd = np.linalg.solve(half.T, C.T).T
    return Ad, Bd, Cd, D + 0.5 * C @ Bd
