"""Loaders for the DaISy benchmark data sets (KU Leuven, ESAT/STADIUS).

``load_daisy(name)`` returns an :class:`~moli.data.IOData` with the inputs and outputs
of one DaISy file: time stamps and sample counters are dropped, channels are named, and
``Ts`` is the sampling period the DaISy description states. Where the description leaves
the period blank, ``Ts = 1.0`` (one sample) and :func:`list_daisy` reports
``Ts_stated=False``; no period has been guessed.

Files are looked up, in this order, in ``data_dir``, in the directory named by the
environment variable ``MOLI_DATA_DIR`` and in the cache directory ``<cache>/daisy``, where
``<cache>`` is ``$MOLI_CACHE_DIR``, else ``$XDG_CACHE_HOME/moli``, else ``~/.cache/moli``.
A file found nowhere is downloaded once from the DaISy server (``NAME.dat.gz``) into the
cache, checked against its known SHA-256 sum (or, for the three sets without one, against
its known shape) and read from there afterwards.

Please cite DaISy when you publish results on these data: De Moor B.L.R. (ed.), *DaISy:
Database for the Identification of Systems*, Department of Electrical Engineering,
ESAT/STADIUS, KU Leuven, Belgium, https://homes.esat.kuleuven.be/~smc/daisy/.
"""

from __future__ import annotations

import gzip
import hashlib
import io
import os
import urllib.request
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import IO

import numpy as np

from .atomic_files import write_atomic
from .daisy_catalog import DESTILL_NOISE_LEVELS, DISTILL2_STEPS, SPECS, DaisySpec
from .iodata import IOData
from ..errors import DataError, MoliError, OptionError

__all__ = [
    "DatasetUnavailableError", "DatasetChecksumError", "DaisyInfo", "daisy_url", "list_daisy",
    "cache_dir", "daisy_path", "load_daisy",
]

DAISY_BASE_URL = "https://ftp.esat.kuleuven.be/pub/SISTA/data"
"""Server folder that holds ``<folder>/NAME.dat.gz`` for every DaISy set."""

DOWNLOAD_TIMEOUT = 30.0
"""Seconds to wait for the DaISy server before giving up."""



class DatasetUnavailableError(MoliError):
    """A DaISy file is in none of the searched directories and cannot be downloaded."""


class DatasetChecksumError(MoliError):
    """A downloaded DaISy file differs from the one this library knows."""


@dataclass(frozen=True)
class DaisyInfo:
    """What the library knows about one DaISy data set.

    Attributes
    ----------
    name : str
        File name without ``.dat``.
    p, m : int
        Number of outputs and inputs returned by :func:`load_daisy`.
    N : int
        Number of samples.
    Ts : float
        Sampling period in ``Ts_unit``; 1.0 when DaISy does not state it.
    Ts_unit : str
        ``"s"``, ``"min"``, or ``"sample"`` when the period is not stated.
    Ts_stated : bool
        False when DaISy gives no sampling period (then ``Ts = 1.0``).
    description : str
        One line on the process.
    url : str
        Download address of ``NAME.dat.gz``.
    sha256 : str or None
        SHA-256 of the uncompressed file, when known.
    """

    name: str
    p: int
    m: int
    N: int
    Ts: float
    Ts_unit: str
    Ts_stated: bool
    description: str
    url: str
    sha256: str | None


def _spec(name: str) -> DaisySpec:
    try:
        return SPECS[name]
    except KeyError:
        raise OptionError(
            f"unknown DaISy data set {name!r}; known: {', '.join(sorted(SPECS, key=str.lower))}"
        ) from None


def daisy_url(name: str) -> str:
    """Download address of ``NAME.dat.gz`` on the DaISy server.

    Examples
    --------
    >>> daisy_url("evaporator")
    'https://ftp.esat.kuleuven.be/pub/SISTA/data/process_industry/evaporator.dat.gz'
    """
    return f"{DAISY_BASE_URL}/{_spec(name).folder}/{name}.dat.gz"


