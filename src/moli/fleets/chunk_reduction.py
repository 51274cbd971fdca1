"""Whole-record least squares over chunks read where they lie, on Dask workers.

A record too long for one machine is a sequence of chunks, each a function that
returns its ``(y, u)`` (a row group of a Parquet file, a slice of a Zarr array,
or samples generated on the spot; see :mod:`moli.data.chunks`). The estimate is the
one :class:`~moli.streaming.chunked.ChunkedEstimator` reaches by absorbing the chunks
in turn, computed in three steps, none of which gathers the record in one place:

1. **State maps.** The filters ``1/alpha_j`` are linear, so the filter state at the
   end of chunk ``k`` is ``T_k S_k + s_k`` of the state ``S_k`` at its start: ``s_k``
   is the chunk filtered from the zero state and ``T_k`` the free response of the unit
   states over the chunk's length, filtered the same way
   (:meth:`ChunkedEstimator.state_map`). Each worker returns the ``(T_k, s_k)`` of its
   chunk: a few small matrices.
2. **Scan.** The client runs ``S_{k+1} = T_k S_k + s_k`` from the zero state: the exact
   state at every chunk boundary (no overlap, no approximation), in microseconds.
3. **Factors and tree.** Each worker reads its chunk again, resumes the estimator
   from ``S_k`` (:meth:`ChunkedEstimator.resume`) and reduces the chunk to the R
   factors of its regressions; the factors of neighbouring chunks are joined by a QR
   of ``[R_a; R_b]`` (:meth:`ChunkedEstimator.merge`) in a binary tree.

Each chunk is read twice, one chunk per worker thread at a time, so a worker's
memory holds one chunk and a few ``K x K`` factors whatever the record's length;
``read_once=True`` reads it once and keeps it on its worker between the two passes.
"""

from __future__ import annotations

import contextlib
from typing import Any, Callable, Sequence

import numpy as np

from ..errors import DataError, OptionError
from ..streaming.chunked import ChunkedEstimator
from .backends import dask_completed
from .dask_workers import quiet_workers
from ..numerics.blas_threads import limited_blas

__all__ = ["estimate_chunks"]

Chunk = Callable[[], tuple[Any, Any]]
Spec = tuple[tuple[int, ...], np.ndarray, int, float]


def estimate_chunks(
    chunks: Sequence[Chunk],
    indices: Sequence[int],
    alpha: Sequence[float],
    m: int,
    *,
    client: Any = None,
    Ts: float = 1.0,
    read_once: bool = False,
) -> ChunkedEstimator:
    """The whole-record batch estimate of a chunked record, reduced on Dask workers.

    Parameters
    ----------
    chunks : sequence of callables
        The record in time order: ``chunk()`` returns that chunk's ``(y, u)``, shapes
        (N_k, p) and (N_k, m) (1-D for one channel). Each is sent to a worker and
        called there (twice, unless ``read_once``), so it should read or generate its
        samples rather than hold them: :func:`moli.data.chunks.list_chunks` gives such
        chunks for Parquet and Zarr files.
    indices : sequence of int
        Observability indices, one per output.
    alpha : array_like
        Monic, stable filter polynomial of degree ``max(indices)``.
    m : int
        Number of inputs.
    client : dask.distributed.Client, optional
        Where to run; None runs the same steps in this process.
    Ts : float, default 1.0
        Sampling period given to the model.
    read_once : bool, default False
        Keep each chunk's samples where they were read, from the state maps to the
        factors, instead of reading them again: for chunks slow to read or make. The
        cluster then holds the whole record at once (Dask spills what its workers'
        memory cannot hold to their disks); without a client, this process does.

    Returns
    -------
    ChunkedEstimator
        Holds the record's factors and its final filter states: ``.model()`` is the
        least-squares model, ``.add`` goes on with later samples. It equals a single
        :class:`ChunkedEstimator` fed the chunks in turn to round-off.

    Raises
    ------
    OptionError
        Invalid structure, filter, ``m``, ``Ts`` or ``client`` (before any work).
    DataError
        ``chunks`` is empty or holds something that is not callable; a chunk whose
        samples do not match ``p`` and ``m``.
    moli.fleets.backends.NoWorkersError
        The cluster had no worker for ``NO_WORKER_TIMEOUT`` seconds (Dask itself
        would wait forever).

    Examples
    --------
    >>> import numpy as np, moli
    >>> from functools import partial
    >>> u = np.random.default_rng(0).standard_normal(600)
    >>> y = moli.StateSpaceModel([[0.8]], [[0.5]], [[1.0]]).simulate(u)[:, 0]
    >>> def piece(a, b):
    ...     return y[a:b], u[a:b]
    >>> chunks = [partial(piece, a, a + 200) for a in range(0, 600, 200)]
    >>> est = estimate_chunks(chunks, [1], moli.filter_polynomial(1.0, 1.0, [1]), 1)
    >>> est.samples, np.round(est.model().poles().real, 6)
    (600, array([0.8]))
    """
    with limited_blas():
        template = ChunkedEstimator(indices, alpha, m, Ts)  # checks the structure first
        spec: Spec = (template.indices, template.alpha, template.m, template.Ts)
        chunks = list(chunks) if isinstance(chunks, Sequence) and not isinstance(chunks, str) else None
        if not chunks:
            raise DataError("chunks must be a non-empty sequence of callables returning (y, u)")
        for k, chunk in enumerate(chunks):
            if not callable(chunk):
                raise DataError(f"chunks[{k}] must be callable, returning (y, u); got {type(chunk).__name__}")
        if not isinstance(read_once, bool):
            raise OptionError(f"read_once must be True or False, got {read_once!r}")
        run = _Runner(client)
        with contextlib.nullcontext() if client is None else quiet_workers(client):
            # with read_once, a source is the future (or value) of a chunk's samples, else the chunk
            sources = [run.submit(_samples, chunk) for chunk in chunks] if read_once else chunks
            maps = run.gather([run.submit(_state_map, source, spec) for source in sources])
            starts, states = _scan(maps, template.filter_states())
            parts = [run.submit(_estimate, source, spec, start, state)
                     for source, start, state in zip(sources, starts, states)]
            del sources  # the factors' tasks hold the samples they need; nothing else should
            while len(parts) > 1:  # neighbours only: merging needs consecutive parts
                parts = [run.submit(ChunkedEstimator.merge, *parts[i : i + 2]) if i + 1 < len(parts) else parts[i]
                         for i in range(0, len(parts), 2)]
            return run.gather(parts)[0]


