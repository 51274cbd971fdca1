"""Where the commands write, and the rule that they never overwrite without ``--force``.

Each run writes into one folder of its own, named after what it read
(``moli-fit-plant/`` for ``plant.csv``), unless the user points elsewhere. A file
that is already there (a model, a report, a figure, a summary) is left alone: the
command stops before any work with one line naming it and the flag that allows it. A
finished model is written whole even if Ctrl-C comes meanwhile (:func:`save_held`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable, Sequence

import click

from ..data.atomic_files import check_output_file, check_output_folder
from ..errors import OptionError
from .console import InterruptHold

__all__ = ["REPORT_FILE", "MODEL_WRITTEN", "run_folder", "refuse_overwrite", "fit_outputs", "save_held"]

REPORT_FILE = "report.html"
# click's ctx.meta key of the model file a command has written: a later Ctrl-C ends the
# command as a partial run (exit code 3), not as one that wrote nothing (130)
MODEL_WRITTEN = "moli.model_written"
# a folder name joins at most this many record names, then counts the rest
NAMES_IN_FOLDER = 3


def run_folder(command: str, names: Sequence[str]) -> Path:
    """The default output folder of one run: ``moli-<command>-<names>``.

    Parameters
    ----------
    command : str
        The command, e.g. ``"fit"``.
    names : sequence of str
        What the run read: file stems or a DaISy name.

    Returns
    -------
    Path
        Relative to the current folder.

    Examples
    --------
    >>> run_folder("fit", ["run1", "run2"]).as_posix()
    'moli-fit-run1+run2'
    >>> run_folder("fit", ["a", "b", "c", "d", "e"]).as_posix()
    'moli-fit-a+b+c+2-more'
    """
    shown = list(names[:NAMES_IN_FOLDER])
    if len(names) > NAMES_IN_FOLDER:
        shown.append(f"{len(names) - NAMES_IN_FOLDER}-more")
    return Path(f"moli-{command}-{'+'.join(shown)}")


def refuse_overwrite(paths: Iterable[Path], force: bool) -> None:
    """Raise :class:`OptionError` naming the first of ``paths`` that exists, unless ``force``.

    Called before any work, so that a long identification never ends in a refusal.
    """
    if force:
        return
    for path in paths:
        if path.exists():
            raise OptionError(f"{path} exists: give --force to overwrite it, or --out to write elsewhere")


def fit_outputs(model_path: Path | None, report_dir: Path | None, folder: Path, force: bool,
                read: list[Path]) -> tuple[Path, Path | None]:
    """The model file and report folder of a fit, refused before any work if they exist.

    Without --out, both go into the run's own ``folder``; with --out, a report only where
    --report says. ``read`` are the files the run reads, which it must not write over.
    """
    if model_path is None:
        model_path, report_dir = folder / "model.json", report_dir or folder / "report"
    check_output_file(model_path, "--out", read)
    if report_dir is not None:
        check_output_folder(report_dir, "--report", (REPORT_FILE,), read)
    refuse_overwrite([model_path] + ([report_dir / REPORT_FILE] if report_dir is not None else []), force)
    return model_path, report_dir


def save_held(model: Any, model_path: Path, hold: InterruptHold) -> None:
    """Write the finished ``model`` while ``hold`` keeps Ctrl-C from cutting it short, then act on
    a Ctrl-C that came meanwhile: the command ends as a partial run (exit code 3), the model kept.

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel
    model_path : Path
    hold : InterruptHold
        Started when the search returned.
    """
    hold.start()        # a no-op when already held
    try:
        model_path.parent.mkdir(parents=True, exist_ok=True)
        model.save(model_path)
        click.get_current_context().meta[MODEL_WRITTEN] = model_path
        click.echo(f"model written to {model_path}")
    finally:
        interrupted = hold.release()
    if interrupted:
        raise KeyboardInterrupt
