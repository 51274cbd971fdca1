"""Filter polynomials: alpha from eta = (wc, zeta), and its divisors alpha_j.

Root rule (documented choice)
-----------------------------
``alpha`` has degree ``nbar = max(indices)``. Its dominant roots are the
discretized second-order pair of cutoff ``wc`` and damping ``zeta``; the next
roots are successive powers ``z**s``, ``(z**s)**s``, ...; an odd ``nbar`` ends with
the real root ``|z_last|**s`` and ``nbar = 1`` is the single real root
``exp(-zeta wc Ts)``. When ``nbar`` is even, ``zeta < 1`` and some index is odd
and below ``nbar``, the fastest pair is replaced by a double real root of the
same modulus so that a real root is available.

Each output's divisor ``alpha_j`` of degree ``l_j`` takes the roots of ``alpha``
slowest first (largest modulus), conjugate pairs kept together; an odd ``l_j``
first takes the slowest real root. ``alpha_j = alpha`` when ``l_j = nbar``.
"""

from __future__ import annotations

import cmath
from typing import Sequence

import numpy as np

from ...data.arguments import integer, period, real_number
from ...errors import FilterError, OptionError
from .indices import Indices

__all__ = [
    "needs_real_root",
    "filter_roots", "filter_polynomial", "check_alpha", "divisor", "divisors",
    "filter_divisors", "filter_rows", "check_candidates",
]

# A pair whose imaginary part is below this share of its modulus may stand for two
# real roots: np.roots splits a double real root into a pair by about sqrt(eps) times
# the spread of nearby roots (up to ~1e-2 seen on slow filters with clustered double
# roots, e.g. zeta = 1). The strictest reading that yields a valid divisor is used.
_REAL_TOLERANCES = (1e-6, 1e-3, 1e-2, 5e-2)


def _check_filter_options(indices: Sequence[int], Ts: float, s: float) -> tuple[int, ...]:
    if isinstance(indices, (str, bytes)) or not isinstance(indices, (Sequence, np.ndarray)) or not len(indices):
        raise FilterError(f"indices must be a non-empty list of positive integers, got {indices!r}")
    indices = tuple(integer("each of the indices", v, error=FilterError, low=1) for v in indices)
    real_number("the spacing factor s", s, error=FilterError, low=1.0, low_open=True)
    period(Ts, error=FilterError)
    return indices


def filter_roots(
    wc: float, zeta: float, indices: Sequence[int], Ts: float = 1.0, s: float = 2.0
) -> np.ndarray:
    """Roots of the filter polynomial alpha for ``eta = (wc, zeta)``.

    See :func:`filter_polynomial` for the parameters.
    """
    indices = _check_filter_options(indices, Ts, s)
    for name, value in (("wc", wc), ("zeta", zeta)):
        real_number(name, value, error=FilterError, low=0.0, low_open=True)
    roots = _roots_rows(np.array([[wc, zeta]], float), indices, Ts, s)[0]
    if np.max(np.abs(roots)) >= 1.0:
        raise FilterError(f"wc = {wc:g} with zeta = {zeta:g} is too slow for Ts = {Ts:g}: the filter's roots "
                          "round to the unit circle; give a larger wc (or zeta)")
    return roots


def _roots_rows(etas: np.ndarray, indices: Indices, Ts: float, s: float) -> np.ndarray:
    """Roots (R, max(indices)) of the filters of the rows ``(wc, zeta)``, by the root rule."""
    nbar = max(indices)
    wc, zeta = etas[:, 0], etas[:, 1]
    if nbar == 1:
        return np.exp(-zeta * wc * Ts).astype(complex)[:, None]
    a = wc * Ts
    over = zeta >= 1
    spread = np.sqrt(np.abs(zeta**2 - 1))
    pair = np.empty((len(etas), 2), complex)
    pair[:, 0] = np.where(over, np.exp(a * (-zeta + spread)), np.exp(a * (-zeta + 1j * spread)))
    pair[:, 1] = np.where(over, np.exp(a * (-zeta - spread)), np.conj(pair[:, 0]))
    columns: list[np.ndarray] = []
    while len(columns) + 2 <= nbar:
        columns.extend(pair.T)
        pair = pair**s
    if len(columns) < nbar:
        columns.append((np.abs(columns[-1]) ** s).astype(complex))
    roots = np.column_stack(columns)
    if needs_real_root(indices) and nbar % 2 == 0:
        roots[~over, -2:] = np.abs(roots[~over, -1])[:, None]
    return roots