def list_daisy() -> list[DaisyInfo]:
    """Every DaISy data set :func:`load_daisy` knows.

    For ``destill`` the numbers are those of one noise level, for ``distill2`` those of
    one step response (see :func:`load_daisy`).

    Returns
    -------
    list of DaisyInfo

    Examples
    --------
    >>> info = {d.name: d for d in list_daisy()}
    >>> info["evaporator"].p, info["evaporator"].m, info["evaporator"].N
    (3, 3, 6305)
    >>> info["evaporator"].Ts, info["evaporator"].Ts_stated
    (1.0, False)
    """
    result = []
    for name, spec in SPECS.items():
        stated = spec.Ts is not None
        result.append(DaisyInfo(
            name=name, p=len(spec.outputs), m=len(spec.inputs), N=spec.shape[0],
            Ts=spec.Ts if stated else 1.0, Ts_unit=spec.Ts_unit if stated else "sample",
            Ts_stated=stated, description=spec.description, url=daisy_url(name),
            sha256=spec.sha256,
        ))
    return result


def cache_dir() -> Path:
    """Directory where downloaded DaISy files are kept.

    ``$MOLI_CACHE_DIR/daisy``, else ``$XDG_CACHE_HOME/moli/daisy``, else
    ``~/.cache/moli/daisy``. The directory is created only when a file is downloaded.
    """
    root = os.environ.get("MOLI_CACHE_DIR")
    if not root:
        xdg = os.environ.get("XDG_CACHE_HOME")
        root = str(Path(xdg) / "moli") if xdg else str(Path.home() / ".cache" / "moli")
    return Path(root).expanduser() / "daisy"


def _search_dirs(data_dir: str | os.PathLike[str] | None) -> list[Path]:
    dirs = [Path(data_dir).expanduser()] if data_dir is not None else []
    env = os.environ.get("MOLI_DATA_DIR")
    if env:
        dirs.append(Path(env).expanduser())
    dirs.append(cache_dir())
    return dirs


def _open_url(url: str, timeout: float) -> IO[bytes]:
    """Open ``url`` for reading; a separate function so tests can replace it."""
    return urllib.request.urlopen(url, timeout=timeout)  # noqa: S310 (fixed https address)


def _download(name: str, spec: DaisySpec, searched: list[Path]) -> Path:
    url = daisy_url(name)
    where = ", ".join(str(d) for d in searched)
    try:
        with _open_url(url, DOWNLOAD_TIMEOUT) as response:
            payload = gzip.decompress(response.read())
    except (OSError, EOFError, zlib.error) as exc:  # URLError and timeouts are OSError
        raise DatasetUnavailableError(
            f"DaISy file {name}.dat is not in any of [{where}] and downloading {url} failed "
            f"({exc}). Download it by hand, gunzip it, and put {name}.dat in a directory "
            "passed as data_dir or named by the MOLI_DATA_DIR environment variable."
        ) from exc
    if spec.sha256 is not None:
        digest = hashlib.sha256(payload).hexdigest()
        if digest != spec.sha256:
            raise DatasetChecksumError(
                f"{url} unpacks to a file with SHA-256 {digest}, expected {spec.sha256}; "
                "it was not kept. The server copy may have changed: check it, then put a "
                f"trusted {name}.dat in data_dir or MOLI_DATA_DIR."
            )
    # Sets without a published checksum are at least checked for shape, before caching.
    _parse(io.BytesIO(payload), url, spec)
    target = cache_dir()
    final = target / f"{name}.dat"
    try:
        target.mkdir(parents=True, exist_ok=True)
        # whole or not at all: an interrupted download never leaves a truncated
        # NAME.dat that later calls would trust
        write_atomic(final, payload)
    except OSError as exc:
        raise DatasetUnavailableError(
            f"downloaded {url} but cannot write to the cache {target} ({exc}); "
            "set MOLI_CACHE_DIR to a writable folder"
        ) from exc
    return final


def daisy_path(name: str, data_dir: str | os.PathLike[str] | None = None) -> Path:
    """Local path of ``NAME.dat``, downloading it into the cache when needed.

    Parameters
    ----------
    name : str
        Data set name, as listed by :func:`list_daisy`.
    data_dir : path, optional
        Directory searched first.

    Returns
    -------
    Path

    Raises
    ------
    DatasetUnavailableError
        The file is nowhere locally and the download failed.
    DatasetChecksumError
        The downloaded file has the wrong SHA-256 sum.
    """
    spec = _spec(name)
    searched = _search_dirs(data_dir)
    for directory in searched:
        candidate = directory / f"{name}.dat"
        if candidate.is_file():
            return candidate
    return _download(name, spec, searched)


