"""Reading measured records from files and data frames into :class:`~moli.data.IOData`.

Supported sources: CSV (a header row with the column names; ``,`` ``;`` or tab
separated), NumPy ``.npz``, MATLAB ``.mat`` (v5/v7), Parquet (needs ``pyarrow``) and
pandas data frames (needs ``pandas``). Channels are picked by column name; a column
named ``time`` or ``t`` gives the sampling period when none is stated.
"""

from __future__ import annotations

import csv
import hashlib
from pathlib import Path
from typing import TYPE_CHECKING, Mapping, Sequence

import numpy as np

from .iodata import IOData
from ..errors import DataError

__all__ = ["from_columns", "read_data", "from_dataframe", "to_dataframe", "fingerprint"]

if TYPE_CHECKING:  # pandas is optional
    import pandas as pd

TIME_COLUMNS = ("time", "t")
SUFFIXES = (".csv", ".txt", ".npz", ".mat", ".parquet")
# Relative spread of the time steps still counted as uniform sampling: spreadsheet
# exports round time stamps to a few digits.
TIME_STEP_TOLERANCE = 1e-3


def _time_column(columns: Sequence[str]) -> str | None:
    for name in columns:
        if name.strip().lower() in TIME_COLUMNS:
            return name
    return None


def _period(times: np.ndarray, column: str) -> float:
    """Sampling period of a time column, which must be uniformly increasing."""
    steps = np.diff(times)
    if steps.size == 0:
        raise DataError(f"column {column!r} has a single time stamp; state the period with Ts")
    period = float(np.median(steps))
    if period <= 0 or np.max(np.abs(steps - period)) > TIME_STEP_TOLERANCE * period:
        raise DataError(
            f"column {column!r} is not uniformly increasing (steps from {steps.min():g} to "
            f"{steps.max():g}); resample the record or state the period with Ts"
        )
    return period


def _channel(table: Mapping[str, object], name: str, source: str) -> np.ndarray:
    if name not in table:
        raise DataError(
            f"{source} has no column {name!r}; columns: {', '.join(map(repr, table))}"
        )
    try:
        values = np.array(table[name], dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"column {name!r} of {source} is not numeric") from None
    if values.ndim == 2 and 1 in values.shape:
        values = values.ravel()  # MATLAB stores vectors as (N, 1) or (1, N)
    if values.ndim != 1:
        raise DataError(f"column {name!r} of {source} has shape {values.shape}, expected (N,)")
    return values


def from_columns(
    table: Mapping[str, object],
    inputs: Sequence[str],
    outputs: Sequence[str],
    Ts: float | None = None,
    source: str = "the table",
) -> IOData:
    """Build an :class:`IOData` from named columns.

    Parameters
    ----------
    table : mapping of str to array_like
        Column name to 1-D values (all of the same length).
    inputs, outputs : sequence of str
        Names of the input and output columns, in channel order.
    Ts : float, optional
        Sampling period; default: the step of a ``time``/``t`` column, else 1.0.
    source : str
        What to call the table in error messages.

    Returns
    -------
    IOData

    Examples
    --------
    >>> from_columns({"t": [0, 0.5, 1.0], "u": [1, 0, 0], "y": [0, 1, 0.5]}, ["u"], ["y"])
    IOData(N=3, p=1, m=1, Ts=0.5, outputs=['y'], inputs=['u'])
    """
    inputs, outputs = list(inputs), list(outputs)
    if not inputs or not outputs:
        raise DataError("name at least one input and one output column")
    both = set(inputs) & set(outputs)
    if both:
        raise DataError(f"columns {sorted(both)} are named both as input and as output")
    u = np.column_stack([_channel(table, name, source) for name in inputs])
    y = np.column_stack([_channel(table, name, source) for name in outputs])
    if Ts is None:
        clock = _time_column(list(table))
        Ts = 1.0 if clock is None else _period(_channel(table, clock, source), clock)
    return IOData(y, u, Ts, output_names=outputs, input_names=inputs)


def _read_csv_columns(path: Path, wanted: Sequence[str], clock: bool) -> dict[str, np.ndarray | None]:
    """Numeric values of the ``wanted`` columns (and of the time column if ``clock``).

    Every other column maps to None, unparsed: it may hold text such as dates.
    """
    with path.open(newline="", encoding="utf-8-sig") as handle:
        try:
            dialect: type[csv.Dialect] | csv.Dialect = csv.Sniffer().sniff(
                handle.readline(), delimiters=",;\t"
            )
        except csv.Error:
            dialect = csv.excel
        handle.seek(0)
        rows = csv.reader(handle, dialect)
        header = [name.strip() for name in next(rows, [])]
        if not any(header):
            raise DataError(f"{path} is empty; expected a header row with column names")
        parse = [name for name in wanted if name in header]
        time_name = _time_column(header)
        if clock and time_name is not None and time_name not in parse:
            parse.append(time_name)
        columns: dict[str, list[float]] = {name: [] for name in parse}
        positions = {name: header.index(name) for name in parse}
        count = 0
        for line, row in enumerate(rows, start=2):
            if not any(cell.strip() for cell in row):
                continue
            count += 1
            for name, col in positions.items():
                cell = row[col].strip() if col < len(row) else ""
                try:
                    columns[name].append(float(cell))
                except ValueError:
                    raise DataError(
                        f"{path}, line {line}, column {name!r}: {cell!r} is not a number"
                    ) from None
    if count == 0:
        raise DataError(f"{path} has a header but no data rows")
    return {name: np.array(columns[name]) if name in columns else None for name in header}


