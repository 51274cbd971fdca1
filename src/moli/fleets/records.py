"""Identify a fleet: many records, each on its own, in parallel.

:func:`identify_many` runs :func:`~moli.method.identification.identify` on every record
of a fleet (one record per loop, unit or test run) on local processes, on a Dask
cluster or on any ``concurrent.futures`` executor (:mod:`moli.fleets.backends`). One
record's failure is kept under its name and never stops the others. Nothing random
is shared: each identification is a deterministic function of its record and its
options (``IdentifyOptions.seed`` seeds the randomized filter search), and each runs
with one BLAS thread, so the results are the same bit for bit whatever the backend
and the number of workers.
"""

from __future__ import annotations

import contextlib
import inspect
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterator, Mapping, Sequence, Union

import numpy as np

from ..data.files import read_data
from ..data.iodata import IOData
from ..errors import DataError, OptionError
from ..method.continuous import ContinuousResult
from ..method.identification import IdentificationResult, identify
from ..method.options import IdentifyOptions
from ..models.continuous import ContinuousModel
from .warning_capture import thread_warnings
from ..models.statespace import StateSpaceModel
from ..numerics.blas_threads import blas_thread_limit, limited_blas
from ..validation.comparison import compare
from .backends import NO_WORKER_TIMEOUT, RecordTimeoutError, run_calls
from .record_paths import absolute_paths, as_given

__all__ = ["FleetEntry", "FleetResult", "identify_many"]

if TYPE_CHECKING:  # pandas is optional
    import pandas as pd

Record = Union[IOData, str, "os.PathLike[str]"]
Item = Union[Record, tuple[Record, Record]]
RECORD_TYPES = (IOData, str, os.PathLike)
COLUMNS = ("name", "order", "fit", "vaf", "seconds", "error")


@dataclass
class FleetEntry:
    """What :func:`identify_many` found for one record.

    Attributes
    ----------
    name : str
        The record's name (its key, its file's stem, or ``record-<position>``).
    result : IdentificationResult or ContinuousResult or None
        The identification (a ContinuousResult with ``time="continuous"``); None when it failed.
    error : str or None
        Why it failed (exception type and message); None when it succeeded.
    seconds : float
        Wall time on the worker, reading the files included.
    warnings : tuple of str
        The distinct warnings raised while identifying it.
    fit : float or None
        Mean over the outputs of the selected model's NRMSE fit on the validation
        record, percent (simulation from the initial state of ``options.x0``).
    timed_out : bool
        True when the record ran longer than ``identify_many``'s ``timeout`` and was
        ended (``error`` then says so).
    """

    name: str
    result: IdentificationResult | ContinuousResult | None
    error: str | None
    seconds: float
    warnings: tuple[str, ...] = ()
    fit: float | None = None
    timed_out: bool = False

    @property
    def ok(self) -> bool:
        """True when the record was identified."""
        return self.error is None

    def row(self) -> dict[str, Any]:
        """name, order, fit, vaf (mean validation VAF), seconds, error; None where absent."""
        selected = None if self.result is None else self.result.selected
        return {
            "name": self.name, "order": None if selected is None else selected.order,
            "fit": self.fit, "vaf": None if selected is None else selected.mean_vaf,
            "seconds": self.seconds, "error": self.error,
        }


