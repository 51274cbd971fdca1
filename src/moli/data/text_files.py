"""Text tables (.csv, .tsv, .txt): encoding, delimiter and decimal mark, then pandas.

The file is decoded here (byte-order mark, else UTF-8, else charset-normalizer's
guess, or the encoding given), the delimiter and the decimal mark are sniffed from its
first lines unless given, and pandas parses the text. Line numbers in messages count
every line of the file from 1, the header included.
"""

from __future__ import annotations

import codecs
import csv
import functools
import itertools
import re
from pathlib import Path
from typing import BinaryIO, Callable, Iterator

from . import frame_files
from .cells import optional
from .frame_files import join_chunks
from .tables import Table, check_header
from ..errors import DataError, OptionError

__all__ = ["detect_encoding"]

# Byte-order marks, the 4-byte UTF-32 ones before UTF-16's that they begin with.
BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
    (codecs.BOM_UTF8, "utf-8-sig"),
    (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16"),
)
# The encoding detector reads this much of a file; a plant record's header and first
# rows are text enough, and the detector's time grows with its input.
DETECT_BYTES = 1 << 18
# Without a byte-order mark or valid UTF-8, the encoding is told from this much of the
# file's beginning: a legacy code page's letters show in a logger's header and first rows.
LEGACY_BYTES = 1 << 24
# This many zero bytes in a row are no text in any encoding: without the character U+0000,
# UTF-8, -16 and -32 have at most 5 in a row (UTF-32: the 3 high bytes of one character
# and the 2 low bytes of the next). Padding left by a crash, or binary data.
ZERO_RUN = b"\x00" * 8
# The sniffed lines are read whole up to this many bytes in all.
SNIFF_BYTES = 1 << 26
# Bytes read at a time when checking that a file is UTF-8.
BLOCK_BYTES = 1 << 22
WHITESPACE = r"\s+"
# Tried in this order: a file with decimal commas separates its columns with ";" or a
# tab, so those win over "," when several split every line alike.
DELIMITERS = ("\t", ";", ",", "|")
DELIMITER_NAMES = {"tab": "\t", "comma": ",", "semicolon": ";", "space": WHITESPACE,
                   "whitespace": WHITESPACE}
DECIMALS = (".", ",")
# The delimiter and decimal mark are sniffed from the header and this many lines.
SNIFF_LINES = 50
# Without a byte-order mark or valid UTF-8, the detector chooses among these: the code
# pages plant software writes. Rare ones are left out, since on a few words of text
# the detector would otherwise find, say, Urdu as likely as French.
LEGACY_ENCODINGS = (
    "cp1250", "cp1251", "cp1253", "cp1254", "cp1255", "cp1256", "cp1257", "cp1258", "cp874",
    "koi8_r", "koi8_u", "cp866", "cp932", "euc_jp", "gb18030", "big5", "cp949",
)
# Words that have accented letters, read as cp1252, have at most this share of them
# in a Western European language.
WESTERN_SHARE = 0.5
WORD = re.compile(r"[^\W\d_]+")
LINE = re.compile(r"([^\r\n]*)(?:\r\n|\r|\n|$)")
# Characters that never occur in a text table: their presence means binary data.
CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")
COMMA_NUMBER = re.compile(r"^[+-]?\d*,\d+(?:[eE][+-]?\d+)?$")
POINT_NUMBER = re.compile(r"^[+-]?\d*\.\d+(?:[eE][+-]?\d+)?$")


def check_text_options(delimiter: object, decimal: object, encoding: object) -> tuple[str | None, str | None, str | None]:
    """The delimiter, decimal mark and encoding asked for, or an error saying what is accepted."""
    if delimiter is not None:
        if not isinstance(delimiter, str) or not (
            delimiter.lower() in DELIMITER_NAMES
            or len(delimiter) == 1 and not delimiter.isalnum() and delimiter not in '."'
        ):
            raise OptionError(f"delimiter must be one character such as ',' ';' '|' or a tab, or one of "
                              f"{', '.join(DELIMITER_NAMES)}; got {delimiter!r}")
        delimiter = DELIMITER_NAMES.get(delimiter.lower(), delimiter)
    if decimal is not None and decimal not in DECIMALS:
        raise OptionError(f"decimal must be '.' or ',', got {decimal!r}")
    if delimiter is not None and delimiter == decimal:
        raise OptionError(f"the delimiter and the decimal mark are both {decimal!r}")
    if encoding is not None:
        try:
            codec = codecs.lookup(str(encoding))
        except LookupError:
            codec = None
        if codec is None or not getattr(codec, "_is_text_encoding", True):   # rot13, base64: no text file's
            raise OptionError(f"unknown text encoding {encoding!r}; e.g. utf-8, utf-16, latin-1, cp1252")
        encoding = codec.name
    return delimiter, decimal, encoding  # type: ignore[return-value]


