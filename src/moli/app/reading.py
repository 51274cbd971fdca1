"""How the commands read their records: the reading flags, one file or several merged,
and the warnings a run raises, printed once each and kept for the report."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path
from typing import Any, Callable, Sequence

import click
from tqdm import tqdm

from ..data.display import console_text
from ..data.files import read_data
from ..data.iodata import IOData, merge
from ..errors import DataError, IrregularSamplingWarning, OptionError, SamplingPeriodWarning

__all__ = ["RunWarnings", "names", "read_records", "reading_options"]

# what reading says on the command line: where the time stamps are irregular, where Ts came from
READ_WARNINGS = (IrregularSamplingWarning, SamplingPeriodWarning)


def names(text: str | None) -> list[str] | None:
    """Comma-separated channel names of a flag; None when the flag is not given."""
    return None if text is None else [name.strip() for name in text.split(",") if name.strip()]


class RunWarnings:
    """The distinct warnings of one run, each printed once as ``moli: warning: ...``.

    ``messages`` keeps them in order for the report and the model file.
    """

    def __init__(self) -> None:
        self.messages: list[str] = []

    def add(self, caught: Sequence[warnings.WarningMessage]) -> None:
        for message in (str(w.message) for w in caught):
            if message not in self.messages:
                self.messages.append(message)
                # through tqdm: a phase's line open on stderr is redrawn below the warning
                tqdm.write(f"moli: warning: {console_text(message)}", file=sys.stderr)


def reading_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """The flags that say how to read a data file (every format of read_data)."""
    flags = [
        click.option("--delimiter", help="Column separator of a text file: one character, or "
                     "tab or whitespace [default: sniffed]."),
        click.option("--decimal", type=click.Choice([".", ","]),
                     help="Decimal mark of a text file [default: sniffed]."),
        click.option("--encoding", help="Encoding of a text file, e.g. utf-8, utf-16, cp1252 "
                     "[default: detected]."),
        click.option("--sheet", help="Sheet of an .xlsx workbook: its name or 0-based position "
                     "[default: the first]."),
        click.option("--time-column", help="Column of time stamps [default: found by its name "
                     "(time, Time [s], Zeit...) or content, docs/data.md]."),
        click.option("--time-format", help="strftime format of date-times that are not ISO 8601, "
                     "e.g. '%d/%m/%Y %H:%M:%S'."),
        click.option("--no-time-column", is_flag=True, help="Ignore time columns."),
    ]
    for flag in reversed(flags):
        command = flag(command)
    return command


def read_records(paths: Sequence[Path], inputs: list[str] | None, outputs: list[str] | None,
                 ts: float | None, reading: dict[str, Any], noted: RunWarnings) -> IOData:
    """read_data on each file with the reading flags; several files are merged as experiments.

    Irregular time steps and where Ts came from become warning lines. Files whose channels or sampling periods
    differ are an error naming the file (:func:`moli.merge`).
    """
    reading = dict(reading)
    if reading.pop("no_time_column"):
        if reading["time_column"] is not None:
            raise OptionError("give --time-column NAME or --no-time-column, not both")
        reading["time_column"] = False
    records = []
    for path in paths:
        with warnings.catch_warnings(record=True) as caught:
            for category in READ_WARNINGS:
                warnings.simplefilter("always", category)
            records.append(read_data(path, inputs, outputs, ts, **reading))
        noted.add([w for w in caught if issubclass(w.category, READ_WARNINGS)])
    if len(records) == 1:
        return records[0]
    try:
        return merge(records)
    except DataError as exc:
        listed = ", ".join(f"record {i} = {path}" for i, path in enumerate(paths))
        raise DataError(f"cannot merge the files as experiments of one plant ({listed}): {exc}") from None