def _read_arrays(path: Path) -> dict[str, np.ndarray]:
    """Variables of an ``.npz`` or ``.mat`` file."""
    try:
        if path.suffix.lower() == ".npz":
            with np.load(path, allow_pickle=False) as archive:
                return {key: archive[key] for key in archive.files}
        from scipy.io import loadmat

        return {k: v for k, v in loadmat(path).items() if not k.startswith("__")}
    except (OSError, ValueError, NotImplementedError) as exc:
        raise DataError(f"cannot read {path}: {exc}") from None


def _read_parquet(path: Path) -> dict[str, np.ndarray]:
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise DataError(f"reading {path} needs pyarrow: pip install pyarrow") from None
    table = pq.read_table(path)
    return {name: table.column(name).to_numpy() for name in table.column_names}


def read_data(
    path: str | Path,
    inputs: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
    Ts: float | None = None,
) -> IOData:
    """Read a record from a CSV, ``.npz``, ``.mat`` or Parquet file.

    Parameters
    ----------
    path : str or Path
        The file; its suffix selects the reader.
    inputs, outputs : sequence of str, optional
        Column (variable) names of the channels. May be omitted only for ``.npz``
        and ``.mat`` files holding 2-D arrays ``u`` and ``y`` (time along axis 0).
    Ts : float, optional
        Sampling period; default: a ``Ts`` variable of the file, else the step of a
        ``time``/``t`` column, else 1.0.

    Returns
    -------
    IOData

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "rec.csv"
    >>> _ = f.write_text("time,u1,y1\\n0,1,0\\n0.1,0,1\\n0.2,0,0.5\\n")
    >>> read_data(f, ["u1"], ["y1"])
    IOData(N=3, p=1, m=1, Ts=0.1, outputs=['y1'], inputs=['u1'])
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"no data file at {path}")
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise DataError(f"cannot read {path}: the suffix must be one of {', '.join(SUFFIXES)}")
    if suffix in (".csv", ".txt"):
        table = _read_csv_columns(path, [*(inputs or []), *(outputs or [])], clock=Ts is None)
    elif suffix == ".parquet":
        table = _read_parquet(path)
    else:
        table = _read_arrays(path)
    if Ts is None and "Ts" in table:
        Ts = float(np.asarray(table["Ts"]).ravel()[0])
    if inputs is None and outputs is None and {"u", "y"} <= set(table):
        return IOData(table["y"], table["u"], 1.0 if Ts is None else Ts)
    if inputs is None or outputs is None:
        raise DataError(
            f"name the input and output columns of {path}; columns: {', '.join(table)}"
        )
    return from_columns(table, inputs, outputs, Ts, source=str(path))


def from_dataframe(
    frame: "pd.DataFrame", inputs: Sequence[str], outputs: Sequence[str], Ts: float | None = None
) -> IOData:
    """Build an :class:`IOData` from columns of a pandas data frame.

    Parameters
    ----------
    frame : pandas.DataFrame
        One row per sample.
    inputs, outputs : sequence of str
        Column names of the channels.
    Ts : float, optional
        Sampling period; default: the step of a ``time``/``t`` column or index, else 1.0.

    Returns
    -------
    IOData

    Examples
    --------
    >>> import pandas as pd
    >>> frame = pd.DataFrame({"time": [0.0, 0.2, 0.4], "u": [1, 0, 0], "y": [0, 1, 0.5]})
    >>> from_dataframe(frame, ["u"], ["y"])
    IOData(N=3, p=1, m=1, Ts=0.2, outputs=['y'], inputs=['u'])
    """
    table = {str(name): frame[name].to_numpy() for name in frame.columns}
    if frame.index.name is not None and str(frame.index.name) not in table:
        table[str(frame.index.name)] = frame.index.to_numpy()
    return from_columns(table, inputs, outputs, Ts, source="the data frame")


def to_dataframe(data: IOData) -> "pd.DataFrame":
    """The record as a pandas data frame: output then input columns, indexed by time.

    The values are those stored in ``data`` (centred if ``data`` is centred).

    Parameters
    ----------
    data : IOData

    Returns
    -------
    pandas.DataFrame
        Columns ``data.output_names + data.input_names``; index ``time`` (``k * Ts``).

    Examples
    --------
    >>> import numpy as np
    >>> to_dataframe(IOData(np.zeros(3), np.ones(3), Ts=0.5)).index.tolist()
    [0.0, 0.5, 1.0]
    """
    import pandas as pd

    values = np.concatenate([data.y, data.u], axis=1)
    index = pd.Index(data.time(), name="time")
    return pd.DataFrame(values, index=index, columns=[*data.output_names, *data.input_names])


def fingerprint(data: IOData) -> str:
    """SHA-256 of a record's outputs, inputs and sample count, as hex.

    Two records get the same fingerprint exactly when they hold the same float64
    values in the same shapes; it identifies the data a model was estimated on.

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
    return digest.hexdigest()
