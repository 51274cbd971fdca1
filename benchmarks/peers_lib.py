"""Peer subspace methods behind one calling convention, for side-by-side benchmarks.

Every ``fit_*`` function takes estimation outputs and inputs with time along axis 0
(means already removed) and a model order ``n``, and returns a discrete-time
``(A, B, C, D)`` of exactly that order, or ``None`` when the peer fails or returns
another order. All models are scored by :func:`simulate_vaf`, so every method is
judged by the same zero-initial-state simulation.

Peers (``pip install sippy-unipi nfoursid pandas``):

* SIPPY (``sippy-unipi``; imported as ``sippy_unipi`` by release 1.0.1, as ``sippy``
  by older ones): N4SID, MOESP, CVA, PARSIM-K through ``system_identification``.
* ``nfoursid``: the ``NFourSID`` class (PO-MOESP instruments, N4SID state estimate).

Pitfalls handled here:

* SIPPY accepts only a Python ``int`` order and horizons. A ``numpy.int64`` makes it
  print an error and return 1x1 zero matrices instead of raising.
* SIPPY lowers the order to the horizon ``f`` without an error when ``n > f``.
* SIPPY calls ``sys.exit`` on an unknown method name, so names go through a whitelist.
* SIPPY prints warnings (with terminal colour codes) on stdout; they are captured.
* SIPPY guesses the data orientation from the array shape; data are passed as
  (channels, N) explicitly.
* nfoursid wants a ``pandas.DataFrame`` with named columns, always estimates ``D``,
  cannot give more than ``p * num_block_rows`` states (larger ranks yield inconsistent
  matrices), and takes a full SVD whose right factor is about N x N.
"""

from __future__ import annotations

import contextlib
import io
import time
from typing import Any, Callable

import numpy as np

from moli import StateSpaceModel
from moli.validation.metrics import vaf

ABCD = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]

SIPPY_METHODS = ("N4SID", "MOESP", "CVA", "PARSIM-K")
SIPPY_DEFAULT_HORIZON = 20


def _import_sippy() -> Any:
    try:
        import sippy_unipi as sippy
    except ImportError:
        try:
            import sippy  # releases before 1.0 used this name
        except ImportError:
            raise ImportError("SIPPY is not installed: pip install sippy-unipi") from None
    return sippy


def _checked(n: int, A: Any, B: Any, C: Any, D: Any, p: int, m: int) -> ABCD | None:
    """The matrices as float arrays, or None unless they are finite and of order n."""
    mats = tuple(np.array(M, dtype=float, ndmin=2) for M in (A, B, C, D))
    shapes = ((n, n), (n, m), (p, n), (p, m))
    if any(M.shape != s for M, s in zip(mats, shapes)):
        return None
    if not all(np.all(np.isfinite(M)) for M in mats):
        return None
    return mats  # type: ignore[return-value]


def fit_sippy(
    method: str,
    y_est: np.ndarray,
    u_est: np.ndarray,
    n: int,
    horizon: int = SIPPY_DEFAULT_HORIZON,
    b_reval: bool = False,
) -> ABCD | None:
    """Identify an order-``n`` model with one of SIPPY's subspace methods.

    Parameters
    ----------
    method : {"N4SID", "MOESP", "CVA", "PARSIM-K"}
    y_est, u_est : ndarray, shapes (N, p), (N, m)
        Estimation data, time along axis 0, means removed.
    n : int
        Model order; must not exceed ``horizon``.
    horizon : int, default 20
        Future and past horizons ``f = p`` (SIPPY's default is 20 for both).
    b_reval : bool, default False
        PARSIM-K only: SIPPY's ``SS_PK_B_reval``, which re-estimates ``B`` (and ``x0``)
        by least squares on the simulated outputs of the final ``(A, C)``. Off by
        default, as in SIPPY.

    Returns
    -------
    (A, B, C, D) or None
        ``D`` is zero (SIPPY's ``SS_D_required=False``). None when SIPPY raises or
        returns anything but finite matrices of order ``n``.
    """
    if method not in SIPPY_METHODS:
        raise ValueError(f"unknown SIPPY method {method!r}; choose from {SIPPY_METHODS}")
    if b_reval and method != "PARSIM-K":
        raise ValueError("b_reval applies only to PARSIM-K")
    n, horizon = int(n), int(horizon)
    if not 1 <= n <= horizon:
        raise ValueError(f"SIPPY needs 1 <= n <= horizon, got n={n}, horizon={horizon}")
    sippy = _import_sippy()
    y, u = np.asarray(y_est, float), np.asarray(u_est, float)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            model = sippy.system_identification(
                y.T, u.T, method, SS_fixed_order=n, SS_f=horizon, SS_p=horizon,
                SS_PK_B_reval=bool(b_reval),
            )
    except (np.linalg.LinAlgError, ValueError, ArithmeticError):
        return None
    return _checked(n, model.A, model.B, model.C, model.D, y.shape[1], u.shape[1])


