"""Excel workbooks (.xlsx): the columns a request needs of one sheet, row by row.

openpyxl turns each cell into a Python value (shared text, number, date) at a cost far
above the XML parser's; a sheet of a few channels beside many other columns would pay
that for every column. Here the sheet's XML is fed to the parser in blocks, and only the
header row and the cells of the needed columns become elements: another column's cell
is only looked at for whether it holds anything, its text never kept, however long.
Shared texts (the workbook's table of strings) are looked up once the cells that refer
to them are known, keeping only those. Memory is so bounded by the columns read, not by
what the workbook inflates to. Cell values then meet the same conversion pandas'
``read_excel`` gives them (error cells and ``NA`` text are missing, numbers written as
text are numbers), and rows are numbered as the spreadsheet shows them (the header is
row 1).
"""

from __future__ import annotations

from pathlib import Path
from typing import IO, Callable, Iterator
from xml.etree.ElementTree import Element, TreeBuilder, XMLParser

from .cells import optional, parsing
from .tables import Table, check_header, frame_table
from ..errors import DataError, OptionError

__all__ = ["check_sheet", "read_excel"]

# The last row number a worksheet may hold (Excel's limit): a row element that claims a
# higher one would make the missing rows before it an unbounded run of empty rows.
MAX_ROW = 1 << 20
# Bytes of a workbook part fed to the XML parser at a time.
FEED_BYTES = 1 << 16
MAIN = "{http://schemas.openxmlformats.org/spreadsheetml/2006/main}"

_DIGITS = "0123456789"


class SharedText:
    """A cell's reference to the workbook's table of strings, looked up later."""

    __slots__ = ("index",)

    def __init__(self, index: int) -> None:
        self.index = index


class _Deferred:
    """Stands for openpyxl's list of shared strings: each lookup gives a :class:`SharedText`."""

    def __getitem__(self, index: int) -> SharedText:
        return SharedText(index)


class _Target:
    """Parser events with no document type: a workbook part never declares one, and an
    entity declared in one could expand a few bytes into gigabytes."""

    def doctype(self, name: str, pubid: str | None, system: str | None) -> None:
        raise DataError(f"the workbook declares a document type ({name!r}); an .xlsx part never does")

    def close(self) -> None:
        return None


class _SheetCells(_Target):
    """Each row of a worksheet as (its ``r``, [(column, cell element)], any cell filled),
    elements built for every cell of the first row, then for the columns that
    ``header(first row's cells)`` returns."""

    def __init__(self, header: Callable[[list[tuple[int, Element]]], set[int]]) -> None:
        from openpyxl.utils.cell import column_index_from_string

        self.header = header
        self._index = column_index_from_string
        self.columns: set[int] | None = None
        self.rows: list[tuple[str | None, list[tuple[int, Element]], bool]] = []
        self._row: tuple[str | None, list[tuple[int, Element]]] | None = None
        self._filled = False
        self._column = -1
        self._cell: TreeBuilder | None = None
        self._depth = 0
        self._skipped = False

    def start(self, tag: str, attrib: dict[str, str]) -> None:
        if self._cell is not None:
            self._cell.start(tag, attrib)
            self._depth += 1
        elif tag == MAIN + "row":
            self._row, self._filled, self._column = (attrib.get("r"), []), False, -1
        elif tag == MAIN + "c" and self._row is not None:
            coordinate = attrib.get("r")
            self._column = self._index(coordinate.rstrip(_DIGITS)) - 1 if coordinate else self._column + 1
            if self.columns is None or self._column in self.columns:
                self._cell, self._depth = TreeBuilder(), 1
                self._cell.start(tag, attrib)
            else:
                self._skipped = True
        elif self._skipped:
            self._filled = True  # a value, formula or text in a cell of another column

    def data(self, text: str) -> None:
        if self._cell is not None:
            self._cell.data(text)

    def end(self, tag: str) -> None:
        if self._cell is not None:
            self._cell.end(tag)
            self._depth -= 1
            if self._depth == 0 and self._row is not None:
                self._row[1].append((self._column, self._cell.close()))
                self._cell = None
        elif tag == MAIN + "c":
            self._skipped = False
        elif tag == MAIN + "row" and self._row is not None:
            self.rows.append((*self._row, self._filled))
            if self.columns is None:
                self.columns = self.header(self._row[1])
            self._row = None


class _SharedTexts(_Target):
    """The texts of the shared strings numbered in ``wanted`` (phonetic runs left out,
    as openpyxl reads them); the others are counted, never kept."""

    def __init__(self, wanted: set[int]) -> None:
        self.wanted = wanted
        self.found: dict[int, str] = {}
        self._count = -1
        self._parts: list[str] | None = None
        self._phonetic = 0
        self._text = False

    def start(self, tag: str, attrib: dict[str, str]) -> None:
        if tag == MAIN + "si":
            self._count += 1
            self._parts = [] if self._count in self.wanted else None
        elif tag == MAIN + "rPh":
            self._phonetic += 1
        elif tag == MAIN + "t":
            self._text = self._parts is not None and not self._phonetic

    def data(self, text: str) -> None:
        if self._text and self._parts is not None:
            self._parts.append(text)

    def end(self, tag: str) -> None:
        if tag == MAIN + "t":
            self._text = False
        elif tag == MAIN + "rPh":
            self._phonetic -= 1
        elif tag == MAIN + "si" and self._parts is not None:
            self.found[self._count] = "".join(self._parts).replace("x005F_", "")
            self._parts = None