def check_candidates(omega: np.ndarray, Ts: float) -> None:
    """Refuse a candidate ``(wc, zeta)`` of ``omega`` whose pair of roots is not stable once the
    coefficients of its second-order filter are rounded (roots that round to the unit circle at
    ``Ts``): the search would take it, and the models built on it would fail where their filter
    is checked. The pair alone: higher degrees add its powers (``s``), whose clustering is the
    spacing's choice, not the candidate's."""
    roots = _roots_rows(np.asarray(omega, float), (2,), Ts, 2.0)
    for (wc, zeta), row in zip(omega, roots):
        try:
            check_alpha(monic_from_roots(row))
        except FilterError:
            raise OptionError(f"omega's candidate (wc, zeta) = ({wc:g}, {zeta:g}) is too slow for Ts = {Ts:g}: "
                              f"its filter's roots round to the unit circle; give it a larger wc") from None


def needs_real_root(indices: Indices) -> bool:
    """Whether an odd index below the largest needs alpha to carry a real root."""
    nbar = max(indices)
    return any(l % 2 == 1 and l < nbar for l in indices)


def filter_polynomial(
    wc: float, zeta: float, indices: Sequence[int], Ts: float = 1.0, s: float = 2.0
) -> np.ndarray:
    """Monic coefficients of the filter polynomial alpha.

    Parameters
    ----------
    wc : float
        Cutoff frequency of the dominant pair, rad per time unit of ``Ts``.
    zeta : float
        Damping of the dominant pair (``>= 1`` gives two real roots).
    indices : sequence of int
        List of observability indices; ``alpha`` has degree ``max(indices)`` and is
        built so that every index gets a valid divisor.
    Ts : float, default 1.0
        Sampling period.
    s : float, default 2.0
        Spacing factor of the faster roots (``z**s``).

    Returns
    -------
    ndarray, shape (max(indices) + 1,)
        ``[1, a_1, ..., a_nbar]``, highest power first.

    Examples
    --------
    >>> filter_polynomial(0.5, 1.0, [1])
    array([ 1.        , -0.60653066])
    """
    return monic_from_roots(filter_roots(wc, zeta, indices, Ts, s))


def check_alpha(alpha: Sequence[float]) -> np.ndarray:
    """Validate a filter polynomial: real, monic, all roots strictly inside the unit circle."""
    try:
        coeffs = np.array(alpha, dtype=float).ravel()
    except (TypeError, ValueError):
        raise FilterError(f"alpha must be a sequence of real coefficients, got {alpha!r}") from None
    if coeffs.size < 2 or not np.all(np.isfinite(coeffs)):
        raise FilterError(f"alpha must be finite with degree >= 1, got {coeffs}")
    if coeffs[0] != 1.0:
        raise FilterError(f"alpha must be monic (leading coefficient 1), got leading {coeffs[0]}")
    if _schur_stable(coeffs):
        return coeffs
    radius = np.max(np.abs(np.roots(coeffs)))
    if radius >= 1.0:
        raise FilterError(
            f"alpha must be stable (roots strictly inside the unit circle); "
            f"its largest root modulus is {radius:.6g}"
        )
    return coeffs


def _schur_stable(coeffs: np.ndarray) -> bool:
    """Whether every root is strictly inside the unit circle (Schur-Cohn reflection test).

    Cheaper than the roots for the small degrees of filters; a polynomial it cannot
    certify (a reflection coefficient of modulus 1 or more) is left to the roots.
    """
    a = coeffs.tolist()
    while len(a) > 1:
        k = a[-1] / a[0]
        if not abs(k) < 1.0:
            return False
        a = [(x - k * y) for x, y in zip(a[:-1], a[:0:-1])]
    return True


def monic_from_roots(roots: np.ndarray) -> np.ndarray:
    """Real coefficients of the monic polynomial with these roots, as ``np.poly``.

    The factors ``q - r`` are multiplied in the given order by the same convolutions
    as ``np.poly``, without its checks and sorting.
    """
    dtype = roots.dtype             # real roots are multiplied in real arithmetic, as np.poly does
    coeffs = np.ones(1, dtype)
    for value in roots.tolist():
        coeffs = np.convolve(coeffs, np.array([1, -value], dtype=dtype))
    return np.real(coeffs).copy()


