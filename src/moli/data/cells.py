"""Cells of a file's columns as numbers, and the optional libraries the readers use.

A cell is missing (empty, ``NA``, ``NaN``, None), a number, or neither; a column of
numbers becomes a float array with NaN where a cell is missing.
"""

from __future__ import annotations

import importlib
import math
from contextlib import contextmanager
from types import ModuleType
from typing import Iterator

import numpy as np

from ..errors import DataError, MoliError

__all__ = ["DATA_EXTRA", "optional", "is_missing", "parse_numbers", "parsing"]

# The extra of pyproject.toml that installs every optional reader.
DATA_EXTRA = "moli[data]"


def optional(module: str, purpose: str) -> ModuleType:
    """Import an optional dependency, or fail naming the extra that installs it.

    Parameters
    ----------
    module : str
        Module to import, e.g. ``"pandas"``.
    purpose : str
        What needs it, for the message, e.g. ``"reading rec.xlsx"``.

    Returns
    -------
    module

    Examples
    --------
    >>> optional("math", "rounding").floor(2.5)
    2
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        package = module.split(".")[0]
        raise DataError(f"{purpose} needs {package}: pip install '{DATA_EXTRA}'") from None


def is_missing(cell: object) -> bool:
    """True for an empty or blank text cell, None, NaN, NaT and pandas' NA.

    Examples
    --------
    >>> [is_missing(c) for c in ("", "  ", None, float("nan"), "0", 0.0)]
    [True, True, True, True, False, False]
    """
    if cell is None:
        return True
    if isinstance(cell, str):
        return not cell.strip()
    if isinstance(cell, float):
        return math.isnan(cell)
    try:
        # NaN, NaT and pandas' NA are the values that differ from themselves (NA's
        # comparison is NA, whose truth value raises)
        return bool(cell != cell)
    except TypeError:
        return True


def parse_numbers(values: object, decimal: str = ".") -> tuple[np.ndarray, int | None]:
    """A column as floats, NaN where a cell is missing, and the first cell that is neither.

    Parameters
    ----------
    values : array_like, 1-D
        Numbers, text or a mix (an object column of a data frame).
    decimal : str, default "."
        Decimal mark of numbers written as text.

    Returns
    -------
    numbers : ndarray, shape (N,)
        Valid up to the first bad cell.
    bad : int or None
        Index of the first cell that is neither missing nor a number; None if every cell is.

    Examples
    --------
    >>> parse_numbers(["1,5", "", "2"], decimal=",")
    (array([1.5, nan, 2. ]), None)
    >>> parse_numbers(["1", "x"])[1]
    1
    """
    array = np.asarray(values)
    if array.dtype.kind in "biuf":
        return array.astype(float, copy=False), None
    if array.dtype.kind in "mM":  # date-times and durations are not channel values
        return np.full(array.shape, np.nan), 0
    numbers = np.full(array.shape, np.nan)
    for index, cell in enumerate(array):
        if is_missing(cell):
            continue
        if isinstance(cell, (int, float, np.integer, np.floating)) and not isinstance(cell, bool):
            numbers[index] = float(cell)
            continue
        text = str(cell).strip()
        if decimal != ".":
            text = text.replace(decimal, ".")
        try:
            numbers[index] = float(text)
        except ValueError:
            return numbers, index
    return numbers, None


@contextmanager
def parsing(path: object, what: str) -> Iterator[None]:
    """Turn any failure of a third-party parser on ``path`` into a :class:`DataError`.

    Parsers meet a corrupt or truncated file with exceptions of many types
    (zipfile.BadZipFile, pyarrow's ArrowInvalid, struct.error, EOFError, KeyError, ...);
    the caller gets one error naming the file, what it was read as and what failed.
    """
    try:
        yield
    except MoliError:
        raise
    except Exception as exc:  # noqa: BLE001 - see the docstring
        detail = str(exc).strip().splitlines()[0] if str(exc).strip() else "no detail"
        raise DataError(f"cannot read {path} as {what}: {type(exc).__name__}: {detail}") from None
