"""What ``moli fit-many`` keeps on disk: each record's model as it finishes, what
``--resume`` may keep of an earlier run, and the warnings of a fleet told once each.

A record's model file says how it was made (``info``: the options, the channels and
period it was read with, the SHA-256 of its file), so a later run can tell whether it
would make the same model again; :func:`kept_model` is that rule.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from ..data.files import file_sha256
from ..fleets.records import FleetEntry
from ..method.options import IdentifyOptions
from .fleet_report import SCORES, write_summary

__all__ = ["FleetSummary", "save_record", "kept_model", "grouped_warnings", "FILE_PLACEHOLDER", "FIT_COLUMNS"]

FIT_COLUMNS = ("name", "status", "order", "fit", "vaf", "validation_N", "seconds", "warnings", "error", "source")
STATUSES = ("identified", "kept", "failed", "timed out")
# The summary is rewritten after every record of a fleet of up to ALWAYS_REWRITTEN_ROWS
# rows (a rewrite, fsync included, measured on a local disk: 16 ms at 10 rows, 25 ms at
# 1000, 60 ms at 3000, 170 ms at 10000). Beyond, it waits until WRITE_SPACING times its
# last rewrite's duration has passed, so that writing it takes at most 1/20 of the run
# instead of time growing as the square of the records. The models are always written as
# each finishes.
ALWAYS_REWRITTEN_ROWS = 1000
WRITE_SPACING = 19.0

# How a grouped warning names each record's own file (its path differs from record to record).
FILE_PLACEHOLDER = "<file>"


class FleetSummary:
    """The summary of a ``fit-many`` run, rewritten whole as each record finishes.

    Parameters
    ----------
    sources : mapping of str to Path
        Each record's file under its name, in the order the summary lists them.
    folder : Path
        Where the models and ``summary.csv`` / ``summary.html`` go.

    Attributes
    ----------
    rows : dict
        The row of each record finished (or kept), by name.
    """

    def __init__(self, sources: Mapping[str, Path], folder: Path) -> None:
        self.sources, self.folder = dict(sources), folder
        self.rows: dict[str, dict[str, Any]] = {}
        self._sha256: dict[str, str] = {}
        self._written = (0.0, 0.0)  # when the summary was last written, and how long that took

    def sha256(self, name: str) -> str:
        """The SHA-256 of the record's file, read once per run."""
        if name not in self._sha256:
            self._sha256[name] = file_sha256(self.sources[name])
        return self._sha256[name]

    def add(self, entry: FleetEntry, read: Mapping[str, Any]) -> None:
        """Save the entry's model (a model that cannot be written fails its row alone), then the
        summary (unless a large one was rewritten a moment ago: :data:`ALWAYS_REWRITTEN_ROWS`)."""
        row = {**entry.row(), "source": str(self.sources[entry.name]), "warnings": list(entry.warnings),
               "status": "timed out" if entry.timed_out else "failed" if entry.error else "identified",
               "validation_N": None if entry.result is None else entry.result.validation.N}
        if entry.result is not None:
            try:
                save_record(entry, self.sources[entry.name], self.sha256(entry.name), read,
                            self.folder / f"{entry.name}.json")
            except OSError as exc:
                row.update(status="failed",
                           error=f"the model was identified but not written: {type(exc).__name__}: {exc}")
        self.rows[entry.name] = row
        last, took = self._written
        if len(self.rows) <= ALWAYS_REWRITTEN_ROWS or time.monotonic() - last >= WRITE_SPACING * took:
            self.write()

    def counts(self) -> dict[str, int]:
        """How many rows have each status."""
        return {status: sum(row["status"] == status for row in self.rows.values()) for status in STATUSES}

    def warnings(self) -> list[tuple[str, list[str]]]:
        """Each distinct warning of the rows once, with the records that raised it."""
        return grouped_warnings((name, str(self.sources[name]), self.rows[name]["warnings"])
                                for name in self.sources if name in self.rows)

    def write(self, ran: str | None = None) -> tuple[Path, Path]:
        """Write the rows so far; ``ran`` (where and how long) once the run is over.

        Returns
        -------
        csv_path, html_path : Path
        """
        start = time.monotonic()
        rows = [{**self.rows[name], "warnings": "; ".join(self.rows[name]["warnings"]) or None}
                for name in self.sources if name in self.rows]
        counts = ", ".join(f"{count} {status}" for status, count in self.counts().items())
        state = (f"{len(rows)} of {len(self.sources)} records finished when this was written "
                 "(moli fit-many --resume identifies the rest)") if ran is None else ran
        paths = write_summary(
            rows, FIT_COLUMNS, self.folder, "summary", "moli fit-many", "fit", warnings=self.warnings(),
            notes=[f"{state}: {counts}",
                   "status: identified in this run, kept from an earlier run (--resume: the same options, "
                   "channels and file SHA-256), failed, or timed out (--timeout); fit and vaf: mean over the "
                   "outputs of the selected model's NRMSE fit and VAF on the held-out tail, percent; "
                   "validation_N: the samples of that tail, which chose the order; warnings: every warning "
                   f"the record raised (the page numbers them, each told once below; {FILE_PLACEHOLDER} "
                   "stands for each record's own file)", SCORES],
        )
        end = time.monotonic()
        self._written = (end, end - start)
        return paths


