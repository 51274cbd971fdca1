"""Checks of single option values: each returns the value in its canonical form or raises
an :class:`OptionError` that names the field of :class:`moli.IdentifyOptions` and what it accepts."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...data.arguments import flag, integer, real_number
from ...errors import OptionError, wrong_type

__all__ = [
    "option_error", "check_integer", "check_number", "check_ridges", "check_choice", "check_flag",
    "check_omega_pairs", "check_delays", "check_names",
]

def option_error(name: str, accepted: str, value: object, of_type: bool = False) -> OptionError:
    error = wrong_type(OptionError) if of_type else OptionError
    return error(f"IdentifyOptions.{name} must be {accepted}, got {value!r}")


def check_integer(name: str, value: object, low: int, high: int | None = None) -> int:
    accepted = f"an integer >= {low}" if high is None else f"an integer from {low} to {high}"
    try:
        number = integer(name, value, error=OptionError)   # numpy's integers too; bools, floats, arrays not
    except OptionError:
        raise option_error(name, accepted, value, of_type=True) from None
    if number < low or (high is not None and number > high):
        raise option_error(name, accepted, value)
    return number


def check_number(name: str, value: object, accepted: str, ok: Any) -> float:
    # a complex value would lose its imaginary part to float(), an array of one element its shape
    try:
        number = real_number(name, value, error=OptionError)
    except TypeError:                                      # the wrong kind of value
        raise option_error(name, accepted, value, of_type=True) from None
    except OptionError:                                    # NaN or infinite
        raise option_error(name, accepted, value) from None
    if not ok(number):
        raise option_error(name, accepted, value)
    return number


def check_ridges(value: object) -> float | tuple[float, ...]:
    accepted = "a number >= 0, or a non-empty sequence of them (guarded refinement tries each)"
    if isinstance(value, (list, tuple)):
        if not value:
            raise option_error("refine_ridge", accepted, value)
        return tuple(check_number("refine_ridge", v, accepted, lambda r: r >= 0) for v in value)
    return check_number("refine_ridge", value, accepted, lambda r: r >= 0)


def check_choice(name: str, value: object, choices: tuple[Any, ...]) -> Any:
    for choice in choices:
        if value is choice or (isinstance(value, str) and value == choice):
            return choice
    raise option_error(name, "one of " + ", ".join(repr(c) for c in choices), value)


def check_flag(name: str, value: object) -> bool:
    try:
        return flag(name, value, error=OptionError)
    except OptionError:
        raise option_error(name, "True or False", value, of_type=True) from None


def check_omega_pairs(value: object) -> tuple[tuple[float, float], ...] | None:
    if value is None:
        return None
    accepted = "None or a non-empty list of (wc, zeta) pairs with wc > 0 and zeta > 0"
    try:
        rows = [tuple(row) for row in value]  # type: ignore[union-attr]
    except TypeError:
        raise option_error("omega", accepted, value) from None
    pairs = []
    for row in rows:
        if len(row) != 2:
            raise option_error("omega", accepted, value)
        wc, zeta = (check_number("omega", v, accepted, lambda x: x > 0) for v in row)
        pairs.append((wc, zeta))
    if not pairs:
        raise option_error("omega", accepted, value)
    return tuple(pairs)


def check_delays(value: object) -> int | tuple[int, ...] | str:
    if isinstance(value, str) and value == "auto":
        return "auto"
    accepted = "'auto', a non-negative integer (every input) or a non-empty sequence of them (one per input)"

    def one(item: object) -> int:
        try:
            return integer("delays", item, error=OptionError, low=0)
        except OptionError:
            raise option_error("delays", accepted, value) from None

    if isinstance(value, (list, tuple, np.ndarray)):
        if len(value) == 0:
            raise option_error("delays", accepted, value)
        return tuple(one(item) for item in value)
    return one(value)


def check_names(name: str, value: object) -> tuple[str, ...] | None:
    """None, or a non-empty sequence of distinct channel names as a tuple (one name alone is allowed)."""
    if value is None:
        return None
    accepted = "None, a channel name or a non-empty sequence of distinct channel names"
    names = (value,) if isinstance(value, str) else value
    if not isinstance(names, (list, tuple)) or not names or not all(isinstance(v, str) and v for v in names):
        raise option_error(name, accepted, value)
    if len(set(names)) != len(names):
        raise option_error(name, accepted + " (a name is repeated)", value)
    return tuple(names)
