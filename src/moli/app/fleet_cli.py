"""The fleet commands: ``moli fit-many`` and ``moli validate-many``.

``fit-many`` identifies every record matched by glob patterns (on local processes or
a Dask scheduler) and writes one model file per record and a summary table, each
model and the table as each record finishes (``--resume`` keeps them in a later run);
``validate-many`` scores such a folder of models on new records and flags the loops
whose fit dropped. Both exit with code 1 when a record failed or was flagged, so a
scheduled job notices; bad arguments end with ``moli: error: ...`` and code 2.
"""

from __future__ import annotations

import glob
import math
from pathlib import Path
from typing import Any, Callable

import click
import numpy as np

from ..data.atomic_files import check_output_folder
from ..data.display import console_text, number_text
from ..data.files import read_data
from ..data.tables import check_request
from ..errors import DataError, MoliError, OptionError
from ..fleets.backends import MAX_TIMEOUT
from ..fleets.records import identify_many
from ..method.options import PRESETS, IdentifyOptions
from ..method.options.choices import KERNELS, METHODS
from ..method.pipeline.routes import check_kernel_options
from ..models.storage import load_model
from ..validation.comparison import X0_CHOICES, compare
from .console import is_interrupt
from .fleet_files import FleetSummary, kept_model
from .fleet_report import SCORES, write_summary
from .outputs import refuse_overwrite
from .reading import names

__all__ = ["fleet_commands", "match_files"]

FAILED = 1
SUMMARY_FILES = ("summary.csv", "summary.html")
VALIDATION_FILES = ("validation.csv", "validation.html")
# Names longer than this are cut in the console table (the CSV keeps them whole).
NAME_WIDTH = 24
# validate-many flags a loop whose mean fit fell by more than this many points.
DEFAULT_MAX_DROP = 5.0
# A warning raised by many records names this many of them on the console.
NAMES_SHOWN = 5
CHECK_COLUMNS = ("name", "fit_before", "fit_now", "drop", "vaf_now", "status", "error", "source")
# validate-many statuses that flag a loop (a model without a new record is only listed)
FLAGGED = ("dropped", "failed", "no model")


def match_files(patterns: tuple[str, ...]) -> list[Path]:
    """The files matched by glob patterns (or named outright), sorted, each once.

    Raises :class:`DataError` naming a pattern that matches no file.
    """
    found: dict[Path, None] = {}
    for pattern in patterns:
        hits = sorted(Path(hit) for hit in glob.glob(pattern, recursive=True) if Path(hit).is_file())
        if not hits:
            raise DataError(f"no file matches {pattern!r}")
        found.update(dict.fromkeys(hits))
    return list(found)


def _by_stem(files: list[Path]) -> dict[str, Path]:
    """Each file under its stem, the name of its record and its model; two files of one stem are refused."""
    named: dict[str, Path] = {}
    for path in files:
        if path.stem in named:
            raise DataError(f"{named[path.stem]} and {path} are both named {path.stem!r}: a record is "
                            "known by its file's stem; rename one or run them apart")
        named[path.stem] = path
    return named


def _client(address: str) -> Any:
    try:
        from distributed import Client
    except ImportError:
        raise OptionError("--scheduler needs Dask: pip install 'moli[distributed]'") from None
    try:
        return Client(address, timeout="20s")
    except (OSError, TimeoutError, ValueError) as exc:      # ValueError: no address (no port, say)
        raise OptionError(f"--scheduler: cannot reach {address}: {exc}") from None


