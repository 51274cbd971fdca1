"""read_frequency_data: a table of frequency responses (CSV or .xlsx) or a MATLAB file → FrequencyData,
saying which convention it read.

The table has one frequency column, ``frequency_hz`` or ``frequency_rad_s``, and two
columns per output/input pair, named ``"<output>/<input> <part>"``: the parts ``re`` and
``im`` (the complex response), or a magnitude (``dB`` for ``20 log10 |G|``, ``mag`` for
``|G|``) and a phase (``deg`` or ``rad``). One convention holds for the whole table; the
channel names come from the headers, in the order they first appear. Each pair may add the
uncertainty of each line, as the variance of the complex response (``var``, ``E|G - G_0|^2``,
as an analyzer's averages give it) or its square root (``sd``): every pair or none. Each pair may
also give its magnitude-squared coherence (``coh``, in [0, 1]), every pair or none: shown, and with
``averages`` (the spectra averaged per line) turned into the variance where no ``var`` or ``sd`` is given.

A ``.mat`` file holds the arrays themselves: ``G`` of shape (F, p, m) with ``frequency_hz`` or
``frequency_rad_s`` (and optionally ``variance`` and ``coherence`` shaped as ``G``, ``output_names`` and
``input_names``), or the fields of MATLAB's ``idfrd`` saved as variables: ``ResponseData``
(p, m, F) with ``Frequency`` and, optionally, ``FrequencyUnit`` ("rad/s", the default, or "Hz"),
``OutputName`` and ``InputName`` (an ``idfrd`` has no coherence).
"""

from __future__ import annotations

import itertools
import re
import warnings
import zipfile
from pathlib import Path

import numpy as np

from ..errors import DataError, FrequencyConventionWarning
from .frequency_data import FrequencyData
from .text_files import SNIFF_LINES, sniff_decimal, sniff_delimiter

__all__ = ["read_frequency_data", "FREQUENCY_COLUMNS", "CONVENTIONS", "MAT_VARIABLES"]

# The frequency column's name (any letter case) → its unit.
FREQUENCY_COLUMNS = {"frequency_hz": "Hz", "frequency_rad_s": "rad/s"}
# Each convention's two parts, as they end the column names (any letter case), and how it is said.
CONVENTIONS = {
    ("re", "im"): "real and imaginary parts",
    ("db", "deg"): "magnitude in dB (20 log10 |G|) and phase in degrees",
    ("db", "rad"): "magnitude in dB (20 log10 |G|) and phase in radians",
    ("mag", "deg"): "linear magnitude and phase in degrees",
    ("mag", "rad"): "linear magnitude and phase in radians",
}
# The variables of a .mat file the reader looks at (no other is inflated).
MAT_VARIABLES = ("G", "frequency_hz", "frequency_rad_s", "variance", "coherence", "output_names", "input_names",
                 "ResponseData", "Frequency", "FrequencyUnit", "OutputName", "InputName")
# The parts that give a line's uncertainty, and how each becomes the variance.
SPREADS = {"var": lambda values: values, "sd": lambda values: values ** 2}
# The part that gives a line's magnitude-squared coherence.
COHERENCE = "coh"
PAIR_COLUMN = re.compile(r"^\s*(?P<output>[^/]+?)\s*/\s*(?P<input>.+?)\s+(?P<part>re|im|db|deg|mag|rad|var|sd|coh)\s*$",
                         re.IGNORECASE)


def _complex(first: np.ndarray, second: np.ndarray, convention: tuple[str, str]) -> np.ndarray:
    if convention == ("re", "im"):
        return first + 1j * second
    magnitude = 10.0 ** (first / 20.0) if convention[0] == "db" else first
    phase = np.deg2rad(second) if convention[1] == "deg" else second
    return magnitude * np.exp(1j * phase)


def _numbers(frame: object, column: str, source: str) -> np.ndarray:
    import pandas as pd  # only when a table is read

    values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
    text = frame[column].astype(str)
    wrong = np.flatnonzero(np.isnan(values) & ~frame[column].isna().to_numpy())
    if wrong.size:
        raise DataError(f"{source}: column {column!r}, row {wrong[0] + 2} (counting the header as row 1) holds "
                        f"{text.iloc[wrong[0]]!r}, not a number")
    return values


