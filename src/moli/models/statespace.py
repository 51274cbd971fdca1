"""The identified state-space model."""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .._version import __version__
from ..data.iodata import as_signal
from ..errors import DataError, ModelFileError, OptionError, UnstableModelWarning
from .bands import magnitude_bands, step_bands
from .simulation import simulate_batch

__all__ = ["StateSpaceModel", "model_from_dict", "load_model"]

FILE_FORMAT = "moli-model"


def _matrix(name: str, value: object, shape: tuple[int, int] | None = None) -> np.ndarray:
    array = np.array(value, dtype=float, ndmin=2)
    if array.ndim != 2 or not np.all(np.isfinite(array)):
        raise DataError(f"{name} must be a finite 2-D matrix, got shape {array.shape}")
    if shape is not None and array.shape != shape:
        raise DataError(f"{name} must have shape {shape}, got {array.shape}")
    return array


def _covariance(value: object, p: int) -> np.ndarray:
    array = _matrix("noise_cov", value, (p, p))
    scale = float(np.max(np.abs(array), initial=0.0))
    # round-off tolerances: a covariance computed as E^T E / N is symmetric and PSD to
    # a few ulps of its largest entry
    if not np.allclose(array, array.T, rtol=0.0, atol=1e-12 * scale) or \
            np.min(np.linalg.eigvalsh(array), initial=0.0) < -1e-10 * scale:
        raise DataError("noise_cov must be symmetric positive semidefinite")
    return array