class _Runner:
    """Dask futures when a client is given; else the same calls, made here and now."""

    def __init__(self, client: Any) -> None:
        if client is not None and not (callable(getattr(client, "submit", None))
                                       and callable(getattr(client, "gather", None))):
            raise OptionError(f"client must be a dask.distributed.Client or None, got {type(client).__name__}")
        self.client = client

    def submit(self, function: Callable[..., Any], *args: Any) -> Any:
        if self.client is None:
            return function(*args)
        # pure=False: a chunk is a recipe, not data; hashing it would only cost time
        return self.client.submit(function, *args, pure=False)

    def gather(self, values: list[Any]) -> list[Any]:
        if self.client is None:
            return values
        for _ in dask_completed(self.client, values):  # fails, not hangs, on a cluster without workers
            pass
        return self.client.gather(values)


def _samples(source: Chunk | tuple[Any, Any]) -> tuple[Any, Any]:
    """A chunk's ``(y, u)``: read by calling it, or already read."""
    values = source() if callable(source) else source
    if not (isinstance(values, tuple) and len(values) == 2):
        raise DataError(f"a chunk must return (y, u), got {type(values).__name__}")
    return values


def _state_map(source: Any, spec: Spec) -> tuple[int, list[tuple[np.ndarray, np.ndarray]]]:
    """Step 1 on a worker: the chunk's length and how it moves the filter states."""
    y, u = _samples(source)
    estimator = ChunkedEstimator(*spec)
    maps = estimator.state_map(y, u)
    return int(np.shape(y)[0]), maps


def _scan(
    maps: list[tuple[int, list[tuple[np.ndarray, np.ndarray]]]], zero: list[np.ndarray]
) -> tuple[list[int], list[list[np.ndarray]]]:
    """Step 2 on the client: each chunk's first sample and its filter states there."""
    starts, states = [], []
    start, state = 0, [np.zeros_like(s) for s in zero]
    for length, chunk_map in maps:
        starts.append(start)
        states.append(state)
        state = [T @ S + s for (T, s), S in zip(chunk_map, state)]
        start += length
    return starts, states


def _estimate(source: Any, spec: Spec, start: int, states: list[np.ndarray]) -> ChunkedEstimator:
    """Step 3 on a worker: the chunk's factors, its filters started in their exact state."""
    y, u = _samples(source)
    return ChunkedEstimator(*spec).resume(start, states).add(y, u)