def _sample(raw: bytes, limit: int = DETECT_BYTES) -> bytes:
    """The head of ``raw`` up to ``limit`` bytes, cut after a line end (and its UTF-16 zero byte)."""
    if len(raw) <= limit:
        return raw
    end = raw.rfind(b"\n", 0, limit) + 1 or limit
    return raw[: end + 1] if raw[end:end + 1] == b"\x00" else raw[:end]


def _decodes(raw: bytes, encoding: str) -> bool:
    try:
        raw.decode(encoding)
    except UnicodeDecodeError:
        return False
    return True


def _western(text: str) -> bool:
    """True when ``text`` reads as a Western European language in which it was decoded.

    Words with accented letters keep most of their letters plain in Western languages
    ("température", "Durchfluß"); Cyrillic, Greek or East Asian bytes read as cp1252
    give words of accented letters only ("âðåìÿ"). Each word counts once, so a status
    word repeated on every row weighs no more than a column name.
    """
    words = {word for word in WORD.findall(text) if not word.isascii()}
    letters = sum(len(word) for word in words)
    accented = sum(not char.isascii() for word in words for char in word)
    return accented <= WESTERN_SHARE * letters


def detect_encoding(raw: bytes) -> str:
    """The text encoding of a file's bytes.

    A byte-order mark decides (UTF-8, UTF-16, UTF-32). Otherwise bytes that are valid
    UTF-8 are UTF-8 (plain ASCII included). Zero bytes mean UTF-16 or UTF-32 without a
    mark, which charset-normalizer tells apart. Other bytes are read as the Windows
    Western code page cp1252 (Latin-1 where cp1252 leaves a byte undefined) when that
    gives words of a Western European language; if not, charset-normalizer chooses
    among the common legacy code pages (Cyrillic, Greek, Central European, Japanese,
    Chinese, Korean...). A few accented letters cannot tell cp1252 from other Latin
    code pages such as cp1250, nor can a handful of East Asian characters identify
    their encoding: give the encoding when column names come out wrong.

    Parameters
    ----------
    raw : bytes
        The file's content (or its beginning).

    Returns
    -------
    str
        A name :func:`codecs.lookup` knows.

    Examples
    --------
    >>> detect_encoding("temps;température\\n0;1\\n".encode("utf-16"))
    'utf-16'
    >>> detect_encoding("temps;température\\n0;1\\n".encode("latin-1"))
    'cp1252'
    """
    for bom, name in BOMS:
        if raw.startswith(bom):
            return name
    if b"\x00" not in raw and _decodes(raw, "utf-8"):
        return "utf-8"
    western = "cp1252" if _decodes(raw, "cp1252") else "latin-1"
    if b"\x00" not in raw and _western(raw.decode(western)):
        return western
    detector = optional("charset_normalizer", "detecting the encoding of a text file")
    candidates = None if b"\x00" in raw else list(LEGACY_ENCODINGS)
    best = detector.from_bytes(_sample(raw), cp_isolation=candidates).best()
    return western if best is None else best.encoding


def _undecodable(path: Path, encoding: str, given: bool) -> DataError:
    """The error naming the line of the file's first byte that does not decode as
    ``encoding``, found block by block (the file is never held whole)."""
    decoder = codecs.getincrementaldecoder(encoding)()
    lines, bad = 1, None
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(BLOCK_BYTES), b""):
            held = bytes(getattr(decoder, "buffer", b""))  # bytes of a character cut by the last block
            try:
                decoder.decode(block)
            except UnicodeDecodeError as exc:
                data = held + block
                lines, bad = lines - held.count(b"\n") + data[: exc.start].count(b"\n"), data[exc.start]
                break
            lines += block.count(b"\n")
    how = "" if given else " (detected)"
    shown = f"byte 0x{bad:02x}" if bad is not None else "its last bytes, a character cut short,"
    return DataError(f"{path} is not {encoding}{how} text: {shown} on line {lines} does not decode; give the "
                     "file's encoding (encoding= or --encoding), e.g. utf-8, utf-16, cp1252")