def fit_nfoursid(
    y_est: np.ndarray, u_est: np.ndarray, n: int, num_block_rows: int
) -> ABCD | None:
    """Identify an order-``n`` model with ``nfoursid.NFourSID``.

    Parameters
    ----------
    y_est, u_est : ndarray, shapes (N, p), (N, m)
        Estimation data, time along axis 0, means removed.
    n : int
        Model order; must not exceed ``p * num_block_rows``.
    num_block_rows : int
        Block rows of the Hankel matrices (past and future horizon).

    Returns
    -------
    (A, B, C, D) or None
        ``D`` is always estimated by nfoursid. None on failure.
    """
    import pandas as pd
    from nfoursid.nfoursid import NFourSID

    y, u = np.asarray(y_est, float), np.asarray(u_est, float)
    p, m = y.shape[1], u.shape[1]
    if not 1 <= n <= p * num_block_rows:
        raise ValueError(
            f"nfoursid needs 1 <= n <= p * num_block_rows = {p * num_block_rows}, got n={n}"
        )
    y_cols, u_cols = [f"y{i}" for i in range(p)], [f"u{j}" for j in range(m)]
    frame = pd.DataFrame(np.hstack([y, u]), columns=y_cols + u_cols)
    try:
        identifier = NFourSID(frame, output_columns=y_cols, input_columns=u_cols,
                              num_block_rows=int(num_block_rows))
        identifier.subspace_identification()
        model, _ = identifier.system_identification(rank=int(n))
    except (np.linalg.LinAlgError, ValueError):
        return None
    return _checked(n, model.a, model.b, model.c, model.d, p, m)


def simulate_vaf(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray,
    u_val: np.ndarray, y_val: np.ndarray,
) -> np.ndarray:
    """Validation VAF per output, simulating from a zero initial state.

    ``VAF_i = max(1 - var(y_i - yhat_i) / var(y_i), 0) * 100``; a simulation that
    diverges to inf or NaN scores 0.

    Parameters
    ----------
    A, B, C, D : ndarray
        Discrete-time model acting on the centred signals.
    u_val, y_val : ndarray, shapes (N, m), (N, p)
        Validation data, centred with the estimation means.

    Returns
    -------
    ndarray, shape (p,)
    """
    yhat = StateSpaceModel(A, B, C, D).simulate(u_val)
    return vaf(y_val, yhat)


def timed(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> tuple[Any, float]:
    """Call ``fn(*args, **kwargs)`` and return ``(result, wall-clock seconds)``."""
    start = time.perf_counter()
    result = fn(*args, **kwargs)
    return result, time.perf_counter() - start


def centred_split(
    y: np.ndarray, u: np.ndarray, est: slice, val: slice
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Estimation and validation records, both centred with the estimation means.

    Returns
    -------
    y_est, u_est, y_val, u_val : ndarray
        New arrays; the inputs are not modified.
    """
    y_mean, u_mean = y[est].mean(axis=0), u[est].mean(axis=0)
    return y[est] - y_mean, u[est] - u_mean, y[val] - y_mean, u[val] - u_mean


Fitter = Callable[[np.ndarray, np.ndarray, int], ABCD | None]


def _sippy_fitter(method: str, twice_n: bool, b_reval: bool = False) -> Fitter:
    def fit(y: np.ndarray, u: np.ndarray, n: int) -> ABCD | None:
        horizon = 2 * n if twice_n else SIPPY_DEFAULT_HORIZON
        return fit_sippy(method, y, u, n, horizon, b_reval=b_reval)
    return fit


def peer_fitters() -> dict[str, Fitter]:
    """Every peer configuration of the benchmark, keyed by a display label.

    Each value is called as ``fit(y_est, u_est, n)``. SIPPY methods run with the
    default horizon 20 and with ``f = p = 2n``, PARSIM-K also with ``SS_PK_B_reval``
    on; nfoursid runs with ``num_block_rows = 2n``.
    """
    fitters: dict[str, Fitter] = {}
    for method in SIPPY_METHODS:
        fitters[f"SIPPY {method} f=20"] = _sippy_fitter(method, twice_n=False)
        fitters[f"SIPPY {method} f=2n"] = _sippy_fitter(method, twice_n=True)
    fitters["SIPPY PARSIM-K f=20 B-reval"] = _sippy_fitter("PARSIM-K", False, b_reval=True)
    fitters["SIPPY PARSIM-K f=2n B-reval"] = _sippy_fitter("PARSIM-K", True, b_reval=True)
    fitters["nfoursid r=2n"] = lambda y, u, n: fit_nfoursid(y, u, n, 2 * n)
    return fitters