def _pairs(columns: list[str], source: str) -> tuple[str, dict[tuple[str, str], dict[str, str]]]:
    """The frequency column and, per (output, input), its parts' columns."""
    found = [c for c in columns if c.strip().lower() in FREQUENCY_COLUMNS]
    if len(found) != 1:
        what = "none" if not found else " and ".join(repr(c) for c in found)
        raise DataError(f"{source}: needs exactly one frequency column, 'frequency_hz' or 'frequency_rad_s'; "
                        f"found {what}")
    pairs: dict[tuple[str, str], dict[str, str]] = {}
    for column in columns:
        if column == found[0]:
            continue
        match = PAIR_COLUMN.match(column)
        if match is None:
            raise DataError(f"{source}: column {column!r} is neither the frequency column nor "
                            "'<output>/<input> <part>' with the part re, im, dB, mag, deg or rad (or var, sd, coh)")
        parts = pairs.setdefault((match["output"], match["input"]), {})
        part = match["part"].lower()
        if part in parts:
            raise DataError(f"{source}: columns {parts[part]!r} and {column!r} give the same part of one pair")
        parts[part] = column
    if not pairs:
        raise DataError(f"{source}: no '<output>/<input> <part>' columns besides {found[0]!r}")
    return found[0], pairs


def _convention(pairs: dict[tuple[str, str], dict[str, str]], source: str) -> tuple[str, str]:
    seen = set()
    for (output, input_), parts in pairs.items():
        kind = next((c for c in CONVENTIONS if set(c) == set(parts) - set(SPREADS) - {COHERENCE}), None)
        if kind is None:
            raise DataError(f"{source}: pair {output}/{input_} has the parts {sorted(parts.values())}; each pair "
                            "needs 're' and 'im', or a magnitude ('dB' or 'mag') and a phase ('deg' or 'rad')")
        seen.add(kind)
    if len(seen) > 1:
        raise DataError(f"{source}: the pairs mix conventions ({'; '.join(CONVENTIONS[c] for c in sorted(seen))}); "
                        "write every pair the same way")
    return seen.pop()


def _spread(pairs: dict[tuple[str, str], dict[str, str]], source: str) -> str | None:
    """The uncertainty part every pair gives ("var" or "sd"), or None where none gives one."""
    given = {(output, input_): [part for part in SPREADS if part in parts] for (output, input_), parts in pairs.items()}
    kinds = {tuple(found) for found in given.values()}
    if len(kinds) > 1 or any(len(found) > 1 for found in given.values()):
        shown = "; ".join(f"{o}/{i}: {', '.join(found) or 'none'}" for (o, i), found in given.items())
        raise DataError(f"{source}: give every pair the same uncertainty column ('var' or 'sd'), or none: {shown}")
    return next(iter(kinds))[0] if kinds and next(iter(kinds)) else None


def _has_coherence(pairs: dict[tuple[str, str], dict[str, str]], source: str) -> bool:
    """Whether the pairs give a coherence column: every pair or none."""
    lacking = [f"{o}/{i}" for (o, i), parts in pairs.items() if COHERENCE not in parts]
    if lacking and len(lacking) < len(pairs):
        raise DataError(f"{source}: give every pair a '{COHERENCE}' column or none; missing for {', '.join(lacking)}")
    return not lacking


def _mat_text(value: object) -> str:
    """A MATLAB char array as text."""
    return "".join(str(part) for part in np.asarray(value).ravel())


def _mat_names(value: object) -> list[str]:
    """A MATLAB cell array (or char matrix) of names as a list of strings."""
    array = np.asarray(value)
    if array.dtype == object:
        return [_mat_text(cell) for cell in array.ravel()]
    return [_mat_text(row) for row in np.atleast_2d(array)]