def _parse(source: Path | IO[bytes], label: object, spec: DaisySpec) -> np.ndarray:
    try:
        table = np.loadtxt(source, ndmin=2)
    except ValueError as exc:
        raise DataError(f"{label} is not a whitespace-separated table of numbers: {exc}") from None
    if table.shape != spec.shape:
        raise DataError(
            f"{label} has shape {table.shape}, expected {spec.shape} for this DaISy set; "
            "the file is truncated or is not the DaISy file of that name"
        )
    return table


def _check_choice(value: int | None, name: str, option: str, choices: tuple[int, ...]) -> None:
    if value not in choices:
        raise OptionError(f"{name} needs {option} in {choices}, got {value!r}")


def load_daisy(
    name: str,
    data_dir: str | os.PathLike[str] | None = None,
    *,
    noise: int | None = None,
    step: int | None = None,
) -> IOData:
    """Load one DaISy data set as input-output data.

    Parameters
    ----------
    name : str
        Data set name, e.g. ``"evaporator"``; :func:`list_daisy` lists them all.
    data_dir : path, optional
        Directory searched for ``NAME.dat`` before ``$MOLI_DATA_DIR`` and the cache.
    noise : {0, 10, 20, 30}, optional
        ``destill`` only (default 0): percentage of white noise added to inputs and
        outputs. The file holds the same simulated experiment at the four levels.
    step : {1, 2, 3}, optional
        ``distill2`` only, required: which input received the unit step. That file
        holds three step responses, not an input-output record.

    Returns
    -------
    IOData
        Signals exactly as in the file (no scaling, no detrending), with the
        time or counter column dropped. ``Ts`` is in the unit given by
        :func:`list_daisy` (``cstr`` and ``destill`` in minutes, others in
        seconds), or 1.0 when DaISy states no period.

    Raises
    ------
    OptionError
        Unknown name, or ``noise``/``step`` missing, invalid or given for a set that
        has no such choice.
    DataError
        The file found has another shape than the DaISy file.
    DatasetUnavailableError, DatasetChecksumError
        See :func:`daisy_path`.

    Notes
    -----
    * ``distill2``: the inputs are not in the file. ``u`` is the unit step (1.0 from
      sample 0 on) on input ``step`` and 0 on the others; ``y`` holds absolute output
      levels, which do not start at zero; subtract ``y[0]`` for the deviation response.
    * ``powerplant``: the three unexplained "Yr" columns are not returned.
    * ``evaporator`` and ``winding`` have no time column: every column is a signal.

    Examples
    --------
    >>> d = load_daisy("evaporator")  # doctest: +SKIP
    >>> d  # doctest: +SKIP
    IOData(N=6305, p=3, m=3, Ts=1, outputs=['dry matter content', 'product flow', ...
    """
    spec = _spec(name)
    if noise is not None and name != "destill":
        raise OptionError(f"noise applies only to 'destill', not to {name!r}")
    if step is not None and name != "distill2":
        raise OptionError(f"step applies only to 'distill2', not to {name!r}")
    if name == "destill":
        noise = 0 if noise is None else noise
        _check_choice(noise, name, "noise", DESTILL_NOISE_LEVELS)
    if name == "distill2":
        _check_choice(step, name, "step", DISTILL2_STEPS)
    path = daisy_path(name, data_dir)
    table = _parse(path, path, spec)
    Ts = spec.Ts if spec.Ts is not None else 1.0
    if name == "destill":
        level = DESTILL_NOISE_LEVELS.index(noise)
        u = table[:, [c + 5 * level for c in spec.u_cols]]
        y = table[:, [c + 3 * level for c in spec.y_cols]]
    elif name == "distill2":
        assert step is not None  # checked above; narrows the type
        first = 1 + 2 * (step - 1)
        y = table[:, first:first + 2]
        u = np.zeros((table.shape[0], 3))
        u[:, step - 1] = 1.0
    else:
        u = table[:, list(spec.u_cols)]
        y = table[:, list(spec.y_cols)]
    return IOData(y, u, Ts=Ts, output_names=spec.outputs, input_names=spec.inputs)
