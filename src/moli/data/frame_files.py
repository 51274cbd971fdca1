"""Files pandas reads into a data frame: Excel workbooks (.xlsx) and Parquet.

Rows of a sheet are numbered as the spreadsheet shows them (the header in row 1),
rows of a Parquet file from 1.
"""

from __future__ import annotations

from pathlib import Path

from .cells import optional, parsing
from .tables import Table, check_header, frame_table
from ..errors import DataError, OptionError

__all__ = ["read_excel", "read_parquet"]


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


def read_parquet(path: Path) -> Table:
    """The columns of a Parquet file (and its index, when pandas stored a named one)."""
    pd = optional("pandas", f"reading {path.name}")
    optional("pyarrow", f"reading {path.name}")
    with parsing(path, "a Parquet file"):
        frame = pd.read_parquet(path, engine="pyarrow")
    return frame_table(frame, str(path))