def fleet_commands(options_from_flags: Callable[..., IdentifyOptions]) -> list[click.Command]:
    """The ``fit-many`` and ``validate-many`` commands.

    Parameters
    ----------
    options_from_flags : callable
        The command line's one rule turning ``--options``/``--preset`` and the option
        flags into :class:`IdentifyOptions` (``moli.app.cli.options_from_flags``),
        handed in so that this module does not import the one that registers it.

    Returns
    -------
    list of click.Command
    """

    @click.command("fit-many")
    @click.argument("patterns", metavar="PATTERN...", nargs=-1, required=True)
    @click.option("--inputs", required=True, help="Comma-separated input column names, e.g. u1,u2.")
    @click.option("--outputs", required=True, help="Comma-separated output column names, e.g. y1,y2.")
    @click.option("--ts", type=float, help="Sampling period [default: a time column's step, else 1].")
    @click.option("--workers", type=click.IntRange(min=1),
                  help="Local worker processes [default: the usable CPUs].")
    @click.option("--scheduler", metavar="ADDRESS",
                  help="Run on this Dask scheduler (e.g. tcp://10.0.0.5:8786) instead of local processes.")
    @click.option("--options", "options_file", type=click.Path(path_type=Path),
                  help="JSON file of identification options, or a saved model whose options are reused.")
    @click.option("--preset", type=click.Choice(PRESETS), help="Search options, as for moli fit [default: default].")
    @click.option("--nmax", type=int, help="Largest order on the greedy path [default: max(10, p + 4)].")
    @click.option("--seed", type=int, help="Seed of the randomized filter search [default: 0].")
    @click.option("--method", type=click.Choice(METHODS), help="The MOLI path, or a kernel method for short "
                  "records, as for moli fit (docs/regularization.md) [default: moli].")
    @click.option("--kernel", type=click.Choice(KERNELS), help="With --method kernel or kernel-arx: the prior "
                  "[default: TC].")
    @click.option("--out", "out_dir", default="models", show_default=True, type=click.Path(path_type=Path),
                  help="Folder for NAME.json per record and summary.csv / summary.html.")
    @click.option("--force", is_flag=True, help="Overwrite model files and a summary already in --out.")
    @click.option("--resume", is_flag=True,
                  help="Keep the models in --out made with these options from these very files; identify the rest.")
    @click.option("--timeout", type=click.FloatRange(min=0, min_open=True, max=MAX_TIMEOUT), metavar="SECONDS",
                  help="End a record that runs longer (its worker process with it) and list it as timed out.")
    def fit_many(*, patterns: tuple[str, ...], inputs: str, outputs: str, ts: float | None,
                 workers: int | None, scheduler: str | None, options_file: Path | None,
                 preset: str | None, nmax: int | None, seed: int | None, method: str | None, kernel: str | None,
                 out_dir: Path, force: bool, resume: bool, timeout: float | None) -> None:
        """Identify every record matched by PATTERN (quote it: 'plant/*.csv').

        Each record is named by its file's stem and identified on its own, its last
        30 % held out for the order rule; one that fails is listed with its error
        and the others go on. Each model and the summary are written as each record
        finishes, so a run that is stopped keeps what it finished (--resume goes on).
        """
        if scheduler is not None and workers is not None:
            raise OptionError("give either --workers (local processes) or --scheduler, not both")
        if resume and force:
            raise OptionError("give either --resume (keep the models already made) or --force (redo them all)")
        if timeout is not None and scheduler is not None:
            raise OptionError("--timeout ends the worker process of a record that runs too long: it needs "
                              "local processes (--workers), not --scheduler")
        options = options_from_flags(options_file, preset, nmax=nmax, seed=seed, method=method, kernel=kernel,
                                     runs_kernel=True)
        check_kernel_options(options)       # before any record is read, as moli fit refuses them
        files = match_files(patterns)
        sources = _by_stem(files)
        written = [*SUMMARY_FILES, *(f"{name}.json" for name in sources)]
        check_output_folder(out_dir, "--out", written, [*files, *([options_file] if options_file else [])])
        if not resume:
            refuse_overwrite([out_dir / name for name in written], force)
        read = {"inputs": names(inputs), "outputs": names(outputs), "Ts": ts}
        check_request(read["inputs"], read["outputs"], ts, None, None, 0.0)   # as moli fit does, before any work
        summary = FleetSummary(sources, out_dir)
        for name, source in sources.items():
            sha256 = summary.sha256(name)  # each file's as the run starts, the one its model records
            kept, redo = kept_model(out_dir / f"{name}.json", options, sha256, read) if resume else (None, None)
            if kept is not None:
                summary.rows[name] = {**kept, "source": str(source)}
            elif redo is not None:
                click.echo(f"  redone: {console_text(name)}: {console_text(redo)}", err=True)
        executor = None if scheduler is None else _client(scheduler)    # a bad address, before anything is written
        out_dir.mkdir(parents=True, exist_ok=True)
        summary.write()
        to_run = {name: str(source) for name, source in sources.items() if name not in summary.rows}
        try:
            fleet = identify_many(to_run, options, executor=executor, n_jobs=workers, read_options=read,
                                  timeout=timeout, on_entry=lambda entry: summary.add(entry, read)) \
                if to_run else None
        except BaseException as exc:
            if is_interrupt(exc):
                summary.write()  # every record finished so far, the last one included
            raise
        finally:
            if executor is not None:
                executor.close()
        ran = "kept, none run" if fleet is None else f"on {fleet.backend} in {fleet.seconds:.1f} s"
        csv_path, html_path = summary.write(f"{len(sources)} records {ran}")
        counts = summary.counts()
        click.echo(f"{len(sources)} records {ran}: {counts['identified'] + counts['kept']} models in {out_dir}"
                   + (f" ({counts['kept']} kept from an earlier run)" if resume else "")
                   + f", {counts['failed'] + counts['timed out']} failed"
                   + (f" ({counts['timed out']} timed out)" if counts["timed out"] else ""))
        for row in (summary.rows[name] for name in sources if name in summary.rows):
            if row.get("error"):
                click.echo(f"  {row['status']}: {console_text(row['name'])}: {console_text(row['error'])}", err=True)
        for message, named in summary.warnings():
            click.echo(f"  warning: {_raised_by(named)}: {console_text(message)}", err=True)
        click.echo(f"summary written to {csv_path} and {html_path}")
        if counts["failed"] or counts["timed out"]:
            raise click.exceptions.Exit(FAILED)

    @click.command("validate-many")
    @click.argument("models_dir", metavar="MODELS", type=click.Path(path_type=Path))
    @click.argument("patterns", metavar="PATTERN...", nargs=-1, required=True)
    @click.option("--x0", type=click.Choice(X0_CHOICES), default="zero", show_default=True,
                  help="Simulate from the zero state or from a least-squares initial state.")
    @click.option("--max-drop", type=click.FloatRange(min=0), default=DEFAULT_MAX_DROP, show_default=True,
                  help="Flag a loop whose mean fit fell by more than this many points.")
    @click.option("--out", "out_dir", type=click.Path(path_type=Path),
                  help="Folder for validation.csv / validation.html [default: MODELS].")
    @click.option("--force", is_flag=True, help="Overwrite a validation.csv / validation.html already there.")
    def validate_many(models_dir: Path, patterns: tuple[str, ...], x0: str, max_drop: float,
                      out_dir: Path | None, force: bool) -> None:
        """Score the models in MODELS on the new records matched by PATTERN.

        A record is checked by the model of the same name (MODELS/NAME.json for
        NAME.csv), read with its channel names and period. A loop is flagged when
        its mean NRMSE fit fell by more than --max-drop points from the fit saved
        by fit-many.
        """
        if not math.isfinite(max_drop):
            raise OptionError(f"--max-drop must be a finite number of points, got {max_drop}")
        if not models_dir.is_dir():
            raise DataError(f"no folder of models at {models_dir}")
        models = {path.stem: path for path in sorted(models_dir.glob("*.json"))}
        records = _by_stem(match_files(patterns))
        check_output_folder(out_dir or models_dir, "--out", VALIDATION_FILES,
                            [*records.values(), *models.values()])
        refuse_overwrite([(out_dir or models_dir) / name for name in VALIDATION_FILES], force)
        if not set(models) & set(records):
            raise DataError(f"no record matched by {', '.join(patterns)} has a model of its name in {models_dir}")
        rows = [_check(name, models.get(name), records[name], x0, max_drop) for name in records]
        rows += [{"name": name, "status": "no new record", "source": str(path)}
                 for name, path in models.items() if name not in records]
        flagged = [row["status"] in FLAGGED for row in rows]
        csv_path, html_path = write_summary(
            rows, CHECK_COLUMNS, out_dir or models_dir, "validation", "moli validate-many", "drop",
            flagged=flagged,
            notes=[f"fit: mean NRMSE fit, percent, simulation from the {x0} initial state; "
                   f"dropped: the fit fell by more than {max_drop:g} points from fit_before, "
                   "the fit fit-many saved with the model", SCORES],
        )
        click.echo(f"{'name':<{NAME_WIDTH}}{'fit before':>12}{'fit now':>10}{'drop':>8}  status")
        for row in sorted(rows, key=lambda r: -(r.get("drop") or 0)):
            click.echo(f"{console_text(row['name'], NAME_WIDTH):<{NAME_WIDTH}}{_number(row.get('fit_before')):>12}"
                       f"{_number(row.get('fit_now')):>10}{_number(row.get('drop')):>8}  "
                       + (f"failed: {console_text(row['error'])}" if row.get("error") else row["status"]))
        click.echo(f"{len(rows)} loops, {sum(flagged)} flagged; written to {csv_path} and {html_path}")
        if any(flagged):
            raise click.exceptions.Exit(FAILED)

    return [fit_many, validate_many]


