"""The ``moli`` command: identify from a file, validate and inspect saved models.

Bad input (missing or unreadable file, unknown column, non-numeric or empty cell, too
few samples, a model that does not match the data) ends with one line
``moli: error: ...`` on stderr and exit code 2, never a traceback; a model written from a
partial run gives 3, Ctrl-C before any model is written 130 (:mod:`moli.app.console`).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import click
from tqdm import tqdm

from .._version import __version__
from ..data.atomic_files import check_output_file, check_output_folder
from ..data.daisy import daisy_path, load_daisy
from ..data.display import console_text
from ..data.files import file_sha256, fingerprint
from ..data.iodata import IOData
from ..data.outliers import flag_outliers, remove_outliers
from ..errors import DataError, MoliError, OptionError
from ..method.identification import IdentificationResult
from ..method.closed_loop.reference_projection import without_reference
from ..method.options import PRESETS, IdentifyOptions
from ..method.options.choices import KERNEL_METHODS, KERNELS, METHODS
from ..method.search.greedy_path import PathStep, StructureSearch, exhaustive
from ..models.storage import load_model
from ..numerics.blas_threads import limited_blas
from ..systems.plant import example_data
from ..validation.comparison import X0_CHOICES, compare
from .figure_files import check_figure_suffix, save_figure
from .figures import measured_vs_simulated
from .fleet_cli import fleet_commands
from .fleet_report import SCORES
from .outputs import MODEL_WRITTEN, REPORT_FILE, fit_outputs, refuse_overwrite, run_folder, save_held
from .progress import READING_SHOWN_AFTER, Phases
from .reading import RunWarnings, names, read_records, reading_options
from .console import PARTIAL, USAGE_ERROR, InterruptHold, interrupted, is_interrupt
from .flag_options import options_from_flags
from .continuous_fit import fit_continuous
from .frequency_fit import fit_frequency
from .kernel_fit import fit_kernel
from .describe import describe
from .search_run import held_out_search
from .report import write_report

__all__ = ["cli", "main", "describe", "options_from_flags"]

# --all-lists fits every list only for orders with at most this many lists: the count
# C(n-1, p-1) grows fast, and each list costs one filter search.
MAX_LISTS_PER_ORDER = 30

class _Group(click.Group):
    """Turns bad input into one line on stderr and exit code 2.

    Flags click cannot parse (``--nmax abc``, an unknown option or command) are bad
    input too: one line, without click's usage block.
    """

    def make_context(self, info_name: str | None, args: list[str], parent: click.Context | None = None,
                     **extra: Any) -> click.Context:
        try:
            return super().make_context(info_name, args, parent, **extra)
        except click.UsageError as exc:
            click.echo(f"moli: error: {exc.format_message()}", err=True)
            sys.exit(USAGE_ERROR)
        except BaseException as exc:     # Ctrl-C while the flags are parsed: nothing written yet
            if not is_interrupt(exc):
                raise
            sys.exit(interrupted())

    def invoke(self, ctx: click.Context) -> Any:
        try:
            with limited_blas():        # the report's computations too (moli.numerics.blas_threads)
                return super().invoke(ctx)
        except click.UsageError as exc:
            click.echo(f"moli: error: {exc.format_message()}", err=True)
            ctx.exit(USAGE_ERROR)
        except (MoliError, OSError) as exc:
            click.echo(f"moli: error: {console_text(exc)}", err=True)
            ctx.exit(USAGE_ERROR)
        except BaseException as exc:     # Ctrl-C: 3 once the model is written (docs/cli.md, exit codes)
            if not is_interrupt(exc):
                raise
            written = ctx.meta.get(MODEL_WRITTEN)
            ctx.exit(interrupted(None if written is None else console_text(written)))


def _identify(data: IOData, fraction: float, options: IdentifyOptions, noted: RunWarnings,
              last_run: str | None = None, hold: InterruptHold | None = None) -> IdentificationResult:
    """Split off the validation tail and run the greedy search with a progress bar; ``hold``
    starts as the search returns (:func:`_finish` releases it once the model is written)."""
    result = held_out_search(data, fraction, options, noted, last_run, hold=hold)
    estimation, validation = data.split(1.0 - fraction)     # the records as read, for the fingerprint
    if result.skipped:
        click.echo(f"moli: interrupted; keeping the model before the {result.skipped[0]} "
                   f"(skipped: {', '.join(result.skipped)})", err=True)
    elif result.interrupted:
        done = len(result.path)
        click.echo(f"moli: interrupted after {done} order{'s' * (done != 1)} of the search; keeping the best "
                   "model found so far", err=True)
    result.model.info.update({
        "data": {"sha256": fingerprint(estimation), "N": estimation.N,
                 "validation_N": validation.N, "validation_fraction": fraction,
                 "validation_source": result.validation_source},
        "validation_vaf": result.selected.vaf.tolist(),
    })
    return result


def _all_lists(result: IdentificationResult) -> tuple[list[PathStep], bool]:
    """Every list of each path order with few enough lists, minus the path itself; and whether
    Ctrl-C stopped them (the lists done are kept)."""
    opts = result.options
    search = StructureSearch(result.estimation, result.validation, result.omega,
                             opts.tuning, opts.iterations, opts.s, seed=opts.seed, x0=opts.x0)
    p = result.estimation.p
    orders = [st.order for st in result.path if math.comb(st.order - 1, p - 1) <= MAX_LISTS_PER_ORDER]
    on_path = {st.indices for st in result.path}
    tried: list[PathStep] = []
    try:
        for order in tqdm(orders, desc="every list", unit="order", file=sys.stderr):
            tried += [st for st in exhaustive(search, order) if st.indices not in on_path]
    except KeyboardInterrupt:
        click.echo("moli: interrupted; stopped fitting every list, the report shows those done", err=True)
        return tried, True
    return tried, False


def _finish(result: IdentificationResult, model_path: Path, report_dir: Path | None, all_lists: bool,
            noted: RunWarnings, hold: InterruptHold, *, data_files: tuple[Path, ...] = ()) -> int:
    """Print the summary, write the model and the report; the exit code (0, or 3 for a partial run)."""
    click.echo(result.summary())
    result.model.info["warnings"] = list(noted.messages)
    save_held(result.model, model_path, hold)
    lists_stopped = False
    if report_dir is not None:
        tried, lists_stopped = _all_lists(result) if all_lists else ([], False)
        with Phases() as phases:
            phases("report")
            report = write_report(result, report_dir, tried, data_file=data_files[0] if len(data_files) == 1 else None,
                                  warnings=noted.messages)
        click.echo(f"report written to {report}")
    return PARTIAL if result.interrupted or lists_stopped else 0


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="moli")
def cli() -> None:
    """Identify multivariable linear models from measured data with MOLI-ZOFT."""


_FORCE = click.option("--force", is_flag=True, help="Overwrite files already there (a model, a report, a figure).")


@cli.command()
@click.option("--out", "out_dir", default="moli-demo", show_default=True, type=click.Path(path_type=Path),
              help="Folder for report.html, the figures and model.json.")
@click.option("--nmax", type=int, help="Largest order on the greedy path [default: as moli fit, max(10, p + 4)].")
@click.option("--all-lists", is_flag=True, help="Also fit every list of each order (slower).")
@_FORCE
def demo(out_dir: Path, nmax: int, all_lists: bool, force: bool) -> None:
    """Identify the built-in simulated 3x3 plant and write a report."""
    check_output_folder(out_dir, "--out", ("model.json", REPORT_FILE))
    refuse_overwrite([out_dir / "model.json", out_dir / REPORT_FILE], force)
    data = example_data()
    click.echo(f"built-in example plant: {data}")
    noted = RunWarnings()
    with InterruptHold() as hold:
        result = _identify(data, 0.5, IdentifyOptions(nmax=nmax), noted, hold=hold)
        result.model.info["data"]["source"] = "moli.example_data()"
        code = _finish(result, out_dir / "model.json", out_dir, all_lists, noted, hold)
    click.get_current_context().exit(code)


@cli.command()
@click.argument("data_files", metavar="DATA...", nargs=-1, type=click.Path(path_type=Path))
@click.option("--inputs", help="Comma-separated input column names, e.g. u1,u2.")
@click.option("--outputs", help="Comma-separated output column names, e.g. y1,y2.")
@click.option("--daisy", metavar="NAME", help="Use a DaISy benchmark set instead of DATA.")
@click.option("--data-dir", type=click.Path(path_type=Path), help="Folder holding DaISy files.")
@click.option("--ts", type=float, help="Sampling period; time stamps in DATA must agree with it "
              "[default: a period stored in DATA, else its time column's median step, else 1].")
@click.option("--options", "options_file", type=click.Path(path_type=Path),
              help="JSON file of identification options (IdentifyOptions.to_dict(), or a saved "
                   "model, whose options are reused); flags given beside it override its fields.")
@click.option("--nmax", type=int, help="Largest order on the greedy path [default: --order, else "
              "max(10, p + 4)].")
@click.option("--order", type=int, help="Fixed order: select the path's model of this order instead "
              "of the order rule.")
@click.option("--validation", "fraction", default=0.3, show_default=True,
              help="Share of the record, at its end, held out for order selection and the report.")
@click.option("--seed", type=int, help="Seed of the randomized filter search [default: 0].")
@click.option("--preset", type=click.Choice(PRESETS),
              help="Search options: default (chosen on the generalization benchmark), fast (the "
                   "default with a shorter refinement, without the orders below the selected one or the "
                   "selected model's optimum: about 0.6 of its time, a little less accurate), "
                   "improved (the earlier default), bounded (no modes slower than a tenth of the "
                   "record) or paper (the published MOLI-ZOFT) [default: default].")
@click.option("--x0", type=click.Choice(X0_CHOICES),
              help="Initial state of the validation simulations [default: zero].")
@click.option("--outliers", type=click.Choice(["warn", "remove"]), default="warn", show_default=True,
              help="Samples far from their neighbours (docs/data.md): warn, or replace them by linear "
                   "interpolation before identifying.")
@click.option("--out", "model_path", type=click.Path(path_type=Path),
              help="Model file to write (JSON) [default: model.json in moli-fit-NAME/, beside report/].")
@click.option("--report", "report_dir", type=click.Path(path_type=Path),
              help="Folder for report.html and the figures [default: moli-fit-NAME/report/ without --out, "
                   "else none].")
@click.option("--all-lists", is_flag=True,
              help=f"Also fit every list of orders with at most {MAX_LISTS_PER_ORDER} lists (report).")
@click.option("--continuous", is_flag=True,
              help="Identify dx/dt = A x + B u directly from the time stamps, regular or not "
                   "(docs/continuous.md).")
@click.option("--input-hold", type=click.Choice(["zoh", "foh"]),
              help="With --continuous: the inputs between samples, held (zoh) or linear (foh) [default: zoh].")
@click.option("--reference", help="Comma-separated columns holding the loops' logged set-points: they "
              "select the two-stage closed-loop method (docs/closed_loop.md).")
@click.option("--closed-loop", type=click.Choice(["open", "two-stage", "direct"]),
              help="A record taken under feedback: identify it as open-loop, by the two-stage method "
                   "(needs --reference) or by the direct prediction-error method [default: two-stage "
                   "with --reference, else direct where an input is a controller's output, else open].")
@click.option("--method", type=click.Choice(METHODS), help="The MOLI path, the realization of a regularized "
              "impulse response (kernel) or the reduction of a regularized ARX model (kernel-arx), order chosen "
              "on validation (docs/regularization.md) [default: moli].")
@click.option("--kernel", type=click.Choice(KERNELS), help="With --method kernel or kernel-arx: the prior "
              "(docs/regularization.md) [default: TC].")
@click.option("--frequency", is_flag=True, help="DATA is a measured frequency response (a CSV of "
              "'<output>/<input> <part>' columns, docs/frequency.md): fit a model to it.")
@click.option("--averages", type=click.IntRange(min=1), help="With --frequency: the spectra averaged per line, "
              "which turns the file's coherence columns into each line's variance (docs/frequency.md §1).")
@_FORCE
@reading_options
def fit(*, data_files: tuple[Path, ...], inputs: str | None, outputs: str | None, daisy: str | None,
        data_dir: Path | None, ts: float | None, options_file: Path | None, nmax: int | None,
        order: int | None, fraction: float, seed: int | None, preset: str | None, x0: str | None,
        outliers: str, model_path: Path | None, report_dir: Path | None, all_lists: bool,
        continuous: bool, input_hold: str | None, reference: str | None, closed_loop: str | None,
        method: str | None, kernel: str | None, frequency: bool, averages: int | None, force: bool,
        **reading: Any) -> None:
    """Identify a model from a data file, several runs of one plant, or a DaISy set.

    DATA is a text table (.csv .tsv .txt), an Excel workbook (.xlsx), Parquet, .npz or
    .mat file (docs/data.md). A table needs a header row with the column names; a
    column named time, t, timestamp, date or datetime gives the sampling period
    (seconds for date-times) unless --ts is given, and must then agree with it.
    Several DATA files (the same columns) are merged as separate experiments; the
    validation part is the tail of the last one.
    """
    if frequency:       # flags read by name there, the time-domain ones refused
        click.get_current_context().exit(fit_frequency(click.get_current_context(), options_from_flags))
    if averages is not None:
        raise OptionError("--averages applies to --frequency (a frequency response's coherence), not to a time "
                          "record; leave it out")
    if bool(data_files) == (daisy is not None):
        raise DataError("give either DATA files or --daisy NAME")
    for flag, named in (("--inputs", inputs), ("--outputs", outputs)):
        shared = [name for name in names(reference) or () if name in (names(named) or ())]
        if shared:
            raise OptionError(f"--reference {','.join(shared)}: also named in {flag}; --reference names the "
                              "logged set-points, columns apart from the plant's inputs and outputs")
    options = options_from_flags(options_file, preset, nmax=nmax, order=order, seed=seed, x0=x0,
                                 time="continuous" if continuous else None, input_hold=input_hold,
                                 reference=names(reference), closed_loop=closed_loop, method=method,
                                 kernel=kernel, runs_kernel=True)
    stems = [daisy] if daisy is not None else [path.stem for path in data_files]
    read = [*data_files, *([options_file] if options_file is not None else [])]
    model_path, report_dir = fit_outputs(model_path, report_dir, run_folder("fit", stems), force, read)
    noted = RunWarnings()
    with Phases() as phases:
        phases.shown_after(f"reading {daisy if daisy is not None else ', '.join(map(str, data_files))}",
                           READING_SHOWN_AFTER)
        if daisy is not None:
            data = load_daisy(daisy, data_dir)
            source, data_files = f"DaISy {daisy}", (daisy_path(daisy, data_dir),)
        else:
            # the references are read as inputs; identify sets them apart
            data = read_records(data_files, [*names(inputs), *names(reference)] if inputs and reference
                                else names(inputs), names(outputs), ts, reading, noted)
            source = ", ".join(map(str, data_files))
    # the plant as identify sees it: the references are read as inputs but are not the plant's
    plant = without_reference(data, options.reference) if options.reference else data
    click.echo(f"{source}: {plant}" + (f", references {list(options.reference)}" if options.reference else "")
               + (f" (the {len(data_files)} files merged)" if len(data_files) > 1 else ""))
    removed = flag_outliers(data).counts if outliers == "remove" else {}
    if removed:
        data = remove_outliers(data)
        click.echo(f"outliers replaced by linear interpolation: {removed}")
    if all_lists and (options.time == "continuous" or options.method in KERNEL_METHODS):
        raise OptionError("--all-lists is for the sampled MOLI search: leave it out with --continuous, "
                          f"--method {options.method}")
    with InterruptHold() as hold:  # from the search's return to the model on disk, Ctrl-C waits
        facts = {"source": source, "outliers_removed": removed}
        if options.time == "continuous":
            code = fit_continuous(data, fraction, options, noted, model_path=model_path, report_dir=report_dir,
                                  data_files=data_files, facts=facts, hold=hold)
        elif options.method in KERNEL_METHODS:
            code = fit_kernel(data, fraction, options, noted, model_path=model_path, report_dir=report_dir,
                              data_files=data_files, facts=facts, hold=hold)
        else:
            result = _identify(data, fraction, options, noted, str(data_files[-1]) if len(data_files) > 1 else None,
                               hold)
            result.model.info["data"].update(source=source, file_sha256=[file_sha256(f) for f in data_files]
                                             if len(data_files) > 1 else file_sha256(data_files[0]),
                                             outliers_removed=removed)
            code = _finish(result, model_path, report_dir, all_lists, noted, hold, data_files=data_files)
    click.get_current_context().exit(code)


@cli.command()
@click.argument("model_file", metavar="MODEL", type=click.Path(path_type=Path))
@click.argument("data_files", metavar="DATA...", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--inputs", help="Input columns [default: the model's input names].")
@click.option("--outputs", help="Output columns [default: the model's output names].")
@click.option("--x0", type=click.Choice(X0_CHOICES), default="zero", show_default=True,
              help="Simulate from the zero state or from a least-squares initial state.")
@click.option("--out", "out_dir", type=click.Path(path_type=Path),
              help="Folder for validation.png [default: moli-validate-NAME/].")
@click.option("--plot", type=click.Path(path_type=Path),
              help="Where to write the measured-against-simulated figure [default: OUT/validation.png].")
@_FORCE
@reading_options
def validate(*, model_file: Path, data_files: tuple[Path, ...], inputs: str | None, outputs: str | None,
             x0: str, out_dir: Path | None, plot: Path | None, force: bool, **reading: Any) -> None:
    """Score MODEL on DATA: VAF and fit per output, and a figure.

    DATA is read with the model's channel names unless --inputs/--outputs name other
    columns, and with the model's sampling period: time stamps or a period stored in
    DATA must agree with it. Several DATA files are scored together, each simulated
    from its own start.
    """
    what = "--plot" if plot else "--out"
    plot = plot or (out_dir or run_folder("validate", [path.stem for path in data_files])) / "validation.png"
    check_output_file(plot, what, [model_file, *data_files])
    check_figure_suffix(plot, what)
    refuse_overwrite([plot], force)
    model = load_model(model_file)
    data = read_records(data_files, names(inputs) or list(model.input_names),
                        names(outputs) or list(model.output_names), model.Ts, reading, RunWarnings())
    comparison = compare(model, data, x0)
    records = f"{len(data_files)} records, " if len(data_files) > 1 else ""
    click.echo(f"{', '.join(map(str, data_files))}: {records}{data.N} samples; simulation from {x0} initial state")
    click.echo(repr(comparison))
    click.echo(SCORES)
    plot.parent.mkdir(parents=True, exist_ok=True)
    save_figure(measured_vs_simulated(data, comparison), plot)
    click.echo(f"figure written to {plot}")


@cli.command()
@click.argument("model_file", metavar="MODEL", type=click.Path(path_type=Path))
def info(model_file: Path) -> None:
    """Print structure, poles, stability, Ts and names of MODEL."""
    click.echo(describe(load_model(model_file)))


for _command in fleet_commands(options_from_flags):  # fit-many, validate-many
    cli.add_command(_command)


def main() -> None:
    """Run the ``moli`` command on ``sys.argv`` (the console script, :func:`moli.app.console.main`,
    calls it once the libraries are loaded)."""
    cli(prog_name="moli")


if __name__ == "__main__":
    main()