def _feed(source: IO[bytes], target: _Target) -> Iterator[None]:
    """Feed a workbook part to ``target`` block by block, pausing after each."""
    parser = XMLParser(target=target)
    for block in iter(lambda: source.read(FEED_BYTES), b""):
        parser.feed(block)
        yield
    parser.close()
    yield


def _looked_up(values: list[list[object]], archive: object, part: str | None) -> None:
    """Replace each :class:`SharedText` in ``values`` (rows of cells) by its text, in place."""
    wanted = {cell.index for row in values for cell in row if isinstance(cell, SharedText)}
    if not wanted:
        return
    target = _SharedTexts(wanted)
    if part is not None:
        with archive.open(part) as source:  # type: ignore[attr-defined]
            for _ in _feed(source, target):
                if len(target.found) == len(wanted):
                    break
    missing = wanted - set(target.found)
    if missing:
        raise DataError(f"a cell refers to shared string {min(missing)}, which the workbook lacks")
    for row in values:
        row[:] = [target.found[cell.index] if isinstance(cell, SharedText) else cell for cell in row]


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


def _rows(parser: object, source: IO[bytes], wanted: Callable[[list[object]], set[int]]
          ) -> Iterator[tuple[int, dict[int, object], bool]]:
    """Each row element of a sheet as (row number, {column: value}, any cell filled).

    ``wanted`` gets the header row's values (by column from 0) and returns the columns
    whose cells are converted from then on; a cell of another column is only looked at
    for whether it holds anything. Shared texts come as :class:`SharedText`.
    """
    def values(kept: list[tuple[int, Element]]) -> dict[int, object]:
        found: dict[int, object] = {}
        for column, element in kept:
            parser.col_counter = column  # type: ignore[attr-defined]  # a cell without a coordinate follows the last
            cell = parser.parse_cell(element)  # type: ignore[attr-defined]
            if cell["value"] is not None and cell["data_type"] != "e":  # error cells are missing
                found[column] = cell["value"]
        return found

    first: list[dict[int, object]] = []  # the header's values, converted once

    def header(kept: list[tuple[int, Element]]) -> set[int]:
        first.append(values(kept))
        return wanted([first[0].get(k) for k in range(max(first[0], default=-1) + 1)])

    cells = _SheetCells(header)
    number = 0
    for _ in _feed(source, cells):
        finished, cells.rows = cells.rows, []
        for stated, kept, filled in finished:
            number = int(float(stated)) if stated else number + 1
            if number > MAX_ROW:
                raise DataError(f"row {number} is beyond the last row of a worksheet ({MAX_ROW})")
            found = first.pop() if first else values(kept)
            yield number, found, filled or bool(found) or any(len(element) for _, element in kept)


def read_excel(path: Path, sheet: str | int | None, needed: Callable[[list[str]], set[str] | None]) -> Table:
    """The columns of one sheet of an .xlsx workbook (the first unless ``sheet`` says).

    ``needed(names)`` says which columns to keep; None (no channels named, which a sheet
    cannot mark) keeps none, so only the header is read. The cells of the other columns
    are never converted. Rows after the last that holds a value anywhere are dropped.
    """
    pd = optional("pandas", f"reading {path.name}")
    optional("openpyxl", f"reading {path.name}")
    from openpyxl.reader.excel import ExcelReader
    from openpyxl.styles.stylesheet import apply_stylesheet
    from openpyxl.worksheet._reader import WorkSheetParser
    from openpyxl.xml.constants import SHARED_STRINGS
    from pandas.io.parsers import TextParser

    with parsing(path, "an Excel .xlsx workbook"):
        # load_workbook would parse every worksheet once more to size it; only the
        # workbook's parts that give cells their values are read here
        reader = ExcelReader(path, read_only=True, data_only=True, keep_links=False)
        try:
            reader.read_manifest()
            listed = reader.package.find(SHARED_STRINGS)
            strings = listed.PartName[1:] if listed is not None else None
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
                cells = [list(header)]
                _looked_up(cells, reader.archive, strings)
                # pandas names the columns: blank header cells "Unnamed: k", repeats "x.1"
                frame = TextParser([["" if cell is None else cell for cell in cells[0]]], header=0).read()
                names.extend(str(label) for label in frame.columns)
                kept = needed(names) or set()
                chosen.extend(k for k, label in enumerate(names) if label in kept)
                return set(chosen)

            rows: list[list[object]] = []
            last = 0  # rows up to here (of ``rows``) hold a value somewhere
            header = 0
            with reader.archive.open(parts[name]) as source:
                parser = WorkSheetParser(source, _Deferred(), data_only=True, epoch=book.epoch,
                                         date_formats=book._date_formats,
                                         timedelta_formats=book._timedelta_formats)
                for number, values, filled in _rows(parser, source, wanted):
                    header = header or number
                    if not chosen:
                        break  # no column to read: the header is all the table gives
                    if number <= header + len(rows):
                        continue  # the header, or a row out of order, as openpyxl skips it
                    # rows the sheet leaves out are empty
                    rows.extend([None] * len(chosen) for _ in range(number - header - 1 - len(rows)))
                    rows.append([values.get(k) for k in chosen])
                    last = len(rows) if filled else last
            _looked_up(rows, reader.archive, strings)
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
