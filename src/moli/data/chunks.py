"""Records too long to load at once, stored in pieces: Parquet row groups, Zarr chunks.

:func:`list_chunks` reads only the files' metadata and returns one
:class:`RecordChunk` per stored piece, in time order. A chunk is a small picklable
recipe; calling it reads that piece's samples, so a chunk can be sent to the machine
that holds (or can reach) the file and read there
(:func:`moli.fleets.chunk_reduction.estimate_chunks`).

Layouts: a Parquet file with one column per channel, read one row group at a time
(write it with ``row_group_size``); a Zarr group (a directory) with one 1-D array
per channel, read one chunk of the first input's array at a time.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence, Union

import numpy as np

from ..errors import DataError

__all__ = ["RecordChunk", "list_chunks"]

PathLike = Union[str, "os.PathLike[str]"]


@dataclass(frozen=True)
class RecordChunk:
    """Samples ``start:stop`` of a record stored in a file; calling it reads ``(y, u)``.

    Attributes
    ----------
    path : str
        The Parquet file or the Zarr group's directory.
    inputs, outputs : tuple of str
        Column (array) names of the channels.
    start, stop : int
        The piece's samples within the file.
    row_group : int or None
        The Parquet row group holding them; None for Zarr.
    """

    path: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    start: int
    stop: int
    row_group: int | None = None

    def __call__(self) -> tuple[np.ndarray, np.ndarray]:
        """The piece's outputs (N, p) and inputs (N, m), time along axis 0."""
        names = [*self.outputs, *self.inputs]
        try:
            if self.row_group is not None:
                import pyarrow.parquet as pq

                table = pq.ParquetFile(self.path).read_row_group(self.row_group, columns=names)
                columns = [table.column(name).to_numpy() for name in names]
            else:
                group = _zarr_group(Path(self.path))
                columns = [group[name][self.start : self.stop] for name in names]
            values = np.column_stack(columns).astype(float, copy=False)
        except DataError:
            raise
        except Exception as exc:  # pyarrow and zarr raise their own types; say which piece failed
            raise DataError(f"cannot read samples {self.start}:{self.stop} of {self.path}: {exc}") from None
        return values[:, : len(self.outputs)], values[:, len(self.outputs) :]


def list_chunks(
    paths: PathLike | Sequence[PathLike], inputs: Sequence[str], outputs: Sequence[str]
) -> list[RecordChunk]:
    """The stored pieces of a record, in time order, from the files' metadata.

    Parameters
    ----------
    paths : path or sequence of paths
        Parquet files (``.parquet``) and Zarr groups (directories), in time order:
        one record may span several files.
    inputs, outputs : sequence of str
        Column (array) names of the channels, in channel order.

    Returns
    -------
    list of RecordChunk
        One per Parquet row group or Zarr chunk along time.

    Raises
    ------
    DataError
        A missing file, an unsupported one, a missing channel, arrays of different
        lengths, or a reader that is not installed (``pyarrow``, ``zarr``).

    Examples
    --------
    >>> import tempfile, pathlib, pyarrow as pa, pyarrow.parquet as pq
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "long.parquet"
    >>> pq.write_table(pa.table({"u": [1.0, 0, 0, 0, 1], "y": [0, 1.0, 0.5, 0.2, 0]}), path,
    ...                row_group_size=2)
    >>> chunks = list_chunks(path, ["u"], ["y"])
    >>> [(c.start, c.stop) for c in chunks]
    [(0, 2), (2, 4), (4, 5)]
    >>> y, u = chunks[1]()
    >>> y.ravel().tolist(), u.ravel().tolist()
    ([0.5, 0.2], [0.0, 0.0])
    """
    inputs, outputs = tuple(map(str, inputs)), tuple(map(str, outputs))
    if not inputs or not outputs:
        raise DataError("name at least one input and one output column")
    if set(inputs) & set(outputs):
        raise DataError(f"columns {sorted(set(inputs) & set(outputs))} are named both as input and as output")
    many = [paths] if isinstance(paths, (str, os.PathLike)) else list(paths)
    if not many:
        raise DataError("paths must name at least one Parquet file or Zarr group")
    chunks: list[RecordChunk] = []
    for given in many:
        path = Path(given)
        if path.is_dir():
            chunks += _zarr_chunks(path, inputs, outputs)
        elif path.is_file() and path.suffix.lower() == ".parquet":
            chunks += _parquet_chunks(path, inputs, outputs)
        else:
            raise DataError(f"{path} is neither a .parquet file nor a Zarr group (directory)")
    return chunks


def _missing(source: Path, names: Sequence[str], have: Sequence[str]) -> None:
    absent = [name for name in names if name not in have]
    if absent:
        raise DataError(f"{source} has no column {absent[0]!r}; columns: {', '.join(map(repr, have))}")


def _parquet_chunks(path: Path, inputs: tuple[str, ...], outputs: tuple[str, ...]) -> list[RecordChunk]:
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise DataError(f"reading {path} needs pyarrow: pip install pyarrow") from None
    try:
        handle = pq.ParquetFile(path)
    except Exception as exc:  # pyarrow raises its own types for a damaged file
        raise DataError(f"cannot read {path}: {exc}") from None
    _missing(path, [*inputs, *outputs], handle.schema_arrow.names)
    chunks, start = [], 0
    for group in range(handle.metadata.num_row_groups):
        stop = start + handle.metadata.row_group(group).num_rows
        chunks.append(RecordChunk(str(path), inputs, outputs, start, stop, group))
        start = stop
    return chunks


def _zarr_group(path: Path) -> Any:
    try:
        import zarr
    except ImportError:
        raise DataError(f"reading {path} needs zarr: pip install zarr") from None
    try:
        return zarr.open_group(str(path), mode="r")
    except Exception as exc:  # zarr raises its own types for a directory that is no group
        raise DataError(f"cannot read {path} as a Zarr group: {exc}") from None


def _zarr_chunks(path: Path, inputs: tuple[str, ...], outputs: tuple[str, ...]) -> list[RecordChunk]:
    group = _zarr_group(path)
    _missing(path, [*inputs, *outputs], sorted(group.array_keys()))
    arrays = [group[name] for name in (*inputs, *outputs)]
    lengths = {array.shape for array in arrays}
    if len(lengths) != 1 or len(arrays[0].shape) != 1:
        raise DataError(f"the channels of {path} must be 1-D arrays of one length, got shapes {sorted(lengths)}")
    N, step = arrays[0].shape[0], arrays[0].chunks[0]
    return [RecordChunk(str(path), inputs, outputs, start, min(start + step, N))
            for start in range(0, N, step)]