@dataclass
class FleetResult:
    """Every record's :class:`FleetEntry`, in the order the records were given.

    Index it by position or by name; iterate over the entries.

    Attributes
    ----------
    entries : list of FleetEntry
    backend : str
        Where it ran, e.g. ``"2 processes"`` or ``"dask, tcp://10.0.0.5:8786"``.
    seconds : float
        Wall time of the whole fleet.

    Examples
    --------
    >>> import moli
    >>> fleet = moli.identify_many([moli.example_data(N=300, seed=1), moli.IOData([0.0] * 5, [1.0] * 5)],
    ...                            moli.IdentifyOptions(nmax=3), n_jobs=1, progress=False)
    >>> [entry.name for entry in fleet], len(fleet.failures), fleet.backend
    (['record-0', 'record-1'], 1, 'this process')
    >>> row = fleet.rows()[0]
    >>> sorted(row), row["order"]
    (['error', 'fit', 'name', 'order', 'seconds', 'vaf'], 3)
    """

    entries: list[FleetEntry]
    backend: str
    seconds: float
    _by_name: dict[str, FleetEntry] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._by_name = {entry.name: entry for entry in self.entries}

    def __len__(self) -> int:
        return len(self.entries)

    def __iter__(self) -> Iterator[FleetEntry]:
        return iter(self.entries)

    def __getitem__(self, key: int | str) -> FleetEntry:
        if isinstance(key, str):
            if key not in self._by_name:
                raise KeyError(f"no record named {key!r} in the fleet")
            return self._by_name[key]
        return self.entries[key]

    @property
    def failures(self) -> list[FleetEntry]:
        """The entries whose identification failed."""
        return [entry for entry in self.entries if not entry.ok]

    def models(self) -> dict[str, StateSpaceModel | ContinuousModel]:
        """The selected model of every identified record, by name."""
        return {e.name: e.result.model for e in self.entries if e.result is not None}

    def rows(self) -> list[dict[str, Any]]:
        """One dict per record, in order: see :meth:`FleetEntry.row`."""
        return [entry.row() for entry in self.entries]

    def to_dataframe(self) -> "pd.DataFrame":
        """One row per record: name, order, fit, vaf, seconds, error (needs pandas).

        ``fit`` is the mean validation NRMSE fit and ``vaf`` the mean validation VAF
        of the selected model, both percent; a failed record has NaN there and its
        message under ``error``.
        """
        import pandas as pd

        frame = pd.DataFrame(self.rows(), columns=list(COLUMNS))
        return frame.astype({"order": "Int64", "fit": float, "vaf": float})


