"""Files pandas reads into a data frame: Excel workbooks (.xlsx) and Parquet.

Rows of a sheet are numbered as the spreadsheet shows them (the header in row 1),
rows of a Parquet file from 1.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterable

import numpy as np

from .cells import optional, parsing
from .tables import Table, check_header, frame_table
from ..errors import DataError, OptionError

__all__ = ["read_excel", "read_parquet", "join_chunks"]

if TYPE_CHECKING:  # pandas is optional
    import pandas as pd

# Rows converted at a time: a long record is held as its columns of numbers, never as
# its whole text, or as one frame beside them.
CHUNK_ROWS = 1 << 18


def check_sheet(sheet: object) -> str | int | None:
    """A sheet name or 0-based position, or an error saying what is accepted."""
    if sheet is None or isinstance(sheet, str) or isinstance(sheet, int) and not isinstance(sheet, bool) and sheet >= 0:
        return sheet  # type: ignore[return-value]
    raise OptionError(f"sheet must be a sheet name or a position from 0, got {sheet!r}")


def _chosen(sheet: str | int | None, names: list[str], path: Path) -> str:
    if sheet is None:
        return names[0]
    if isinstance(sheet, str) and sheet not in names and sheet.isdigit():
        sheet = int(sheet)  # the command line passes positions as text
    if isinstance(sheet, int) and sheet < len(names):
        return names[sheet]
    if sheet in names:
        return sheet  # type: ignore[return-value]
    raise DataError(f"{path} has no sheet {sheet!r}; sheets: {', '.join(map(repr, names))}")


def _spreadsheet_row(index: int) -> str:
    return f"row {index + 2}"


def read_excel(path: Path, sheet: str | int | None) -> Table:
    """The columns of one sheet of an .xlsx workbook (the first unless ``sheet`` says)."""
    pd = optional("pandas", f"reading {path.name}")
    optional("openpyxl", f"reading {path.name}")
    with parsing(path, "an Excel .xlsx workbook"):
        with pd.ExcelFile(path, engine="openpyxl") as book:
            name = _chosen(sheet, list(book.sheet_names), path)
            frame = pd.read_excel(book, sheet_name=name)
    source = f"{path}, sheet {name!r}"
    check_header(list(frame.columns), source)
    return frame_table(frame, source, _spreadsheet_row)


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


def read_parquet(path: Path, needed: Callable[[list[str]], set[str] | None] = lambda names: None) -> Table:
    """The columns of a Parquet file (and its index, when pandas stored a named one).

    ``needed(names)`` says which columns to keep (None: all); the file is converted
    :data:`CHUNK_ROWS` rows at a time, so the others never take memory.
    """
    optional("pandas", f"reading {path.name}")
    parquet = optional("pyarrow.parquet", f"reading {path.name}")
    with parsing(path, "a Parquet file"):
        file = parquet.ParquetFile(path)
        # pandas stores an unnamed index that is not a range as __index_level_0__
        names = [name for name in file.schema_arrow.names if not name.startswith("__index_level_")]
        kept = needed(names)
        chosen = None if kept is None else [name for name in names if name in kept]
        chunks = (batch.to_pandas() for batch in file.iter_batches(CHUNK_ROWS, columns=chosen))
        columns = join_chunks(chunks, str(path), names if chosen is None else chosen)
    return Table(columns, str(path), names=tuple(names))