def _read_mat(path: str | Path, source: str, Ts: float | None, averages: int | None) -> tuple[FrequencyData, str]:
    """The arrays of a .mat file (the module's two conventions) and how they were read."""
    from scipy.io import loadmat, whosmat  # only when a .mat file is read

    try:
        listed = {name for name, _, _ in whosmat(path)}
        content = loadmat(path, variable_names=[n for n in MAT_VARIABLES if n in listed], squeeze_me=False)
    except (ValueError, OSError, NotImplementedError, TypeError, IndexError, KeyError) as exc:
        # scipy's reader fails on a damaged file with any of these
        raise DataError(f"{source}: not a readable .mat file: {type(exc).__name__}: {exc}") from None
    if "G" in content:
        found = [n for n in FREQUENCY_COLUMNS if n in content]
        if len(found) != 1:
            raise DataError(f"{source}: G needs exactly one of frequency_hz and frequency_rad_s; found {found or 'none'}")
        G, unit = np.asarray(content["G"]), FREQUENCY_COLUMNS[found[0]]
        frequencies, how = content[found[0]], f"G (F x p x m) with {found[0]}"
        variance, coherence = content.get("variance"), content.get("coherence")
        names = [_mat_names(content[n]) if n in content else None for n in ("output_names", "input_names")]
        if G.ndim != 3:
            raise DataError(f"{source}: G must have shape (F, p, m), got {G.shape}")
    elif "ResponseData" in content and "Frequency" in content:
        response = np.asarray(content["ResponseData"])
        if response.ndim != 3:
            raise DataError(f"{source}: ResponseData must have shape (p, m, F), got {response.shape}")
        G, frequencies, variance, coherence = response.transpose(2, 0, 1), content["Frequency"], None, None
        stated = _mat_text(content["FrequencyUnit"]) if "FrequencyUnit" in content else "rad/s"
        if stated.lower() not in ("hz", "rad/s", "rad/timeunit"):
            raise DataError(f"{source}: FrequencyUnit {stated!r} is neither 'Hz' nor 'rad/s'")
        unit = "Hz" if stated.lower() == "hz" else "rad/s"
        how = f"ResponseData (p x m x F) with Frequency in {unit}"
        names = [_mat_names(content[n]) if n in content else None for n in ("OutputName", "InputName")]
    else:
        raise DataError(f"{source}: needs G (F x p x m) with frequency_hz or frequency_rad_s, or ResponseData "
                        f"(p x m x F) with Frequency; it holds {', '.join(sorted(listed)) or 'no variable'}")
    try:
        data = FrequencyData(np.asarray(frequencies, dtype=float).ravel(), G, unit=unit, Ts=Ts, variance=variance,
                             output_names=names[0], input_names=names[1], coherence=coherence, averages=averages)
    except DataError as exc:
        raise DataError(f"{source}: {exc}") from None
    if coherence is not None:
        how += " and coherence" + ("" if averages is None else f" (the variance from it and {averages} averages)")
    return data, how


def _sniffed_format(path: Path, sep: str | None) -> tuple[str, str]:
    """The separator that splits the table's first lines alike, where none is given, and the
    decimal mark of their numbers (:mod:`moli.data.text_files`' sniffing, as ``read_data`` has it)."""
    with path.open(encoding="utf-8", errors="replace") as handle:
        lines = [line.rstrip("\r\n") for line in itertools.islice(handle, SNIFF_LINES) if line.strip()]
    separator = sep or (sniff_delimiter(lines) if lines else ",")
    return separator, sniff_decimal(lines[1:], separator)