def identify_many(
    datasets: Sequence[Item] | Mapping[str, Item],
    options: IdentifyOptions | None = None,
    *,
    executor: Any = None,
    n_jobs: int | None = None,
    read_options: Mapping[str, Any] | None = None,
    progress: bool | Callable[[FleetEntry], None] = True,
    no_worker_timeout: float = NO_WORKER_TIMEOUT,
    timeout: float | None = None,
    on_entry: Callable[[FleetEntry], None] | None = None,
) -> FleetResult:
    """Identify every record of a fleet, in parallel; one failure stops nothing.

    Parameters
    ----------
    datasets : sequence or mapping of records
        Each item is an :class:`IOData`, a file path (read on the worker with
        ``moli.read_data(path, **read_options)``), or an ``(estimation, validation)``
        pair of those. A mapping names its items; otherwise a file is named by its
        stem and an in-memory record ``record-<position>``. Names must be distinct.
    options : IdentifyOptions, optional
        The options of every identification (``identify``'s default when None).
        A record without validation data holds out its last 30 %, as ``identify`` does.
    executor : optional
        Where to run: None for local processes (started and watched by moli: they end
        when this process ends, however it ends); a ``dask.distributed.Client`` (any cluster Dask
        reaches: a ``LocalCluster``, Kubernetes, SLURM...); a
        ``concurrent.futures.Executor``; or the name of a joblib backend such as
        ``"loky"``, ``"threading"`` or ``"ray"`` (needs ``ray``).
    n_jobs : int, optional
        Local worker processes (or joblib workers); default: the usable CPUs. 1 runs
        in this process (in one worker process when ``timeout`` is set). Not used
        with a Client or an Executor, which bring their own.
    read_options : mapping, optional
        Keywords of :func:`moli.read_data` for the file items (``inputs``,
        ``outputs``, ``Ts``).
    progress : bool or callable, default True
        True shows a bar on stderr (when ``tqdm`` is installed); a callable is called
        with each :class:`FleetEntry` as it completes.
    no_worker_timeout : float, default 60
        Seconds a Dask cluster may have no worker at all; then the records still
        pending fail with that reason (Dask itself would wait forever).
    timeout : float, optional
        Seconds one record may take on its worker (reading included); a record over
        it is ended with its worker process and listed as failed, ``timed_out``
        True. Needs local processes (``executor=None``).
    on_entry : callable, optional
        Called in this process with each :class:`FleetEntry` as it completes, before
        the next is taken (to save each result as it comes, say); an exception it
        raises ends the run, the workers with it.

    Returns
    -------
    FleetResult
        The entries in the order of ``datasets``.

    Raises
    ------
    DataError
        ``datasets`` or one of its items is not of a kind listed above, or two
        items share a name (before any work).
    OptionError
        Invalid ``options``, ``executor``, ``n_jobs``, ``read_options``,
        ``progress``, ``timeout`` or ``on_entry`` (before any work).

    Examples
    --------
    >>> import moli
    >>> fleet = {f"loop{k}": moli.example_data(N=400, seed=k) for k in range(3)}
    >>> fleet["broken"] = moli.IOData([[0.0]] * 5, [[1.0]] * 5)
    >>> result = moli.identify_many(fleet, moli.IdentifyOptions(nmax=4), n_jobs=1, progress=False)
    >>> [entry.ok for entry in result]
    [True, True, True, False]
    >>> result["broken"].error.split(":")[0]
    'DataError'
    >>> result["loop0"].result.selected.order <= 4
    True
    """
    items = _items(datasets)
    if options is not None and not isinstance(options, IdentifyOptions):
        raise OptionError(f"options must be an IdentifyOptions, got {type(options).__name__}")
    reading = _read_options(read_options)
    if not (isinstance(progress, bool) or callable(progress)):
        raise OptionError(f"progress must be True, False or a callable, got {progress!r}")
    if on_entry is not None and not callable(on_entry):
        raise OptionError(f"on_entry must be a callable or None, got {on_entry!r}")
    given = {name: item for name, item in items}
    if executor is None or isinstance(executor, str):
        # a joblib backend's workers live on from call to call, in the folder they started in
        items = [(name, absolute_paths(item)) for name, item in items]
    calls = [(name, item, options or IdentifyOptions(), reading) for name, item in items]
    entries: dict[int, FleetEntry] = {}
    start = time.perf_counter()
    if isinstance(no_worker_timeout, bool) or not isinstance(no_worker_timeout, (int, float)) \
            or not no_worker_timeout > 0:
        raise OptionError(f"no_worker_timeout must be a positive number of seconds, got {no_worker_timeout!r}")
    blas_thread_limit()     # a bad MOLI_BLAS_THREADS refused here, not as every record's error on process workers
    with run_calls(_identify_one, calls, executor, n_jobs, no_worker_timeout, timeout) as (backend, done), \
            _reporting(progress, len(calls)) as tell:
        for index, entry, lost in done:
            name, item = items[index]
            if lost is not None:  # the backend could not return it (a worker died, it ran too long)
                timed_out = isinstance(lost, RecordTimeoutError)
                entry = FleetEntry(name, None, f"{type(lost).__name__}: {lost}",
                                   float(timeout or 0.0) if timed_out else 0.0, timed_out=timed_out)
            entry.warnings = tuple(dict.fromkeys(as_given(message, item, given[name])
                                                 for message in entry.warnings))
            entry.error = None if entry.error is None else as_given(entry.error, item, given[name])
            entries[index] = entry
            tell(entry)
            if on_entry is not None:
                on_entry(entry)
    return FleetResult([entries[i] for i in range(len(calls))], backend, time.perf_counter() - start)


def _name_of(item: Item, position: int) -> str:
    first = item[0] if isinstance(item, tuple) else item
    return f"record-{position}" if isinstance(first, IOData) else Path(first).stem