def save_record(entry: FleetEntry, source: Path, sha256: str, read: Mapping[str, Any], path: Path) -> None:
    """Write ``entry``'s selected model to ``path`` (whole or not at all), with how it was made.

    Parameters
    ----------
    entry : FleetEntry
        An identified record (``entry.result`` not None).
    source : Path
        Its file, as the user named it.
    sha256 : str
        The SHA-256 of that file when the run began.
    read : mapping
        The reading options: ``inputs``, ``outputs``, ``Ts`` (None when not given).
    path : Path
    """
    result = entry.result
    assert result is not None
    result.model.info.update({
        "data": {"source": str(source), "file_sha256": sha256, "read": dict(read),
                 "N": result.estimation.N + result.validation.N,
                 "validation_N": result.validation.N, "validation_source": result.validation_source},
        "validation_vaf": result.selected.vaf.tolist(),
        "validation_fit": entry.fit,
        "warnings": list(entry.warnings),
        "seconds": entry.seconds,
    })
    result.model.save(path)


def _differences(saved: Any, wanted: Mapping[str, Any]) -> list[str]:
    if not isinstance(saved, Mapping):
        return ["none recorded"]
    return [f"{name} {saved.get(name)!r}, not {value!r}" for name, value in wanted.items() if saved.get(name) != value]


def kept_model(path: Path, options: IdentifyOptions, sha256: str,
               read: Mapping[str, Any]) -> tuple[dict[str, Any] | None, str | None]:
    """What ``--resume`` makes of ``path``: keep its model, or redo the record, and why.

    A model is kept when its ``info`` records the same options, the same reading options
    and the same SHA-256 of the record's file as this run's.

    Returns
    -------
    row : dict or None
        The summary row of the kept model (status ``"kept"``); None otherwise.
    reason : str or None
        Why the record is redone; None when the model is kept or there is none.
    """
    if not path.exists():
        return None, None
    try:
        content = json.loads(path.read_text(encoding="utf-8"))
        info, order = content["info"], len(content["A"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return None, f"its model file cannot be read ({type(exc).__name__}: {exc})"
    data = info.get("data") if isinstance(info.get("data"), Mapping) else {}
    wanted = json.loads(json.dumps(options.to_dict()))  # as the file holds them: lists, not tuples
    changed = _differences(info.get("options"), wanted)
    if changed:
        return None, "its model was made with other options: " + "; ".join(changed)
    if "file_sha256" not in data:
        return None, "its model does not record the SHA-256 of the file it was made from"
    if data["file_sha256"] != sha256:
        return None, "its file is not the one the model was made from (another SHA-256)"
    changed = _differences(data.get("read"), dict(read))
    if changed:
        return None, "its model was read with other channels or period: " + "; ".join(changed)
    vaf = info.get("validation_vaf")
    return {"name": path.stem, "status": "kept", "order": order, "fit": info.get("validation_fit"),
            "vaf": float(np.mean(vaf)) if vaf else None, "validation_N": data.get("validation_N"),
            "seconds": info.get("seconds"), "warnings": list(info.get("warnings", [])),
            "source": data.get("source")}, None


def grouped_warnings(records: Iterable[tuple[str, str, Sequence[str]]]) -> list[tuple[str, list[str]]]:
    """Each distinct warning once, with the records that raised it, in order of first appearance.

    Parameters
    ----------
    records : iterable of (name, source, warnings)
        A record's name, its file as the user named it, and its warnings.

    Returns
    -------
    list of (message, names)
        Where a message names the record's own file, the file reads
        :data:`FILE_PLACEHOLDER`, so that one warning about every file is told once.

    Examples
    --------
    >>> grouped_warnings([("a", "p/a.csv", ["p/a.csv: Ts = 1", "short"]), ("b", "p/b.csv", ["p/b.csv: Ts = 1"])])
    [('<file>: Ts = 1', ['a', 'b']), ('short', ['a'])]
    """
    found: dict[str, list[str]] = {}
    for name, source, messages in records:
        for message in messages:
            found.setdefault(message.replace(source, FILE_PLACEHOLDER) if source else message, []).append(name)
    return list(found.items())
