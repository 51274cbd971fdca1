"""Continuous-time filters: alpha(s) from eta = (wc, zeta), its divisors, and the grid.

The root rule mirrors the discrete one (docs/method.md §2) in the s-plane
(docs/continuous.md §3). Roots are built for ``wc = 1``: the identification works in
the filter's own time unit ``tau = wc t``, where every filter of one ``zeta`` is the
same polynomial and the regressors are of comparable size whatever ``wc`` is.

- ``nbar = 1``: the real root ``-zeta``.
- The dominant pair ``-zeta +- i sqrt(1 - zeta^2)`` (for ``zeta >= 1`` the real roots
  ``-zeta +- sqrt(zeta^2 - 1)``); each next pair is the previous one times ``s``.
- An odd ``nbar`` ends with the real root ``s`` times the real part of the last root
  placed.
- When ``nbar`` is even, ``zeta < 1`` and an odd index below ``nbar`` needs a real
  root, the fastest pair (natural frequency ``r``) becomes the real roots ``-r`` and
  ``-s r``: distinct, unlike the discrete rule's double root, so that every filter has
  a full set of eigenvectors.

Each divisor takes the slowest roots (smallest decay rate ``-Re``) first, conjugate
pairs together; an odd degree first takes the slowest real root.
"""

from __future__ import annotations

import numpy as np

from ...errors import FilterError
from ..structure.filters import monic_from_roots, select_groups
from ..structure.indices import Indices

__all__ = ["unit_roots", "unit_divisors", "continuous_grid", "ZETAS"]

# The damping values of the discrete default grid (docs/method.md §5).
ZETAS = (0.6, 0.7, 1.1)
# Cutoffs per decade of the grid.
PER_DECADE = 2
# The slowest cutoff: this many radians over the longest segment (a filter slower
# than that has not settled within the record).
SLOWEST_RADIANS = 8.0 * np.pi
# The fastest cutoff, as a share of the Nyquist frequency pi / T of the median step.
# The outputs are taken as linear between samples, and the current sample enters its
# own regressors through that interpolation by a weight that grows with wc T: 0.15 of
# the fastest regressor's steady gain here, 0.44 at the discrete grid's top 0.356 pi
# (docs/continuous.md §2).
FASTEST_SHARE = 0.1


def unit_roots(zeta: float, indices: Indices, s: float) -> np.ndarray:
    """Roots of alpha(s) for ``wc = 1`` by the module's rule, slowest first."""
    nbar = max(indices)
    if nbar == 1:
        return np.array([-zeta], complex)
    if zeta < 1:
        pair = np.array([complex(-zeta, np.sqrt(1 - zeta**2)), complex(-zeta, -np.sqrt(1 - zeta**2))])
    else:
        spread = np.sqrt(zeta**2 - 1)
        pair = np.array([-zeta + spread, -zeta - spread], complex)
    roots: list[complex] = []
    while len(roots) + 2 <= nbar:
        roots.extend(pair)
        pair = pair * s
    if len(roots) < nbar:
        roots.append(complex(s * roots[-1].real))
    elif zeta < 1 and any(l % 2 == 1 and l < nbar for l in indices):
        r = abs(roots[-1])
        roots[-2:] = [complex(-r), complex(-s * r)]
    return np.array(roots)


def _groups(roots: np.ndarray) -> list[tuple]:
    """Real singles and conjugate pairs, slowest decay first (a real root after a pair)."""
    groups = [(r.real,) for r in roots if r.imag == 0] + [(r, r.conjugate()) for r in roots if r.imag > 0]
    groups.sort(key=lambda g: (-g[0].real, len(g) == 1))
    return groups


def unit_divisors(zeta: float, indices: Indices, s: float) -> list[np.ndarray]:
    """``alpha`` (``wc = 1``) and each output's divisor: coefficients, highest power first.

    Returns ``[alpha, alpha_1, ..., alpha_p]``.
    """
    roots = unit_roots(zeta, indices, s)
    alpha = monic_from_roots(roots)
    out = [alpha]
    for l in indices:
        if l == roots.size:
            out.append(alpha)
            continue
        chosen = select_groups(_groups(roots), l)
        if chosen is None:  # pragma: no cover - the rule always places a needed real root
            raise FilterError(f"no real divisor of degree {l} of the filter with roots {roots.tolist()}")
        values = np.array([r for g in chosen for r in g], complex)
        out.append(monic_from_roots(values))
    return out


def continuous_grid(steps: np.ndarray, durations: np.ndarray) -> np.ndarray:
    """The default candidates ``(wc, zeta)`` in rad per time unit for these stamps.

    Cutoffs log-spaced at :data:`PER_DECADE` per decade from
    ``SLOWEST_RADIANS / longest segment`` to ``FASTEST_SHARE pi / median step``, each
    with every damping of :data:`ZETAS`.
    """
    fastest = FASTEST_SHARE * np.pi / float(np.median(steps))
    slowest = min(SLOWEST_RADIANS / float(np.max(durations)), fastest / 10.0)
    count = max(int(np.ceil(PER_DECADE * np.log10(fastest / slowest))) + 1, 2)
    wcs = np.geomspace(slowest, fastest, count)
    return np.array([(wc, zeta) for zeta in ZETAS for wc in wcs])