def _is_item(item: Any) -> bool:
    if isinstance(item, tuple):
        return len(item) == 2 and all(isinstance(part, RECORD_TYPES) for part in item)
    return isinstance(item, RECORD_TYPES)


def _items(datasets: Any) -> list[tuple[str, Item]]:
    """(name, item) pairs, each item checked for its kind, names distinct."""
    if isinstance(datasets, Mapping):
        named: list[tuple[str | None, Any]] = [(str(key), item) for key, item in datasets.items()]
    elif isinstance(datasets, Sequence) and not isinstance(datasets, (str, bytes)):
        named = [(None, item) for item in datasets]
    else:
        raise DataError("datasets must be a list or a mapping of records (IOData, file paths or "
                        f"(estimation, validation) pairs), got {type(datasets).__name__}")
    if not named:
        raise DataError("datasets is empty: give at least one record")
    checked: list[tuple[str, Item]] = []
    seen: dict[str, int] = {}
    for position, (key, item) in enumerate(named):
        if not _is_item(item):
            raise DataError(f"datasets[{key or position!r}] must be an IOData, a file path or an "
                            f"(estimation, validation) pair of those, got {type(item).__name__}")
        name = key or _name_of(item, position)
        if name in seen:
            raise DataError(f"datasets: records {seen[name]} and {position} are both named {name!r}; "
                            "pass a mapping of distinct names to records")
        seen[name] = position
        checked.append((name, item))
    return checked


def _read_options(read_options: Mapping[str, Any] | None) -> dict[str, Any]:
    if read_options is None:
        return {}
    if not isinstance(read_options, Mapping):
        raise OptionError(f"read_options must be a mapping of read_data keywords, got {type(read_options).__name__}")
    try:
        inspect.signature(read_data).bind("record", **read_options)
    except TypeError as exc:
        raise OptionError(f"read_options: {exc} (moli.read_data{inspect.signature(read_data)})") from None
    return dict(read_options)


@contextlib.contextmanager
def _reporting(progress: bool | Callable[[FleetEntry], None], total: int) -> Iterator[Callable[[FleetEntry], None]]:
    """The callback told of each finished entry: the caller's, a bar on stderr, or nothing."""
    if callable(progress):
        yield progress
        return
    try:
        from tqdm import tqdm
    except ImportError:  # the bar is a convenience of the cli extra
        progress = False
    if not progress:
        yield lambda entry: None
        return
    with tqdm(total=total, desc="fleet", unit="record", file=sys.stderr) as shown:
        failed = 0

        def tell(entry: FleetEntry) -> None:
            nonlocal failed
            failed += not entry.ok
            shown.set_postfix_str(f"{failed} failed", refresh=False)
            shown.update()

        yield tell


def _load(record: Record, read_options: dict[str, Any]) -> IOData:
    return record if isinstance(record, IOData) else read_data(record, **read_options)


def _identify_one(name: str, item: Item, options: IdentifyOptions,
                  read_options: dict[str, Any]) -> FleetEntry:
    """One record, on a worker: read, identify, score; any failure becomes the entry's error."""
    start = time.perf_counter()
    result, fit, error = None, None, None
    with thread_warnings() as caught, limited_blas():  # kept apart on thread backends too
        try:
            if isinstance(item, tuple):
                estimation, validation = (_load(part, read_options) for part in item)
            else:
                estimation, validation = _load(item, read_options), None
            result = identify(estimation, validation, options)
            fit = float(np.mean(compare(result.model, result.validation, options.x0).fit))
        except Exception as exc:  # a bad record is reported under its name; the fleet goes on
            result, error = None, f"{type(exc).__name__}: {exc}"
    messages = tuple(dict.fromkeys(str(w.message) for w in caught))
    return FleetEntry(name, result, error, time.perf_counter() - start, messages, fit)
