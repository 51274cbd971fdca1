"""Reading measured records from files into :class:`~moli.data.IOData`, and back out.

:func:`read_data` reads text tables (.csv, .tsv, .txt), Excel workbooks (.xlsx),
Parquet, NumPy ``.npz`` and MATLAB ``.mat`` files. The suffix picks the reader
(:mod:`~moli.data.text_files`, :mod:`~moli.data.sheets`, :mod:`~moli.data.frame_files`,
:mod:`~moli.data.array_files`); :mod:`~moli.data.tables` picks the channels, checks
every cell and finds the sampling period. docs/data.md describes what is read and what
each error means.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np

from .array_files import read_mat, read_npz
from .frame_files import read_parquet
from .sheets import check_sheet, read_excel
from .iodata import IOData
from .tables import check_request, needed_columns, record
from .text_files import check_text_options, read_text
from .timing import TIME_TOLERANCE
from ..errors import DataError, OptionError

__all__ = ["read_data", "to_dataframe", "fingerprint", "file_sha256", "SUFFIXES"]

if TYPE_CHECKING:  # pandas is optional
    import pandas as pd

TEXT_SUFFIXES = (".csv", ".tsv", ".txt")
SUFFIXES = (*TEXT_SUFFIXES, ".xlsx", ".parquet", ".npz", ".mat")
# Bytes read at a time when hashing a file.
HASH_BLOCK = 1 << 20


def read_data(
    path: str | Path,
    inputs: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
    Ts: float | None = None,
    *,
    delimiter: str | None = None,
    decimal: str | None = None,
    encoding: str | None = None,
    sheet: str | int | None = None,
    time_column: str | bool | None = None,
    time_format: str | None = None,
    time_tolerance: float = TIME_TOLERANCE,
) -> IOData:
    """Read a record from a text table, an Excel workbook, Parquet, ``.npz`` or ``.mat`` file.

    Columns not named as channels are ignored, whatever they hold (a status text, a
    second clock). Every cell of a channel must be a number: a text cell, an empty
    cell or ``inf`` is an error naming the file, the line (text: lines of the file
    from 1, header included; spreadsheet: its row numbers; other formats: the sample
    index) and the column.

    Parameters
    ----------
    path : str or Path
        The file; its suffix (``.csv .tsv .txt .xlsx .parquet .npz .mat``) selects the reader.
    inputs, outputs : sequence of str, optional
        Column (variable) names of the channels, in channel order. May be omitted when
        the file says which channels are which: 2-D arrays ``u`` and ``y`` in ``.npz``
        or ``.mat`` files (channels ``u1, ...`` and ``y1, ...``) or a MATLAB iddata struct.
    Ts : float, optional
        Sampling period. Default: a period stored in the file (``Ts`` variable, iddata),
        else in a period or rate column (``Ts``, ``dt``, ``Fs``, ``rate``... holding one
        value, or filled in its first row only; ``Ts = 1/rate``), else the median step of
        the time column, else 1.0. When the file has time stamps too, they must agree
        with ``Ts`` within ``time_tolerance``.
    delimiter : str, optional
        Text files: the column separator, one character or ``"tab"``, ``"whitespace"``;
        default: sniffed (tab, ``;``, ``,``, ``|``, else whitespace).
    decimal : {".", ","}, optional
        Text files: the decimal mark; default: sniffed (``,`` when numbers are written so
        and the delimiter is not ``,``).
    encoding : str, optional
        Text files: the encoding; default: detected (:func:`~moli.data.text_files.detect_encoding`).
    sheet : str or int, optional
        Excel files: the sheet's name or 0-based position; default the first.
    time_column : str or False, optional
        The column of time stamps; default: among the columns that are not channels,
        the first named ``time``, ``t``, ``timestamp``, ``date`` or ``datetime`` (any
        case), else one whose name looks like time (``Time [s]``, ``Timestamp (UTC)``,
        ``Zeit``) and that holds increasing times, else the first column when it holds
        date-times, or evenly increasing numbers under a blank or generic name
        (:mod:`moli.data.clocks`); False: none. Numbers are times in the unit of
        ``Ts``; date-times (ISO 8601 text, spreadsheet or Parquet time stamps) give
        ``Ts`` in **seconds**.
    time_format : str, optional
        strftime format of date-time text that is not ISO 8601, e.g. ``"%d/%m/%Y %H:%M:%S"``.
    time_tolerance : float, default 0.01
        Fraction of ``Ts`` a time step may be off and still count as regular.

    Returns
    -------
    IOData
        With the time column's stamps in ``times`` (seconds since the first sample for
        date-times), or ``times=None`` without a time column.

    Raises
    ------
    DataError
        The file is missing, unreadable or not of its suffix's format; a channel is
        missing, holds a cell that is not a number or a missing sample; time stamps do
        not increase or disagree with ``Ts``.
    OptionError
        An option that is not accepted, or that does not apply to the file's format
        (before the file is read).

    Warns
    -----
    SamplingPeriodWarning
        When ``Ts`` is neither given nor stored as a variable: which column gave it, or
        that 1.0 was assumed and how to set it.
    IrregularSamplingWarning
        Time steps that differ from ``Ts`` by more than ``time_tolerance``; the message
        lists the gaps longer than 1.5 Ts, the warning's ``gaps`` holds every such step
        (:class:`~moli.data.SamplingGap`, also from :func:`~moli.data.find_gaps`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "rec.csv"
    >>> _ = f.write_text("time;u1;y1;status\\n0,0;1;0;ok\\n0,1;0;1,5;ok\\n0,2;0;0,5;late\\n")
    >>> read_data(f, ["u1"], ["y1"])
    IOData(N=3, p=1, m=1, Ts=0.1, outputs=['y1'], inputs=['u1'])
    """
    request = check_request(inputs, outputs, Ts, time_column, time_format, time_tolerance)
    if not isinstance(path, (str, os.PathLike)):
        raise DataError(f"path must be a str or Path, got {type(path).__name__}")
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise DataError(f"cannot read {path}: the suffix must be one of {', '.join(SUFFIXES)}")
    text = check_text_options(delimiter, decimal, encoding)
    given = {"delimiter": delimiter, "decimal": decimal, "encoding": encoding}
    if suffix not in TEXT_SUFFIXES and any(v is not None for v in given.values()):
        wrong = next(name for name, value in given.items() if value is not None)
        raise OptionError(f"{wrong} applies to text files ({', '.join(TEXT_SUFFIXES)}), not {suffix}")
    if sheet is not None and suffix != ".xlsx":
        raise OptionError(f"sheet applies to .xlsx files, not {suffix}")
    chosen = check_sheet(sheet)
    if not path.is_file():
        raise DataError(f"{path} is a folder, not a data file" if path.is_dir() else f"no data file at {path}")
    def needed(names: list[str]) -> set[str] | None:
        return needed_columns(request, names)

    if suffix in TEXT_SUFFIXES:
        table = read_text(path, *text, needed)
    elif suffix == ".xlsx":
        table = read_excel(path, chosen, needed)
    elif suffix == ".parquet":
        table = read_parquet(path, needed)
    else:
        table = (read_npz if suffix == ".npz" else read_mat)(path, needed)
    return record(table, request)


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes, as hex: which file a model or a report came from.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    str

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "empty.csv"
    >>> _ = f.write_bytes(b"")
    >>> file_sha256(f)[:16]
    'e3b0c44298fc1c14'
    """
    digest = hashlib.sha256()
    with Path(path).open("rb") as handle:
        for block in iter(lambda: handle.read(HASH_BLOCK), b""):
            digest.update(block)
    return digest.hexdigest()


def to_dataframe(data: IOData) -> "pd.DataFrame":
    """The record as a pandas data frame: output then input columns, indexed by time.

    The values are those stored in ``data`` (centred if ``data`` is centred).

    Parameters
    ----------
    data : IOData

    Returns
    -------
    pandas.DataFrame
        Columns ``data.output_names + data.input_names``; index ``time``: ``data.time()``
        (the record's time stamps, else ``k * Ts``). A record of several segments gets a
        row of NaN between two segments, which :func:`from_dataframe` and
        :func:`read_data` read back as the boundary, and its index counts ``k * Ts``
        through those rows (stamps may restart at a segment).

    Examples
    --------
    >>> import numpy as np
    >>> to_dataframe(IOData(np.zeros(3), np.ones(3), Ts=0.5)).index.tolist()
    [0.0, 0.5, 1.0]
    """
    import pandas as pd

    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    values = np.concatenate([data.y, data.u], axis=1)
    time = data.time()
    if data.n_segments > 1:
        # a missing sample at each boundary; the times after it move on by one period
        breaks = list(data.segment_starts[1:])
        values = np.insert(values, breaks, np.nan, axis=0)
        time = np.arange(values.shape[0]) * data.Ts
    index = pd.Index(time, name="time")
    return pd.DataFrame(values, index=index, columns=[*data.output_names, *data.input_names])


def fingerprint(data: IOData) -> str:
    """SHA-256 of a record's outputs, inputs and sample count, as hex.

    Two records get the same fingerprint exactly when they hold the same float64
    values in the same shapes and segments; it identifies the data a model was
    estimated on.

    Parameters
    ----------
    data : IOData

    Returns
    -------
    str

    Examples
    --------
    >>> import numpy as np
    >>> len(fingerprint(IOData(np.zeros(4), np.ones(4))))
    64
    """
    digest = hashlib.sha256()
    digest.update(np.array([data.N, data.p, data.m], dtype=np.int64).tobytes())
    digest.update(np.ascontiguousarray(data.y, dtype=np.float64).tobytes())
    digest.update(np.ascontiguousarray(data.u, dtype=np.float64).tobytes())
    if data.n_segments > 1:  # a record of one segment keeps the fingerprint it always had
        digest.update(np.array(data.segment_starts, dtype=np.int64).tobytes())
    return digest.hexdigest()
