"""Names read from files are data: how they are shown in figures, consoles and spreadsheets.

A channel name comes from a file's header and may hold anything: matplotlib mathtext
(``$\\frac{a}$``), control characters that forge console lines, a megabyte of text, or
a leading ``=`` that a spreadsheet runs as a formula. Each place that shows a name
passes it through one of these functions first.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["figure_label", "console_text", "report_name", "spreadsheet_cell", "time_label", "frequency_label", "angular_unit",
           "period_text", "number_text", "FIGURE_LABEL_CHARS", "REPORT_NAME_CHARS"]

# Longer names are cut in figures: a title or axis label is a few inches wide, and
# matplotlib lays out text in time that grows with its length.
FIGURE_LABEL_CHARS = 40
# Longer names are cut in reports (the model file keeps them whole): a page that repeats
# a megabyte-long name is no longer one to read.
REPORT_NAME_CHARS = 200
# Cells starting with these run as formulas in spreadsheet programs (OWASP, CSV injection).
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def _shortened(text: str, limit: int) -> str:
    return text if len(text) <= limit else text[: limit - 1] + "…"


def console_text(text: Any, limit: int | None = None) -> str:
    """``text`` with control characters written as escapes, so it stays on its own line.

    Examples
    --------
    >>> console_text("flow\\nfake line")
    'flow\\\\nfake line'
    """
    text = str(text)
    if limit is not None:
        text = text[: limit + 1]  # escapes only lengthen it: what lies beyond is never shown
    shown = "".join(ch if ch.isprintable() or ch == " " else repr(ch)[1:-1] for ch in text)
    return shown if limit is None else _shortened(shown, limit)


def _cut_in_the_middle(text: str, limit: int) -> str:
    """``text`` in at most ``limit`` characters, its middle replaced by ``…``; an escape
    ``\\$`` is never cut in two (its halves would start mathtext or show a stray backslash)."""
    if len(text) <= limit:
        return text
    head, tail = limit - 1 - (limit - 1) // 2, (limit - 1) // 2
    start, end = text[:head], text[len(text) - tail:] if tail else ""
    if start.endswith("\\") and text[head] == "$":
        start = start[:-1]
    if end.startswith("$") and text[len(text) - tail - 1] == "\\":
        end = end[1:]
    return start + "…" + end


def figure_label(text: Any, limit: int = FIGURE_LABEL_CHARS) -> str:
    """``text`` as matplotlib draws it literally: ``$`` escaped (no mathtext), shortened in
    the middle: channels named alike most often differ at the end, and a figure shows them
    side by side.

    Examples
    --------
    >>> figure_label("cost $a$")
    'cost \\\\$a\\\\$'
    >>> figure_label("Plant1/Area2/Reactor3/Valve101.OP", 20)
    'Plant1/Are…lve101.OP'
    """
    # escaped first: the escapes count towards the limit, so no label outgrows it
    return _cut_in_the_middle(console_text(text).replace("$", r"\$"), limit)


def report_name(text: Any, limit: int = REPORT_NAME_CHARS) -> str:
    """``text`` as a report or a sentence about the data shows it: control characters
    escaped, shortened.

    Examples
    --------
    >>> report_name("y" * 300)[-3:], len(report_name("y" * 300))
    ('yy…', 200)
    """
    return console_text(text, limit)


def spreadsheet_cell(value: Any) -> Any:
    """A CSV cell that a spreadsheet shows as text, never runs as a formula.

    Text starting with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return gets a
    leading single quote (the OWASP advice on CSV injection); numbers, and text
    that is a plain number such as ``-1.5``, are kept as they are.

    Examples
    --------
    >>> spreadsheet_cell("=HYPERLINK(1)"), spreadsheet_cell("-2.5"), spreadsheet_cell(-2.5)
    ("'=HYPERLINK(1)", '-2.5', -2.5)
    """
    if not isinstance(value, str) or not value.startswith(FORMULA_STARTS):
        return value
    try:
        if math.isfinite(float(value)) and value.strip() == value:
            return value
    except ValueError:
        pass
    return "'" + value


def time_label(unit: str | None, what: str = "time") -> str:
    """An axis label of time in the record's unit (``IOData.time_unit``, a model's
    ``info["time_unit"]``): "time (s)", or "time" where no unit was stated.

    >>> time_label("s"), time_label(None)
    ('time (s)', 'time')
    """
    return what if unit is None else f"{what} ({unit})"


def angular_unit(unit: str | None) -> str:
    """Radians per the record's time unit: "rad/s", or "rad per time unit" where none was stated."""
    return f"rad/{unit}" if unit is not None else "rad per time unit"


def frequency_label(unit: str | None) -> str:
    """An axis label of angular frequency in the record's time unit.

    >>> frequency_label("ms"), frequency_label(None)
    ('frequency (rad/ms)', 'frequency (rad per time unit)')
    """
    return f"frequency ({angular_unit(unit)})"


def period_text(Ts: float, unit: str | None) -> str:
    """A sampling period with its unit: "0.1 s", or "0.1" where no unit was stated.

    >>> period_text(0.1, "s")
    '0.1 s'
    """
    return f"{Ts:g}" if unit is None else f"{Ts:g} {unit}"


def number_text(value: float, decimals: int, sign: str = "") -> str:
    """``value`` with ``decimals`` decimals, or in ``g`` form from 1e6 on, where fixed decimals
    would print hundreds of digits (a pole of 1e300) or run a table's columns together."""
    return f"{value:{sign}.{decimals}f}" if abs(value) < 1e6 else f"{value:{sign}.{decimals}g}"
