"""Summary tables of a fleet: a CSV file and a self-contained, sortable HTML page."""

from __future__ import annotations

import csv
import html
from pathlib import Path
from typing import Any, Mapping, Sequence

from .._version import __version__
from ..data.atomic_files import atomic_file, write_atomic
from ..data.display import number_text, spreadsheet_cell

__all__ = ["SCORES", "write_summary"]

# What VAF and fit are, wherever a table shows them without the report's longer note.
SCORES = ("VAF = 100 (1 - var(y - yhat) / var(y)), clipped at 0: a model no better than the "
          "output's mean scores 0, so one diverging output cannot drag a mean arbitrarily far "
          "down; fit = 100 (1 - |y - yhat| / |y - mean(y)|), not clipped (negative: worse than the "
          "mean). yhat is a simulation driven by the measured inputs alone, not a prediction; "
          "percent, 100 is perfect")

STYLE = """
body { font-family: sans-serif; max-width: 70em; margin: 2em auto; color: #222; }
table { border-collapse: collapse; font-size: 0.9em; }
th, td { padding: 0.2em 0.6em; text-align: right; border-bottom: 1px solid #ddd; }
th { cursor: pointer; background: #f3f3f3; }
td.text { text-align: left; }
tr.flag { background: #fde7c7; }
.note { color: #555; font-size: 0.9em; }
"""

# Clicking a header sorts by that column (numbers as numbers, blanks last), again to reverse.
SORTER = """
function sortBy(col) {
  const body = document.querySelector("#fleet tbody");
  const rows = Array.from(body.rows);
  const up = body.dataset.col == col && body.dataset.dir != "up";
  const key = r => { const t = r.cells[col].textContent; const x = Number(t);
                     return t === "" ? null : (isNaN(x) ? t : x); };
  rows.sort((a, b) => { const x = key(a), y = key(b);
    if (x === null || y === null) return (x === null) - (y === null);
    return (x < y ? -1 : x > y ? 1 : 0) * (up ? 1 : -1); });
  body.dataset.col = col; body.dataset.dir = up ? "up" : "down";
  rows.forEach(r => body.appendChild(r));
}
"""


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return number_text(value, 2)
    return str(value)


def _warning_list(warnings: Sequence[tuple[str, Sequence[str]]]) -> str:
    """The page's Warnings section: each distinct warning once, with how many records raised it and which."""
    if not warnings:
        return ""
    items = "".join(f"<li><b>W{k}</b>, {len(names)} record{'s' if len(names) > 1 else ''} "
                    f"({html.escape(', '.join(map(str, names)))}): {html.escape(message)}</li>"
                    for k, (message, names) in enumerate(warnings, 1))
    return f"<h2>Warnings</h2>\n<ul>{items}</ul>"


def write_summary(
    rows: Sequence[Mapping[str, Any]],
    columns: Sequence[str],
    folder: Path,
    stem: str,
    title: str,
    sort_by: str,
    *,
    flagged: Sequence[bool] | None = None,
    notes: Sequence[str] = (),
    warnings: Sequence[tuple[str, Sequence[str]]] = (),
) -> tuple[Path, Path]:
    """Write ``stem.csv`` and ``stem.html`` in ``folder``, rows sorted by ``sort_by``.

    Parameters
    ----------
    rows : sequence of mappings
        One per record; ``columns`` are read from each (None is an empty cell).
    columns : sequence of str
    folder : Path
    stem : str
        File name without suffix.
    title : str
        The page's heading.
    sort_by : str
        The column the page shows sorted, highest first (blanks last); the CSV keeps
        the order of ``rows``.
    flagged : sequence of bool, optional
        Rows to highlight.
    notes : sequence of str
        Lines shown under the heading.
    warnings : sequence of (message, names)
        Each distinct warning once with the records that raised it: the page lists
        them under "Warnings", numbered, and its ``warnings`` column shows a row's
        numbers (the CSV keeps the column's text).

    Returns
    -------
    csv_path, html_path : Path
    """
    folder.mkdir(parents=True, exist_ok=True)
    csv_path, html_path = folder / f"{stem}.csv", folder / f"{stem}.html"
    with atomic_file(csv_path, newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(columns), extrasaction="ignore")
        writer.writeheader()
        writer.writerows({c: "" if row.get(c) is None else spreadsheet_cell(row[c]) for c in columns}
                         for row in rows)
    marks = list(flagged) if flagged is not None else [False] * len(rows)
    order = sorted(range(len(rows)), key=lambda i: (rows[i].get(sort_by) is None, -(rows[i].get(sort_by) or 0)))
    raised: dict[str, list[str]] = {}
    for k, (_, names) in enumerate(warnings, 1):
        for name in names:
            raised.setdefault(str(name), []).append(f"W{k}")
    head = "".join(f'<th onclick="sortBy({k})">{html.escape(c)}</th>' for k, c in enumerate(columns))
    body = []
    for i in order:
        shown = {**rows[i], "warnings": "; ".join(raised.get(str(rows[i].get("name")), [])) or None} \
            if warnings else rows[i]
        cells = "".join(
            f'<td class="text">{html.escape(_cell(shown.get(c)))}</td>'
            if isinstance(shown.get(c), str) else f"<td>{html.escape(_cell(shown.get(c)))}</td>"
            for c in columns
        )
        body.append(f'<tr class="flag">{cells}</tr>' if marks[i] else f"<tr>{cells}</tr>")
    failures = [row for row in rows if row.get("error")]
    failed = "".join(f"<li><b>{html.escape(str(row['name']))}</b>: {html.escape(str(row['error']))}</li>"
                     for row in failures)
    page = f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{STYLE}</style><script>{SORTER}</script></head><body>
<h1>{html.escape(title)}</h1>
{"".join(f'<p class="note">{html.escape(note)}</p>' for note in notes)}
<p class="note">{len(rows)} records, {len(failures)} failed. Click a column heading to sort by it.</p>
<table id="fleet"><thead><tr>{head}</tr></thead>
<tbody data-col="{list(columns).index(sort_by)}" data-dir="down">{"".join(body)}</tbody></table>
<h2>Failures</h2>
{f"<ul>{failed}</ul>" if failures else "<p>None.</p>"}
{_warning_list(warnings)}
<p class="note">moli {__version__}</p>
</body></html>
"""
    write_atomic(html_path, page)
    return csv_path, html_path