def _raised_by(named: list[str]) -> str:
    """``loop1``, or ``3 records (loop0, loop1, loop2)``, the list cut after NAMES_SHOWN names."""
    if len(named) == 1:
        return console_text(named[0])
    shown = ", ".join(named[:NAMES_SHOWN]) + (", ..." if len(named) > NAMES_SHOWN else "")
    return f"{len(named)} records ({console_text(shown)})"


def _number(value: float | None) -> str:
    return "" if value is None else number_text(value, 2)


def _check(name: str, model_path: Path | None, record: Path, x0: str, max_drop: float) -> dict[str, Any]:
    """One loop's check; a failure is the row's error, never the end of the run."""
    row: dict[str, Any] = {"name": name, "source": str(record)}
    if model_path is None:
        return {**row, "status": "no model"}
    try:
        model = load_model(model_path)
        data = read_data(record, list(model.input_names), list(model.output_names), model.Ts)
        comparison = compare(model, data, x0)
    except (MoliError, OSError) as exc:
        return {**row, "status": "failed", "error": f"{type(exc).__name__}: {exc}"}
    now = float(np.mean(comparison.fit))
    before = model.info.get("validation_fit")
    drop = None if before is None else float(before) - now
    status = "dropped" if drop is not None and drop > max_drop else "ok"
    return {**row, "fit_before": before, "fit_now": now, "drop": drop, "vaf_now": comparison.mean_vaf,
            "status": status}