def read_frequency_data(path: str | Path, *, Ts: float | None = None, sep: str | None = None,
                        averages: int | None = None) -> FrequencyData:
    """Read a table of frequency responses (a text table, the first sheet of an ``.xlsx``
    workbook, or a Parquet file) into :class:`FrequencyData`.

    Parameters
    ----------
    path : str or Path
        The table (see the module's description, and docs/frequency.md for an example); a
        name ending in ``.xlsx`` is read as a workbook.
    Ts : float, optional
        Sampling period when the responses are those of a discrete-time system; None:
        continuous time.
    sep : str, optional
        The column separator of a text table; by default the one that splits its first lines
        alike (tab, semicolon, comma, bar, else white space), as :func:`moli.read_data` finds it.
    averages : int, optional
        The spectra averaged per line behind the ``coh`` columns: the variance then follows
        from the coherence (:class:`FrequencyData`); only with coherence and no ``var``/``sd``.

    Returns
    -------
    FrequencyData

    Raises
    ------
    DataError
        No or two frequency columns, a column that fits no convention, a pair with a
        part missing, mixed conventions, a pair missing from the output × input grid, a
        cell that is not a number, or any check of :class:`FrequencyData` (each names the
        file and the column, line or pair).

    Warns
    -----
    FrequencyConventionWarning
        Which frequency column and convention were read, and the channels found.

    Examples
    --------
    >>> import tempfile, warnings, pathlib
    >>> import numpy as np
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "frf.csv").write_text("frequency_hz,y1/u1 dB,y1/u1 deg\\n1,0,0\\n2,-6.0206,-90\\n")
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     data = read_frequency_data(folder / "frf.csv")
    >>> bool(np.allclose(data.G[:, 0, 0], [1.0, -0.5j], atol=1e-5))      # -6.0206 dB is a half
    True
    >>> "dB" in str(caught[0].message)
    True
    """
    import pandas as pd  # only when a table is read

    source = str(path)
    if not Path(path).is_file():
        raise DataError(f"{source}: no such file")
    if Path(path).suffix.lower() == ".mat":
        data, how = _read_mat(path, source, Ts, averages)
        warnings.warn(FrequencyConventionWarning(
            f"{source}: {how}; {data.p} output(s) ({', '.join(data.output_names)}) and {data.m} input(s) "
            f"({', '.join(data.input_names)}); "
            f"{'continuous time' if Ts is None else f'discrete time, Ts = {Ts:g}'}"), stacklevel=2)
        return data
    try:
        suffix = Path(path).suffix.lower()
        if suffix == ".xlsx":
            frame = pd.read_excel(path, sheet_name=0, engine="openpyxl")
        elif suffix == ".parquet":
            frame = pd.read_parquet(path)
        else:
            separator, decimal = _sniffed_format(Path(path), sep)
            frame = pd.read_csv(path, sep=separator, decimal=decimal,
                                engine="python" if len(separator) > 1 else "c")   # a regular expression
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError, OSError, zipfile.BadZipFile) as exc:
        raise DataError(f"{source}: not a readable table: {exc}") from None
    columns = [str(c) for c in frame.columns]
    frame.columns = columns
    frequency, pairs = _pairs(columns, source)
    convention = _convention(pairs, source)
    outputs = list(dict.fromkeys(o for o, _ in pairs))
    inputs = list(dict.fromkeys(i for _, i in pairs))
    missing = [f"{o}/{i}" for o in outputs for i in inputs if (o, i) not in pairs]
    if missing:
        raise DataError(f"{source}: every output/input pair needs its columns; missing {', '.join(missing)}")
    spread = _spread(pairs, source)
    G = np.empty((len(frame), len(outputs), len(inputs)), dtype=complex)
    variance = None if spread is None else np.empty(G.shape)
    coherence = np.empty(G.shape) if _has_coherence(pairs, source) else None
    if averages is not None and (coherence is None or spread is not None):
        raise DataError(f"{source}: averages turn the 'coh' columns into variances, so they need 'coh' columns "
                        f"and no '{spread or 'var'}' ones; this table has {'no coh' if coherence is None else spread} "
                        "columns: leave averages out")
    for (output, input_), parts in pairs.items():
        first, second = (_numbers(frame, parts[part], source) for part in convention)
        G[:, outputs.index(output), inputs.index(input_)] = _complex(first, second, convention)
        if variance is not None:
            variance[:, outputs.index(output), inputs.index(input_)] = SPREADS[spread](
                _numbers(frame, parts[spread], source))
        if coherence is not None:
            coherence[:, outputs.index(output), inputs.index(input_)] = _numbers(frame, parts[COHERENCE], source)
    unit = FREQUENCY_COLUMNS[frequency.strip().lower()]
    try:
        data = FrequencyData(_numbers(frame, frequency, source), G, unit=unit, Ts=Ts, variance=variance,
                             output_names=outputs, input_names=inputs, coherence=coherence, averages=averages)
    except DataError as exc:
        raise DataError(f"{source}: {exc}") from None
    warnings.warn(FrequencyConventionWarning(
        f"{source}: frequencies in {unit} from column {frequency!r}; responses as {CONVENTIONS[convention]}"
        + ("" if spread is None else f", each line's {'variance' if spread == 'var' else 'standard deviation'} "
                                     f"from the '{spread}' columns,")
        + ("" if coherence is None else " with the coherence of each line from the 'coh' columns"
           + ("" if averages is None else f" (the variance from it and {averages} averages)") + ",")
        + f" for {len(outputs)} output(s) ({', '.join(outputs)}) and {len(inputs)} input(s) ({', '.join(inputs)}); "
        f"{'continuous time' if Ts is None else f'discrete time, Ts = {Ts:g}'}"), stacklevel=2)
    return data