def _scan(path: Path) -> int | None:
    """The offset of the file's first byte that is not UTF-8 text (a zero byte counts),
    None when there is none; the file is read block by block.

    A run of :data:`ZERO_RUN` zero bytes anywhere is an error here, before any decoding
    or parsing: a file padded with zeros would otherwise be taken for UTF-16 and read
    whole, or parsed as one endless line.
    """
    decoder = codecs.getincrementaldecoder("utf-8")()
    first, done, tail = None, 0, b""
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(BLOCK_BYTES), b""):
            joined = tail + block
            found = joined.find(ZERO_RUN)
            if found >= 0:
                raise DataError(
                    f"{path} is not a text table: it holds zero bytes from byte {done - len(tail) + found} "
                    "on (a file padded with zeros after a crash, or binary data); cut the file before "
                    "them, or is it another format with the wrong suffix?")
            if first is None:
                first = _not_utf8(decoder, block, done)
            tail, done = joined[1 - len(ZERO_RUN):], done + len(block)
    return _not_utf8(decoder, b"", done, final=True) if first is None else first


def _not_utf8(decoder: codecs.BufferedIncrementalDecoder, block: bytes, done: int,
              final: bool = False) -> int | None:
    """Where in the file (``block`` starts at byte ``done``) UTF-8 stops, or None."""
    held = len(decoder.buffer)  # bytes of a character the last block cut
    zero = block.find(b"\x00")
    try:
        decoder.decode(block if zero < 0 else block[:zero], final)
    except UnicodeDecodeError as exc:
        return done - held + exc.start
    return None if zero < 0 else done + zero


def _file_encoding(path: Path, head: bytes, first: int | None) -> str:
    """:func:`detect_encoding` of the file (``first``: where UTF-8 stops, from :func:`_scan`)
    without holding it in memory: a file that is not UTF-8 is told from its first
    :data:`LEGACY_BYTES` and, when ``first`` lies beyond them, the lines around it."""
    if any(head.startswith(bom) for bom, _ in BOMS):
        return detect_encoding(head)
    if first is None:
        return "utf-8"
    with path.open("rb") as handle:
        raw = _sample(handle.read(LEGACY_BYTES + 1), LEGACY_BYTES)
        if first >= len(raw):
            handle.seek(max(first - DETECT_BYTES, 0))
            window = handle.read(2 * DETECT_BYTES)
            raw += window[window.find(b"\n") + 1: window.rfind(b"\n") + 1 or None]
    return detect_encoding(raw)


def _head_text(head: bytes, encoding: str, path: Path, given: bool) -> str:
    """The first bytes of the file as text (a character cut at the end is left out); binary
    data in them is an error, since it shows at once in a file of another format."""
    try:
        text = codecs.getincrementaldecoder(encoding)().decode(head)
    except UnicodeDecodeError:
        raise _undecodable(path, encoding, given) from None
    except UnicodeError as exc:           # utf-16 and utf-32 of a file without a byte-order mark
        raise DataError(f"{path} cannot be read as {encoding}: {exc}; give the byte order (e.g. utf-16-le)") from None
    bad = CONTROL.search(text)
    if bad:
        line = text.count("\n", 0, bad.start()) + 1
        raise DataError(
            f"{path} is not a text table: it holds binary data (character "
            f"0x{ord(bad.group()):02x} on line {line} as {encoding}); is it the right file, or "
            "another format with the wrong suffix?"
        )
    return text


def _fields(line: str, delimiter: str) -> list[str]:
    if delimiter == WHITESPACE:
        return line.split()
    if '"' not in line:  # nothing quoted: the csv module's field size limit need not apply
        return line.split(delimiter)
    limit = csv.field_size_limit()
    csv.field_size_limit(max(limit, len(line) + 1))  # a wide table's line is one field for the wrong delimiter
    try:
        return next(csv.reader([line], delimiter=delimiter))
    finally:
        csv.field_size_limit(limit)


def sniff_delimiter(lines: list[str]) -> str:
    """The first delimiter of :data:`DELIMITERS` (else whitespace) that splits every line
    into the same number (> 1) of fields; failing that, the one that splits the header most.
    """
    for delimiter in (*DELIMITERS, WHITESPACE):
        counts = {len(_fields(line, delimiter)) for line in lines}
        if len(counts) == 1 and counts.pop() > 1:
            return delimiter
    return max(DELIMITERS, key=lambda d: len(_fields(lines[0], d)))


def sniff_decimal(lines: list[str], delimiter: str) -> str:
    """"," when some cell is a number written with a decimal comma and none with a point."""
    if delimiter == ",":
        return "."
    cells = [cell.strip() for line in lines for cell in _fields(line, delimiter)]
    comma = any(COMMA_NUMBER.match(cell) for cell in cells)
    point = any(POINT_NUMBER.match(cell) for cell in cells)
    return "," if comma and not point else "."


def _shown(delimiter: str) -> str:
    return {"\t": "tab", WHITESPACE: "whitespace"}.get(delimiter, repr(delimiter))


def _numbered(text: str) -> Iterator[tuple[int, str]]:
    """The non-blank lines of ``text`` with their numbers from 1 (any line ending), lazily."""
    for number, match in enumerate(LINE.finditer(text), start=1):
        if match.group(1).strip():
            yield number, match.group(1)


