"""Files pandas reads into a data frame: Parquet, and chunks of any table joined into columns.

Rows of a Parquet file are numbered from 1.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterable

import numpy as np

from .cells import optional, parsing
from .tables import Table, frame_table

__all__ = ["read_parquet", "join_chunks"]

if TYPE_CHECKING:  # pandas is optional
    import pandas as pd

# Rows converted at a time: a long record is held as its columns of numbers, never as
# its whole text, or as one frame beside them.
CHUNK_ROWS = 1 << 18


def join_chunks(chunks: Iterable["pd.DataFrame"], source: str, names: list[str]) -> dict[str, np.ndarray]:
    """The columns ``names`` of a table read chunk by chunk, each joined into one array.

    The other columns are dropped with each chunk. A column of numbers is float in every
    chunk and stays so; one with a text cell somewhere becomes an object array, whose
    cells the table's checks then look at.
    """
    parts: dict[str, list[np.ndarray]] = {name: [] for name in names}
    for chunk in chunks:
        for name, values in frame_table(chunk, source).columns.items():
            if name in parts:
                parts[name].append(values)
    return {name: np.concatenate(parts.pop(name)) if parts[name] else np.empty(0)
            for name in names}


def read_parquet(path: Path, needed: Callable[[list[str]], set[str] | None]) -> Table:
    """The columns of a Parquet file (and its index, when pandas stored a named one).

    ``needed(names)`` says which columns to keep; None (no channels named, which a
    Parquet file cannot mark) keeps none. The file is converted :data:`CHUNK_ROWS` rows
    at a time, so the others never take memory.
    """
    optional("pandas", f"reading {path.name}")
    parquet = optional("pyarrow.parquet", f"reading {path.name}")
    with parsing(path, "a Parquet file"):
        file = parquet.ParquetFile(path)
        # pandas stores an unnamed index that is not a range as __index_level_0__
        names = [name for name in file.schema_arrow.names if not name.startswith("__index_level_")]
        kept = needed(names) or set()
        chosen = [name for name in names if name in kept]
        chunks = (batch.to_pandas() for batch in file.iter_batches(CHUNK_ROWS, columns=chosen)) if chosen else ()
        columns = join_chunks(chunks, str(path), chosen)
    return Table(columns, str(path), names=tuple(names))
