"""Lists of observability indices: validation and enumeration."""

from __future__ import annotations

from itertools import combinations
from typing import Iterator, Sequence

import numpy as np

from ...errors import StructureError

__all__ = ["check_indices", "compositions", "raised", "generic_indices", "parameter_counts"]

Indices = tuple[int, ...]


def check_indices(indices: Sequence[int], p: int) -> Indices:
    """Validate a list of observability indices for ``p`` outputs.

    Parameters
    ----------
    indices : sequence of int
        One positive integer per output.
    p : int
        Number of outputs.

    Returns
    -------
    tuple of int

    Examples
    --------
    >>> check_indices([1, 2, 1], 3)
    (1, 2, 1)
    """
    if isinstance(indices, (str, bytes)):
        raise StructureError(f"indices must be a list of positive integers, got {indices!r}")
    try:
        values = [int(v) for v in indices]
    except (TypeError, ValueError):
        raise StructureError(f"indices must be a list of positive integers, got {indices!r}") from None
    if any(float(v) != float(w) for v, w in zip(values, indices)):
        raise StructureError(f"indices must be integers, got {list(indices)}")
    if len(values) != p:
        raise StructureError(
            f"a list of observability indices needs one entry per output: "
            f"got {len(values)} entries for {p} outputs"
        )
    if min(values) < 1:
        raise StructureError(f"every observability index must be >= 1, got {values}")
    return tuple(values)


def compositions(n: int, p: int) -> Iterator[Indices]:
    """All lists of ``p`` positive indices summing to ``n`` (``C(n-1, p-1)`` of them).

    Examples
    --------
    >>> list(compositions(4, 2))
    [(1, 3), (2, 2), (3, 1)]
    """
    if n < p:
        return
    for cuts in combinations(range(1, n), p - 1):
        bounds = (0, *cuts, n)
        yield tuple(b - a for a, b in zip(bounds[:-1], bounds[1:]))


def raised(indices: Indices) -> list[Indices]:
    """The ``p`` lists obtained by raising one index of ``indices`` by one."""
    return [tuple(v + (i == j) for i, v in enumerate(indices)) for j in range(len(indices))]


def generic_indices(n: int, p: int) -> Indices:
    """The one list of order ``n >= p`` whose observer form spans almost every system of that order.

    With ``n = q p + r``: ``q + 1`` for the first ``r`` outputs, ``q`` for the others (the
    observability indices of a generic system, the rows picked in output order); its
    family is an open dense set of the ``p x m`` systems of order ``n``. Every other list
    spans a thinner family: the Jacobian of its simulation error has rank below
    ``n (p + m)`` (26 to 29 of 30 for the lists of 3 outputs, 3 inputs and order 5, against
    30 for (2, 2, 1); docs/method.md §12), and a plant outside it leaves a bias that no
    record length removes.
    """
    q, r = divmod(n, p)
    return tuple(q + 1 if j < r else q for j in range(p))


def parameter_counts(indices: Indices, m: int) -> np.ndarray:
    """Number of parameters of each output's regression: ``(p+m) l_j + j`` (0-based j)."""
    p = len(indices)
    return np.array([(p + m) * l + j for j, l in enumerate(indices)])