def _line_locator(path: Path, encoding: str, rows: int) -> Callable[[int], str]:
    """Names data row ``k`` by its line in the file; the file is read again to count its
    lines on first use, since only messages need them."""

    @functools.cache
    def lines() -> list[int]:
        return [number for number, _ in _numbered(path.read_bytes().decode(encoding))][1:]

    def row(k: int) -> str:
        # a quoted cell spanning lines would shift the count: name the data row instead
        return f"line {lines()[k]}" if len(lines()) == rows else f"data row {k + 1}"

    return row


def _sniffed_bytes(handle: BinaryIO, head: bytes) -> tuple[bytes, bool]:
    """The bytes holding the lines the delimiter is sniffed from, and whether the file ended.

    Reads on past ``head`` until those lines are whole, however long (a table of
    20,000 columns has lines of hundreds of KiB), up to :data:`SNIFF_BYTES`.
    """
    sniffed = bytearray(head)
    while sniffed.count(b"\n") <= SNIFF_LINES + 1 and len(sniffed) < SNIFF_BYTES:
        block = handle.read(DETECT_BYTES)
        if not block:
            return bytes(sniffed), True
        sniffed += block
    return bytes(sniffed), len(head) < DETECT_BYTES


def _check_repeated(header: list[str], kept: set[str], path: Path) -> None:
    """Refuse a header that names a column the request reads twice (pandas would rename the second)."""
    names = [name.strip() for name in header]
    repeated = sorted({name for name in names if names.count(name) > 1} & kept)
    if repeated:
        raise DataError(f"{path}: the header names the column {repeated[0]!r} {names.count(repeated[0])} times: rename")


def read_text(path: Path, delimiter: str | None, decimal: str | None, encoding: str | None,
              needed: Callable[[list[str]], set[str] | None]) -> Table:
    """The columns of a text table, every cell located by its line in the file.

    ``needed(names)`` says which of the header's (stripped) column names to keep; None (no
    channels named, which a text table cannot mark) keeps none, so only the header is
    parsed. The table's ``names`` lists them all. The file is parsed in chunks of
    :data:`~moli.data.frame_files.CHUNK_ROWS` rows, so no more than one chunk's text and
    cells are held besides the columns kept.
    """
    first = _scan(path)
    with path.open("rb") as handle:
        head_bytes = handle.read(DETECT_BYTES)
        sniffed, ended = _sniffed_bytes(handle, head_bytes)
    chosen = encoding or _file_encoding(path, head_bytes, first)
    text = _head_text(sniffed, chosen, path, encoding is not None)
    if not ended and "\n" in text:
        text = text[: text.rindex("\n")]  # a line cut short would split into fewer fields
    head = [line for _, line in itertools.islice(_numbered(text), SNIFF_LINES + 1)]
    if not head:
        raise DataError(f"{path} is empty; expected a header row with column names")
    delimiter = delimiter or sniff_delimiter(head)
    decimal = decimal or sniff_decimal(head[1:], delimiter)
    if decimal == delimiter:
        raise DataError(f"{path}: the delimiter and the decimal mark are both {decimal!r}; "
                        "give them (delimiter=, decimal= or --delimiter, --decimal)")
    pd = optional("pandas", f"reading {path.name}")
    options = dict(sep=delimiter, decimal=decimal, encoding=chosen, index_col=False,
                   skipinitialspace=True, skip_blank_lines=True)
    try:
        header = [str(name) for name in pd.read_csv(path, nrows=0, **options).columns]
        check_header(header, str(path))
        names = list(dict.fromkeys(name.strip() for name in header))
        kept = needed(names) or set()
        columns = {}
        if kept & set(names):
            raw = pd.read_csv(path, nrows=1, header=None, dtype=str, keep_default_na=False, **options)  # unrenamed
            _check_repeated([str(name) for name in raw.iloc[0]] if len(raw) else [], kept, path)
            with pd.read_csv(path, chunksize=frame_files.CHUNK_ROWS, **options) as reader:
                columns = join_chunks(reader, str(path), [n for n in names if n in kept])
    except UnicodeDecodeError:
        raise _undecodable(path, chosen, encoding is not None) from None
    except DataError:
        raise
    except ValueError as exc:  # pandas' ParserError and EmptyDataError are ValueErrors
        raise DataError(f"cannot read {path} as a table with {_shown(delimiter)} between "
                        f"columns: {exc}") from None
    rows = len(next(iter(columns.values()), ()))
    return Table(columns, str(path), _line_locator(path, chosen, rows), decimal=decimal,
                 names=tuple(names))
