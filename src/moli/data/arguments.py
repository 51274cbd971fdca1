"""Checks of scalar and array arguments shared by every public function.

Each check raises the moli error its caller names (``DataError`` by default) with the
argument's name and what is accepted, before the caller does any work, and returns a
fresh value: the caller's objects are never modified.
"""

from __future__ import annotations

from numbers import Integral, Real
from typing import TYPE_CHECKING

import numpy as np

from ..errors import DataError, MoliError, wrong_type

if TYPE_CHECKING:          # iodata imports this module
    from .iodata import IOData

__all__ = ["real_number", "integer", "flag", "period", "real_array", "name_list", "check_channel_order",
           "check_validation_length"]


def _scalar(value: object) -> object:
    """A 0-d array's item (``np.array(0.5)`` is a number); anything else as given."""
    return value.item() if isinstance(value, np.ndarray) and value.ndim == 0 else value


def real_number(name: str, value: object, *, error: type[MoliError] = DataError,
                low: float | None = None, low_open: bool = False, high: float | None = None) -> float:
    """``value`` as a finite float in ``[low, high]`` (``(low, high]`` when ``low_open``).

    Text, booleans, None, complex numbers and arrays are refused: a number given as
    text is a mistake to report, not to guess at.
    """
    value = _scalar(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, Real):
        raise wrong_type(error)(f"{name} must be a finite real number, got {value!r}")
    if not np.isfinite(value):
        raise error(f"{name} must be a finite real number, got {value!r}")
    number = float(value)
    below = low is not None and (number <= low if low_open else number < low)
    if below or (high is not None and number > high):
        left = "(-inf" if low is None else f"({low:g}" if low_open else f"[{low:g}"
        right = ", inf)" if high is None else f", {high:g}]"
        raise error(f"{name} must lie in {left}{right}, got {value!r}")
    return number


def integer(name: str, value: object, *, error: type[MoliError] = DataError, low: int | None = None) -> int:
    """``value`` as an int of at least ``low`` (a float such as 3.0 is refused too)."""
    value = _scalar(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, Integral):
        raise wrong_type(error)(f"{name} must be an integer, got {value!r}")
    if low is not None and value < low:
        raise error(f"{name} must be an integer of at least {low}, got {value!r}")
    return int(value)


def flag(name: str, value: object, *, error: type[MoliError] = DataError) -> bool:
    """``value`` as a bool: True or False (numpy's too); text such as "False" is refused, not read as true."""
    value = _scalar(value)
    if not isinstance(value, (bool, np.bool_)):
        raise wrong_type(error)(f"{name} must be True or False, got {value!r}")
    return bool(value)


# The sampling periods moli takes: any clock's, in any time unit, with room to spare; beyond them a
# filter's cutoffs (about 1 / Ts) or their powers leave the floating-point range
PERIOD_RANGE = (1e-100, 1e100)


def period(value: object, *, error: type[MoliError] = DataError, name: str = "Ts") -> float:
    """A sampling period: a positive finite number within :data:`PERIOD_RANGE`."""
    value = _scalar(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, Real):
        raise wrong_type(error)(f"{name} must be a positive finite number, got {value!r}")
    if not (np.isfinite(value) and value > 0):
        raise error(f"{name} must be a positive finite number, got {value!r}")
    if not PERIOD_RANGE[0] <= value <= PERIOD_RANGE[1]:
        raise error(f"{name} = {value!r} lies outside {PERIOD_RANGE[0]:g} .. {PERIOD_RANGE[1]:g}: give the "
                    "period in another time unit")
    return float(value)


def real_array(name: str, value: object, *, error: type[MoliError] = DataError, ndim: int | None = None,
               shape: tuple[int, ...] | None = None, finite: bool = True) -> np.ndarray:
    """A float copy of ``value``: real, numeric, rectangular, of the given ``ndim``/``shape``.

    ``finite=False`` lets NaN and inf through (the caller decides what they mean).
    """
    if value is None or isinstance(value, (str, bytes)):
        raise wrong_type(error)(f"{name} must be an array of real (numeric) values, got {value!r}")
    if isinstance(value, np.ma.MaskedArray):     # a masked entry is a missing value, not its stored one
        value = np.ma.filled(value.astype(float), np.nan)
    try:
        raw = np.asarray(value)
    except ValueError as exc:  # ragged nested lists
        raise error(f"{name} must be a rectangular array of real numbers: {exc}") from None
    if raw.dtype.kind in "mM":
        raise error(f"{name} must be an array of real (numeric) values, got {raw.dtype} (dates or durations: "
                    "give them as time stamps, times=...)")
    if raw.dtype.kind == "c" or raw.dtype == object and any(isinstance(x, complex) for x in raw.flat):
        raise error(f"{name} must be real, got complex values (take .real or abs() first if that is meant)")
    if raw.dtype.kind not in "biuf":
        try:
            raw = raw.astype(float)
        except (TypeError, ValueError) as exc:
            raise error(f"{name} must be an array of real (numeric) values: {exc}") from None
    array = np.array(raw, dtype=float, copy=True)
    if ndim is not None and array.ndim != ndim:
        raise error(f"{name} must be a {ndim}-D array, got shape {array.shape}")
    if shape is not None and array.shape != shape:
        raise error(f"{name} must have shape {shape}, got {array.shape}")
    if finite and not np.all(np.isfinite(array)):
        raise error(f"{name} must be finite, got NaN or inf")
    return array


def name_list(name: str, value: object, count: int, *, error: type[MoliError] = DataError) -> tuple[str, ...]:
    """``count`` distinct channel names from a list or tuple of strings."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple, np.ndarray)):
        raise wrong_type(error)(f"{name} must be a list of {count} names, got {value!r}")
    names = tuple(str(n) for n in value)
    if len(names) != count:
        raise error(f"{name} has {len(names)} names for {count} channels")
    if len(set(names)) != len(names):
        raise error(f"{name} must be distinct, got {names}")
    return names


def check_channel_order(first: object, second: object, first_what: str, second_what: str) -> None:
    """Refuse ``second`` (a record) where its channels carry ``first``'s names in another order.

    ``first`` and ``second`` have ``output_names`` and ``input_names`` (records, models) and
    as many channels of each kind. Channels are matched by position, so a record whose columns
    were given in another order would be scored, or fitted, channel against the wrong channel;
    names that differ altogether (a record's default names beside a file's) say nothing of the
    order and are let be.
    """
    for side in ("output", "input"):
        ours, theirs = getattr(first, f"{side}_names"), getattr(second, f"{side}_names")
        if tuple(ours) != tuple(theirs) and sorted(ours) == sorted(theirs):
            raise DataError(f"{second_what}'s {side}s are {', '.join(theirs)} and {first_what}'s "
                            f"{', '.join(ours)}: the same channels in another order, and channels are matched "
                            f"by position; give {second_what}'s {side}s in {first_what}'s order")


def check_validation_length(validation: "IOData") -> None:
    """Refuse, before any work, a validation record too short to score a simulation on (one sample)."""
    if validation.N < 2:
        raise DataError(f"validation holds {validation.N} sample: too few to score a model's simulation on; "
                        "give a longer validation record, or none (the last 30 % of data is held out)")
