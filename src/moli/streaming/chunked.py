"""Batch MOLI estimation of records too long for memory, chunk by chunk.

Filter states are carried across chunks and each group of outputs keeps the R
factor of its augmented regression ``[phi, y]``, updated by a QR of
``[R_prev; rows_chunk]`` (:class:`moli.streaming.sqrt_rls.SquareRootRls` with no prior and
no forgetting). ``|Phi theta - y|^2 = |R11 theta - r12|^2 + r22^2`` and ``R11``
has the column norms of ``Phi``, so solving the small triangular problem with
:func:`moli.method.least_squares.estimation.solve_batch` gives the whole-record least-squares solution
of :func:`moli.estimate` (up to round-off), never forming normal equations.
Memory is constant: a few K x K factors plus one chunk.

Parts of one record can also be estimated apart and combined: :meth:`ChunkedEstimator.resume`
starts an estimator mid-record from given filter states, :meth:`ChunkedEstimator.state_map`
says how a chunk moves those states, and :meth:`ChunkedEstimator.merge` joins the factors
of consecutive parts (the R of ``[R_a; R_b]`` is the R of both parts' rows).
:func:`moli.fleets.chunk_reduction.estimate_chunks` builds on them.
"""

from __future__ import annotations

import copy
import warnings
from typing import Sequence

import numpy as np

from ..data.arguments import real_array
from ..errors import DataError, IllConditionedWarning, OptionError
from ..method.least_squares.estimation import COND_LIMIT, check_sample_count, realize, solve_batch
from ..models.statespace import StateSpaceModel
from .recursive import FixedFilterEstimator, checked_chunk
from ..numerics.blas_threads import limited_blas

__all__ = ["ChunkedEstimator"]