def _poly_rows(roots: np.ndarray) -> np.ndarray:
    """:func:`_poly` of each row of ``roots`` (R, k): real coefficients, shape (R, k + 1)."""
    R, k = roots.shape
    coeffs = np.zeros((R, k + 1), roots.dtype)
    coeffs[:, 0] = 1.0
    for i in range(k):
        # multiply by (q - r_i): the convolution np.poly does, for every row at once
        coeffs[:, 1 : i + 2] -= roots[:, i, None] * coeffs[:, : i + 1]
    return np.real(coeffs).copy()


def _root_groups(roots: np.ndarray, tol: float) -> list[tuple]:
    """Group roots into conjugate pairs and real singles, slowest first."""
    reals: list[tuple] = []
    pairs: list[tuple] = []
    # Python scalars: numpy's per-element overhead dominates for a dozen roots
    for r in np.asarray(roots, complex).tolist():
        if abs(r.imag) <= tol * max(abs(r), 1e-300):
            reals.append((r.real,))
        elif r.imag > 0:
            pairs.append((r, r.conjugate()))
    # slowest (largest modulus) first; a real root after a pair of equal modulus
    groups = reals + pairs
    groups.sort(key=lambda g: (-abs(g[0]), len(g) == 1, -abs(cmath.phase(g[0]))))
    return groups


def select_groups(groups: list[tuple], degree: int) -> list[tuple] | None:
    """Slowest groups filling ``degree`` (an odd degree first takes the slowest real root)."""
    chosen: list[tuple] = []
    budget = degree
    if degree % 2 == 1:
        reals = [i for i, g in enumerate(groups) if len(g) == 1]
        if not reals:
            return None
        groups = list(groups)
        chosen.append(groups.pop(reals[0]))
        budget -= 1
    for g in groups:
        if budget == 0:
            break
        if len(g) <= budget:
            chosen.append(g)
            budget -= len(g)
    return None if budget else chosen


def _pick_divisor(roots: np.ndarray, degree: int) -> np.ndarray:
    """Coefficients of the divisor of the given degree chosen from ``roots`` by the root rule."""
    for tol in _REAL_TOLERANCES:
        chosen = select_groups(_root_groups(roots, tol), degree)
        if chosen is not None:
            values = [r for g in chosen for r in g]
            dtype = complex if any(len(g) == 2 for g in chosen) else float
            return monic_from_roots(np.array(values, dtype=dtype))
    raise FilterError(
        f"alpha with roots {np.round(roots, 6).tolist()} has no real root, so it has no "
        f"real divisor of degree {degree}; build alpha with filter_polynomial(..., indices) "
        "so that it carries one"
    )


def divisor(alpha: Sequence[float], degree: int) -> np.ndarray:
    """The monic divisor of ``alpha`` of the given degree (see the module's root rule).

    Parameters
    ----------
    alpha : array_like
        Monic, stable filter polynomial.
    degree : int
        Degree ``l_j`` of the divisor, ``1 <= degree <= deg(alpha)``.

    Returns
    -------
    ndarray, shape (degree + 1,)

    Raises
    ------
    FilterError
        If ``degree`` is odd, below ``deg(alpha)`` and ``alpha`` has no real root.

    Examples
    --------
    >>> divisor([1.0, -1.5, 0.56], 1)
    array([ 1. , -0.8])
    """
    coeffs = check_alpha(alpha)
    nbar = coeffs.size - 1
    if not 1 <= integer("degree", degree, error=FilterError) <= nbar:
        raise FilterError(f"a divisor of alpha (degree {nbar}) needs degree 1..{nbar}, got {degree}")
    if degree == nbar:
        return coeffs
    return _pick_divisor(np.roots(coeffs), degree)


def divisors(alpha: Sequence[float], indices: Indices) -> list[np.ndarray]:
    """One divisor ``alpha_j`` per index (degree ``l_j``); see :func:`divisor`."""
    coeffs = check_alpha(alpha)
    if coeffs.size - 1 != max(indices):
        raise FilterError(
            f"alpha must have degree max(indices) = {max(indices)}, got degree {coeffs.size - 1}"
        )
    cache: dict[int, np.ndarray] = {}
    for l in set(indices):
        cache[l] = divisor(coeffs, l)
    return [cache[l] for l in indices]


