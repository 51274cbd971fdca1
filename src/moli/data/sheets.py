"""Excel workbooks (.xlsx): the columns a request needs of one sheet, row by row.

openpyxl turns each cell into a Python value (shared text, number, date) at a cost far
above the XML parser's; a sheet of a few channels beside many other columns would pay
that for every column. Here only the header row and the cells of the needed columns are
converted; the others are skipped as XML elements. Cell values then meet the same
conversion pandas' ``read_excel`` gives them (error cells and ``NA`` text are missing,
numbers written as text are numbers), and rows are numbered as the spreadsheet shows
them (the header is row 1).
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Iterator

from .cells import optional, parsing
from .tables import Table, check_header, frame_table
from ..errors import DataError, OptionError

__all__ = ["check_sheet", "read_excel"]

# The last row number a worksheet may hold (Excel's limit): a row element that claims a
# higher one would make the missing rows before it an unbounded run of empty rows.
MAX_ROW = 1 << 20

_DIGITS = "0123456789"


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


def _rows(parser: object, source: object, wanted: Callable[[list[object]], set[int]]
          ) -> Iterator[tuple[int, dict[int, object], bool]]:
    """Each row element of a sheet as (row number, {column: value}, any cell filled).

    ``wanted`` gets the header row's values (by column from 0) and returns the columns
    whose cells are converted from then on; a cell of another column is only looked at
    for whether it holds anything, in a row whose wanted cells are all empty.
    """
    from openpyxl.utils.cell import column_index_from_string
    from openpyxl.xml.functions import iterparse

    row_tag = "{http://schemas.openxmlformats.org/spreadsheetml/2006/main}row"
    columns: set[int] | None = None
    number = 0
    for _, element in iterparse(source):
        if element.tag != row_tag:
            continue
        stated = element.get("r")
        number = int(float(stated)) if stated else number + 1
        if number > MAX_ROW:
            raise DataError(f"row {number} is beyond the last row of a worksheet ({MAX_ROW})")
        values: dict[int, object] = {}
        column = 0
        for cell in element:
            coordinate = cell.get("r")
            column = column_index_from_string(coordinate.rstrip(_DIGITS)) - 1 if coordinate else column + 1
            if columns is None or column in columns:
                parser.col_counter = column  # type: ignore[attr-defined]  # a cell without a coordinate follows the last
                found = parser.parse_cell(cell)  # type: ignore[attr-defined]
                if found["value"] is not None and found["data_type"] != "e":  # error cells are missing
                    values[column] = found["value"]
        filled = bool(values) or any(len(cell) for cell in element)
        element.clear()
        if columns is None:
            columns = wanted([values.get(k) for k in range(max(values, default=-1) + 1)])
        yield number, values, filled


def read_excel(path: Path, sheet: str | int | None,
               needed: Callable[[list[str]], set[str] | None] = lambda names: None) -> Table:
    """The columns of one sheet of an .xlsx workbook (the first unless ``sheet`` says).

    ``needed(names)`` says which columns to keep (None: all); the cells of the others
    are never converted. Rows after the last that holds a value anywhere are dropped.
    """
    pd = optional("pandas", f"reading {path.name}")
    optional("openpyxl", f"reading {path.name}")
    from openpyxl.reader.excel import ExcelReader
    from openpyxl.styles.stylesheet import apply_stylesheet
    from openpyxl.worksheet._reader import WorkSheetParser
    from pandas.io.parsers import TextParser

    with parsing(path, "an Excel .xlsx workbook"):
        # load_workbook would parse every worksheet once more to size it; only the
        # workbook's parts that give cells their values are read here
        reader = ExcelReader(path, read_only=True, data_only=True, keep_links=False)
        try:
            reader.read_manifest()
            reader.read_strings()
            reader.read_workbook()
            reader.read_theme()
            book = reader.wb
            apply_stylesheet(reader.archive, book)
            parts = {sheet.name: rel.target for sheet, rel in reader.parser.find_sheets()
                     if rel.target in reader.valid_files and "chartsheet" not in rel.Type}
            name = _chosen(sheet, list(parts), path)
            names: list[str] = []
            chosen: list[int] = []

            def wanted(header: list[object]) -> set[int]:
                # pandas names the columns: blank header cells "Unnamed: k", repeats "x.1"
                frame = TextParser([["" if cell is None else cell for cell in header]], header=0).read()
                names.extend(str(label) for label in frame.columns)
                kept = needed(names)
                chosen.extend(k for k, label in enumerate(names) if kept is None or label in kept)
                return set(chosen)

            rows: list[list[object]] = []
            last = 0  # rows up to here (of ``rows``) hold a value somewhere
            header = 0
            with reader.archive.open(parts[name]) as source:
                parser = WorkSheetParser(source, reader.shared_strings, data_only=True, epoch=book.epoch,
                                         date_formats=book._date_formats,
                                         timedelta_formats=book._timedelta_formats)
                for number, values, filled in _rows(parser, source, wanted):
                    header = header or number
                    if number <= header + len(rows):
                        continue  # the header, or a row out of order, as openpyxl skips it
                    # rows the sheet leaves out are empty
                    rows.extend([None] * len(chosen) for _ in range(number - header - 1 - len(rows)))
                    rows.append([values.get(k) for k in chosen])
                    last = len(rows) if filled else last
        finally:
            reader.archive.close()
        if not names:
            raise DataError(f"{path}, sheet {name!r} is empty: row 1 must name the columns")
        labels = [names[k] for k in chosen]
        frame = TextParser(rows[:last], header=None, names=labels).read() if last else pd.DataFrame(columns=labels)
    source_name = f"{path}, sheet {name!r}"
    check_header(names, source_name)

    def spreadsheet_row(index: int) -> str:
        return f"row {header + 1 + index}"

    return Table(frame_table(frame, source_name).columns, source_name, spreadsheet_row, names=tuple(names))