class StateSpaceModel:
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

    def __init__(
        self,
        A: object,
        B: object,
        C: object,
        D: object | None = None,
        Ts: float = 1.0,
        output_names: Sequence[str] | None = None,
        input_names: Sequence[str] | None = None,
        indices: Sequence[int] | None = None,
        alpha: Sequence[float] | None = None,
        y_offset: object | None = None,
        u_offset: object | None = None,
        info: dict[str, Any] | None = None,
        *,
        divisors: Sequence[Sequence[float]] | None = None,
        K: object | None = None,
        noise_cov: object | None = None,
        cov_factor: object | None = None,
    ) -> None:
        self.A = _matrix("A", A)
        n = self.A.shape[0]
        if self.A.shape != (n, n):
            raise DataError(f"A must be square, got shape {self.A.shape}")
        self.B = _matrix("B", B)
        self.C = _matrix("C", C)
        if self.B.shape[0] != n or self.C.shape[1] != n:
            raise DataError(f"B needs {n} rows and C {n} columns, got {self.B.shape} and {self.C.shape}")
        p, m = self.C.shape[0], self.B.shape[1]
        self.D = np.zeros((p, m)) if D is None else _matrix("D", D, (p, m))
        if not (np.isfinite(Ts) and Ts > 0):
            raise DataError(f"Ts must be positive, got {Ts!r}")
        self.Ts = float(Ts)
        self.output_names = tuple(output_names) if output_names is not None else tuple(f"y{i + 1}" for i in range(p))
        self.input_names = tuple(input_names) if input_names is not None else tuple(f"u{i + 1}" for i in range(m))
        if len(self.output_names) != p or len(self.input_names) != m:
            raise DataError(f"need {p} output names and {m} input names")
        self.indices = None if indices is None else tuple(int(v) for v in indices)
        self.alpha = None if alpha is None else np.array(alpha, dtype=float)
        self.y_offset = np.zeros(p) if y_offset is None else np.array(y_offset, dtype=float).reshape(p)
        self.u_offset = np.zeros(m) if u_offset is None else np.array(u_offset, dtype=float).reshape(m)
        self.info = dict(info or {})
        self.divisors = None if divisors is None else self._checked_divisors(divisors)
        if (K is None) != (noise_cov is None):
            raise DataError("K and noise_cov make the noise model together: give both or neither")
        self.K = None if K is None else _matrix("K", K, (n, p))
        self.noise_cov = None if noise_cov is None else _covariance(noise_cov, p)
        self.cov_factor = None if cov_factor is None else _matrix("cov_factor", cov_factor)
        if self.cov_factor is not None and self.cov_factor.shape[0] != n * n + n * m + p * n + p * m:
            raise DataError(f"cov_factor needs one row per entry of A, B, C and D "
                            f"({n * n + n * m + p * n + p * m}), got {self.cov_factor.shape[0]}")

    def _checked_divisors(self, given: Sequence[Sequence[float]]) -> tuple[np.ndarray, ...]:
        if self.indices is None or len(given) != len(self.indices) or len(self.indices) != self.p:
            raise DataError(f"divisors need the model's indices, one divisor per output ({self.p})")
        checked = []
        for j, (coeffs, l) in enumerate(zip(given, self.indices)):
            alpha_j = _matrix(f"divisor of output {j + 1}", coeffs).ravel()
            if alpha_j.size - 1 != l or alpha_j[0] != 1.0:
                raise DataError(f"divisor of output {j + 1} must be monic of degree {l}, got {alpha_j.tolist()}")
            if np.max(np.abs(np.roots(alpha_j))) >= 1.0:
                raise DataError(f"divisor of output {j + 1} must be stable (roots strictly inside the unit circle)")
            checked.append(alpha_j)
        return tuple(checked)

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
        )

    @property
    def n(self) -> int:
        """Order (number of states)."""
        return self.A.shape[0]

    @property
    def p(self) -> int:
        """Number of outputs."""
        return self.C.shape[0]

    @property
    def m(self) -> int:
        """Number of inputs."""
        return self.B.shape[1]

    def __repr__(self) -> str:
        lists = f", indices={list(self.indices)}" if self.indices else ""
        return f"StateSpaceModel(n={self.n}, p={self.p}, m={self.m}, Ts={self.Ts:g}{lists}, stable={self.is_stable()})"

    def simulate(self, u: object, x0: object | None = None) -> np.ndarray:
        """Simulate the model (deviation variables).

        Parameters
        ----------
        u : array_like, shape (N, m)
            Input deviations, time along axis 0 (1-D accepted when m = 1).
        x0 : array_like, shape (n,), optional
            Initial state; zero by default.

        Returns
        -------
        ndarray, shape (N, p)
        """
        uu = as_signal("u", u, self.m)
        start = None
        if x0 is not None:
            start = np.array(x0, dtype=float).reshape(-1)
            if start.shape != (self.n,):
                raise DataError(f"x0 must have {self.n} entries, got {np.shape(x0)}")
            start = start[None]
        y = simulate_batch(self.A[None], self.B[None], self.C[None], uu, start)[0]
        return y + uu @ self.D.T

    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` (discrete time)."""
        return np.linalg.eigvals(self.A)

    def is_stable(self) -> bool:
        """True when every pole lies strictly inside the unit circle."""
        return bool(self.n == 0 or np.max(np.abs(self.poles())) < 1.0)

    def markov(self, count: int) -> np.ndarray:
        """Markov parameters ``D, C B, C A B, ...``: shape (count, p, m), entry k is h_k."""
        out = np.empty((count, self.p, self.m))
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
            radius = np.max(np.abs(self.poles()))
            warnings.warn(
                f"identified model (indices {list(self.indices or [])}) is unstable: "
                f"largest pole modulus {radius:.4g}",
                UnstableModelWarning,
                stacklevel=stacklevel + 1,
            )

    def to_control(self, noise: bool = False):  # -> control.StateSpace
        """Convert to a python-control ``StateSpace`` with the channel names.

        Requires the optional dependency ``control`` (``pip install control``).

        Parameters
        ----------
        noise : bool, default False
            False: the deterministic part (inputs ``u``). True: the innovations form,
            with inputs ``[u, e]`` (``e`` named ``e@<output>``, covariance
            ``noise_cov``), ``B = [B, K]`` and ``D = [D, I]``; needs a noise model.
        """
        if not isinstance(noise, bool):
            raise OptionError(f"noise must be True or False, got {noise!r}")
        if noise and self.K is None:
            raise OptionError("to_control(noise=True) needs a noise model, and model.K is None")
        try:
            import control
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ImportError("to_control() needs python-control: pip install control") from exc
        if noise:
            return control.ss(
                self.A, np.hstack([self.B, self.K]), self.C, np.hstack([self.D, np.eye(self.p)]), self.Ts,
                inputs=[*self.input_names, *(f"e@{name}" for name in self.output_names)],
                outputs=list(self.output_names),
            )
        return control.ss(
            self.A, self.B, self.C, self.D, self.Ts,
            inputs=list(self.input_names), outputs=list(self.output_names),
        )

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
            "info": self.info,
        }

    def save(self, path: str | Path) -> None:
        """Write the model to a JSON file (read it back with :func:`moli.load_model`)."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=1))


def model_from_dict(content: dict[str, Any]) -> StateSpaceModel:
    """Rebuild a model from :meth:`StateSpaceModel.to_dict` output, checking it."""
    if not isinstance(content, dict) or content.get("format") != FILE_FORMAT:
        raise ModelFileError("not a moli model file (missing 'format': 'moli-model')")
    major = str(content.get("version", "")).split(".")[0]
    if major != __version__.split(".")[0]:
        raise ModelFileError(
            f"model file written by moli {content.get('version')}, which this moli "
            f"{__version__} cannot read"
        )
    try:
        return StateSpaceModel(
            content["A"], content["B"], content["C"], content["D"], content["Ts"],
            content["output_names"], content["input_names"], content.get("indices"),
            content.get("alpha"), content.get("y_offset"), content.get("u_offset"),
            content.get("info"), divisors=content.get("divisors"),
            K=content.get("K"), noise_cov=content.get("noise_cov"),  # absent in older files
            cov_factor=content.get("cov_factor"),
        )
    except KeyError as exc:
        raise ModelFileError(f"model file lacks the field {exc}") from None
    except DataError as exc:
        raise ModelFileError(f"model file is inconsistent: {exc}") from None


def load_model(path: str | Path) -> StateSpaceModel:
    """Read a model written by :meth:`StateSpaceModel.save`.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    StateSpaceModel
    """
    try:
        content = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise ModelFileError(f"no model file at {path}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{path} is not a JSON model file: {exc}") from None
    return model_from_dict(content)