def filter_divisors(
    wc: float, zeta: float, indices: Indices, Ts: float = 1.0, s: float = 2.0
) -> list[np.ndarray]:
    """The divisors ``alpha_j`` of the filter built from ``eta = (wc, zeta)``.

    Equivalent to ``divisors(filter_polynomial(wc, zeta, indices, Ts, s), indices)``
    but picks the roots directly, without a round trip through the coefficients.
    """
    table = _divisor_table(filter_roots(wc, zeta, indices, Ts, s), indices)
    return [table[l] for l in indices]


def _divisor_table(roots: np.ndarray, indices: Indices) -> dict[int, np.ndarray]:
    """The filter with these roots (degree ``max(indices)``) and its divisors, by degree."""
    nbar = roots.size
    return {l: (monic_from_roots(roots) if l == nbar else _pick_divisor(roots, l)) for l in set(indices)}


def filter_rows(
    etas: np.ndarray, indices: Indices, Ts: float = 1.0, s: float = 2.0
) -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """``alpha`` and its divisors for many ``eta = (wc, zeta)`` at once.

    The root rule of :func:`filter_polynomial` and :func:`filter_divisors`, computed
    for all rows together (a filter search builds the filters of a whole grid of
    candidates for each list of indices). Equal to the one-row functions up to
    round-off.

    Parameters
    ----------
    etas : ndarray, shape (R, 2)
        Rows ``(wc, zeta)``, positive and finite.
    indices : tuple of int
    Ts, s : float
        Sampling period and root spacing factor.

    Returns
    -------
    alphas : ndarray, shape (R, max(indices) + 1)
    divisors : dict
        ``divisors[l]``, shape (R, l + 1), for every ``l`` in ``indices``.
    """
    etas = np.asarray(etas, float)
    indices = _check_filter_options(indices, Ts, s)
    if etas.ndim != 2 or etas.shape[1] != 2 or not (np.all(np.isfinite(etas)) and np.all(etas > 0)):
        raise FilterError("etas must be rows (wc, zeta) of positive, finite numbers")
    nbar = max(indices)
    roots = _roots_rows(etas, indices, Ts, s)
    if len(etas) == 1:                  # one filter: the one-row route has less overhead
        single = _divisor_table(roots[0], indices)
        return single[nbar][None], {l: d[None] for l, d in single.items()}
    divisors_ = {nbar: _poly_rows(roots)}
    lower = sorted(set(indices) - {nbar})
    if not lower:
        return divisors_[nbar], divisors_
    # zeta >= 1: every root real, the divisor takes the slowest ones. zeta < 1: conjugate
    # pairs of decreasing modulus, then the real roots; rows whose pairs are so narrow
    # (or so fast) that the rule might read them otherwise take the one-row route.
    over = etas[:, 1] >= 1
    slowest = np.take_along_axis(roots.real, np.argsort(-np.abs(roots), axis=1, kind="stable"), axis=1)
    n_pair_roots = 2 * (nbar // 2) - (2 if needs_real_root(indices) and nbar % 2 == 0 else 0)
    heads = roots[:, :n_pair_roots]
    moduli = np.abs(np.column_stack([heads[:, ::2], roots[:, n_pair_roots : n_pair_roots + 1]]))
    paired = ~over & np.all(np.abs(heads.imag) > _REAL_TOLERANCES[0] * np.abs(heads), axis=1)
    paired &= np.all(np.diff(moduli, axis=1) < 0, axis=1)
    for l in lower:
        if l % 2 == 0:
            picked = roots[paired, :l]
        elif l == 1:
            picked = roots[paired, -1:].real
        else:          # the slowest real root (built last), then the slowest pairs
            picked = np.column_stack([roots[paired, -1], roots[paired, : l - 1]])
        out = np.empty((len(etas), l + 1))
        out[over] = _poly_rows(slowest[over, :l])
        out[paired] = _poly_rows(picked)
        for r in np.flatnonzero(~over & ~paired):
            out[r] = _divisor_table(roots[r], indices)[l]
        divisors_[l] = out
    return divisors_[nbar], divisors_