class ChunkedEstimator(FixedFilterEstimator):
    """Whole-record batch estimate accumulated over chunks of any sizes.

    Parameters
    ----------
    indices : sequence of int
        Observability indices, one per output.
    alpha : array_like
        Monic, stable filter polynomial of degree ``max(indices)``.
    m : int
        Number of inputs.
    Ts : float, default 1.0
        Sampling period given to the model.

    Attributes
    ----------
    start : int
        The record's sample this estimator began at (0, or as given to :meth:`resume`).
    samples : int
        The record's samples up to the last one absorbed (``start`` plus those absorbed).

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(300)
    >>> y = np.zeros(300)
    >>> for k in range(1, 300):
    ...     y[k] = 0.8 * y[k - 1] + 0.5 * u[k - 1]
    >>> est = ChunkedEstimator([1], moli.filter_polynomial(1.0, 1.0, [1]), 1)
    >>> est = est.add(y[:100], u[:100]).add(y[100:], u[100:])
    >>> np.round(est.model().poles().real, 6)
    array([0.8])

    The second half estimated apart, from the states the first half ends in, then merged:

    >>> first = ChunkedEstimator([1], moli.filter_polynomial(1.0, 1.0, [1]), 1).add(y[:150], u[:150])
    >>> second = ChunkedEstimator([1], first.alpha, 1).resume(150, first.filter_states())
    >>> both = first.merge(second.add(y[150:], u[150:]))
    >>> both.samples, np.round(both.model().poles().real, 6)
    (300, array([0.8]))
    """

    def __init__(self, indices: Sequence[int], alpha: Sequence[float], m: int, Ts: float = 1.0) -> None:
        # no forgetting, unit noise variance and no prior: the plain least-squares factor
        super().__init__(indices, alpha, m, Ts, 1.0, 1.0, p0=np.inf)
        self.start = 0

    def filter_states(self) -> list[np.ndarray]:
        """The filter states after the samples absorbed so far.

        Returns
        -------
        list of ndarray
            One per distinct index ``l`` (ascending), shape (2 l, p + m): the
            ``lfilter`` state of each signal, then its last ``l`` filtered samples.
        """
        return [state[0] for state in self._bank.filter_states()]

    def resume(self, start: int, states: Sequence[np.ndarray]) -> "ChunkedEstimator":
        """Begin mid-record: the next chunk starts at sample ``start``, the filters in ``states``.

        Parameters
        ----------
        start : int
            Samples of the record before the next chunk (the first ``max(indices)``
            samples of the record only charge the filters).
        states : sequence of ndarray
            The layout of :meth:`filter_states`, e.g. from an estimator that absorbed
            the record's first ``start`` samples.

        Returns
        -------
        ChunkedEstimator
            ``self``.
        """
        if self.samples:
            raise OptionError("resume an estimator before it absorbs any sample")
        if isinstance(start, bool) or not isinstance(start, (int, np.integer)) or start < 0:
            raise OptionError(f"start must be a sample count >= 0, got {start!r}")
        expected = [state.shape[1:] for state in self._bank.filter_states()]
        if isinstance(states, (str, bytes)) or not isinstance(states, Sequence):
            raise DataError(f"states must be the sequence of arrays filter_states() gives, got {states!r}")
        arrays = [real_array("each of the states", state, finite=False) for state in states]
        if [a.shape for a in arrays] != expected or not all(np.all(np.isfinite(a)) for a in arrays):
            raise DataError(f"states must be finite arrays of shapes {expected}")
        self._bank.resume(int(start), [a[None] for a in arrays])
        self.start = int(start)
        return self

    def state_map(self, y: object, u: object) -> list[tuple[np.ndarray, np.ndarray]]:
        """How a chunk moves the filter states, without absorbing it.

        Parameters
        ----------
        y : array_like, shape (N, p)
        u : array_like, shape (N, m)

        Returns
        -------
        list of (ndarray, ndarray)
            Per distinct index ``l`` (ascending), ``(T, s)`` of shapes (2 l, 2 l) and
            (2 l, p + m): a chunk that starts in state ``S`` ends in ``T @ S + s``.
        """
        z = checked_chunk(y, u, len(self.indices), self.m)
        return [(T[0], s[0]) for T, s in self._bank.state_map(z)]

    def merge(self, later: "ChunkedEstimator") -> "ChunkedEstimator":
        """This estimator and ``later``, which continued the same record, as one.

        Parameters
        ----------
        later : ChunkedEstimator
            Same indices, filter and inputs, resumed where this one ends
            (``later.start == self.samples``).

        Returns
        -------
        ChunkedEstimator
            A new estimator over both parts, equal (to round-off) to one that absorbed
            them in turn; neither input is changed. Merging is associative.
        """
        if not isinstance(later, ChunkedEstimator):
            raise OptionError(f"later must be a ChunkedEstimator, got {type(later).__name__}")
        if (later.indices, later.m) != (self.indices, self.m) or not np.array_equal(later.alpha, self.alpha):
            raise OptionError("merge needs estimators of the same indices, filter and inputs")
        if later.start != self.samples:
            raise DataError(
                f"later starts at sample {later.start}, but this estimator ends at {self.samples}"
            )
        merged = copy.deepcopy(self)
        merged._bank.merge(later._bank)
        return merged

    def add(self, y: object, u: object) -> "ChunkedEstimator":
        """Absorb the next chunk of the record.

        Parameters
        ----------
        y : array_like, shape (N, p)
            Outputs, time along axis 0 (1-D accepted when p = 1).
        u : array_like, shape (N, m)
            Inputs, time along axis 0 (1-D accepted when m = 1).

        Returns
        -------
        ChunkedEstimator
            ``self``.
        """
        with limited_blas():
            self._absorb(y, u)
            return self

    def model(self) -> StateSpaceModel:
        """The least-squares model of all samples absorbed so far.

        Warns
        -----
        IllConditionedWarning
            If a least-squares problem is badly conditioned (poor excitation).
        UnstableModelWarning
            If the model has poles on or outside the unit circle.
        """
        check_sample_count(self.samples, self.indices, self.m)
        thetas, worst = [], 1.0
        for count, factor in self._bank.factors():
            theta, cond = solve_batch(factor[:, :count, :count], factor[:, :count, count])
            thetas.append(theta)
            worst = max(worst, float(cond[0]))
        if worst > COND_LIMIT:
            warnings.warn(
                f"least-squares problem for list {list(self.indices)} is badly conditioned "
                f"(condition ~{worst:.2g}): the input may not excite the plant enough, or the "
                "order is too high for the data",
                IllConditionedWarning,
                stacklevel=2,
            )
        model = self._model(*realize(thetas, [self._alphas], self.indices, self.m))
        model.warn_if_unstable(stacklevel=2)
        return model
