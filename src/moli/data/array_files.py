"""Files of named arrays: NumPy ``.npz`` archives and MATLAB ``.mat`` files.

Each 1-D variable (or MATLAB column or row vector) is a column named after the
variable. 2-D arrays ``u`` and ``y`` (time along axis 0) become columns ``u1, u2, ...``
and ``y1, y2, ...`` and are the default channels. A scalar ``Ts`` is the sampling
period. A MATLAB iddata saved as a struct (``s = get(data)`` or ``struct(data)``, then
``save``) gives its channels under their ``InputName``/``OutputName`` and its ``Ts``.

Only the arrays a request needs are inflated, chosen from the shapes the file states
before any data (the ``.npy`` headers of an archive, MATLAB's variable headers): a
compressed file's other arrays, however large they inflate, cost nothing.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from .cells import parsing
from .clocks import looks_like_time, period_kind
from .tables import LISTED_COLUMNS, Table
from ..errors import DataError

__all__ = ["read_npz", "read_mat"]

IDDATA_FIELDS = {"OutputData", "InputData"}
# The arrays that mark the channels and the period when a request names no channels.
MARKED = ("u", "y")
Needed = Callable[[list[str]], "set[str] | None"]


def _sample(index: int) -> str:
    return f"sample {index}"


def _stored_period(value: object, where: str) -> float | None:
    """A stored sampling period: None when absent or empty, else a positive float."""
    if value is None or np.size(value) == 0:
        return None
    array = np.asarray(value)
    if array.size != 1 or array.dtype.kind not in "iuf" or not (np.isfinite(array) & (array > 0)).all():
        raise DataError(f"{where} must be a positive number, got {value!r}")
    return float(array.ravel()[0])


def array_table(arrays: dict[str, object], source: str, stored: Sequence[str] = ()) -> Table:
    """Columns of named arrays: vectors by name, ``u``/``y`` matrices split into channels.

    ``stored`` names every array of the file, read or not, for messages.
    """
    arrays = dict(arrays)
    Ts = _stored_period(arrays.pop("Ts", None), f"the Ts stored in {source}")
    columns: dict[str, np.ndarray] = {}
    marked: dict[str, tuple[str, ...]] = {}
    for name, value in arrays.items():
        array = np.asarray(value)
        if array.ndim == 2 and 1 in array.shape:
            array = array.ravel()  # MATLAB stores vectors as (N, 1) or (1, N)
        if name in ("u", "y") and array.ndim in (1, 2):
            if 0 in array.shape:
                raise DataError(f"{source}: {name} has shape {array.shape}; it needs at least one "
                                "sample (row) and one channel (column)")
            matrix = array.reshape(len(array), -1)
            marked[name] = tuple(f"{name}{k + 1}" for k in range(matrix.shape[1]))
            columns.update(zip(marked[name], matrix.T))
        elif array.ndim == 1:
            columns[name] = array
    if set(marked) == {"u", "y"} and len(columns[marked["u"][0]]) != len(columns[marked["y"][0]]):
        raise DataError(
            f"{source}: u has {len(columns[marked['u'][0]])} rows and y "
            f"{len(columns[marked['y'][0]])}; time runs along axis 0 (one row per sample)"
        )
    both = set(marked) == {"u", "y"}
    unread = tuple(name for name in stored if name not in arrays and name != "Ts")
    return Table(columns, source, _sample, Ts,
                 marked["u"] if both else None, marked["y"] if both else None,
                 names=(tuple(columns) + unread) if unread else ())


def _rows(shape: tuple[int, ...]) -> int:
    """Samples of an array of ``shape`` as :func:`array_table` reads it (vectors either way)."""
    if len(shape) == 2 and 1 in shape:
        return max(shape)
    return shape[0] if shape else 1


def _wanted(stored: list[str], shape: Callable[[str], tuple[int, ...]], needed: Needed,
            source: str) -> list[str]:
    """The stored arrays a request reads, decided from the shapes the file states.

    With channels named: those columns, ``u``/``y`` for their channels ``u1, y2, ...``,
    and ``Ts``. With none named: ``u``, ``y``, ``Ts``, and the arrays that may give the
    period (named like time or a period, ``moli.data.clocks``) holding no more values
    than ``u`` has samples; ``u`` and ``y`` must agree in samples before either is read.
    ``shape(name)`` is asked only of these arrays.
    """
    if "Ts" in stored and int(np.prod(shape("Ts"))) > 1:
        raise DataError(f"the Ts stored in {source} must be one positive number, got an array of "
                        f"shape {shape('Ts')}")
    kept = needed(stored)
    if kept is not None:
        matrices = {name for name in MARKED for column in kept if re.fullmatch(rf"{name}\d+", column)}
        return [name for name in stored if name in kept or name in matrices or name == "Ts"]
    if not set(MARKED) <= set(stored):
        return [name for name in stored if name == "Ts"]
    samples = {name: _rows(shape(name)) for name in MARKED}
    if samples["u"] != samples["y"]:
        raise DataError(f"{source}: u has {samples['u']} rows and y {samples['y']}; time runs "
                        "along axis 0 (one row per sample)")
    clocks = {name for name in stored if name not in (*MARKED, "Ts")
              and (looks_like_time(name) or period_kind(name) is not None)
              and int(np.prod(shape(name))) <= samples["u"]}
    return [name for name in stored if name in (*MARKED, "Ts") or name in clocks]


def _columns(shapes: dict[str, tuple[int, ...]]) -> set[str]:
    """The columns that arrays of these shapes give: their names, and ``u1, u2, ...`` of ``u``/``y``."""
    split = {f"{name}{k + 1}" for name in MARKED if name in shapes
             for k in range(int(np.prod(shapes[name])) // max(_rows(shapes[name]), 1))}
    return set(shapes) | split


def _unmarked(path: Path, stored: list[str]) -> DataError:
    """The error for a file without ``u``/``y`` (or iddata) read with no channels named."""
    shown = ", ".join(map(repr, stored[:LISTED_COLUMNS]))
    more = f" and {len(stored) - LISTED_COLUMNS} more" if len(stored) > LISTED_COLUMNS else ""
    return DataError(f"name the input and output columns of {path} (inputs=, outputs=; --inputs, "
                     f"--outputs), or store them as 2-D arrays u and y, one row per sample; "
                     f"columns: {shown}{more}")


def _npz_shape(archive: object, name: str) -> tuple[int, ...]:
    """The shape an archive's array states in its ``.npy`` header: its data stay compressed."""
    with archive.zip.open(f"{name}.npy") as member:  # type: ignore[attr-defined]
        version = np.lib.format.read_magic(member)
        header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        return tuple(header(member)[0])


def read_npz(path: Path, needed: Needed) -> Table:
    """The arrays of a NumPy ``.npz`` archive (no pickled objects).

    Only the arrays ``needed`` asks for are inflated (see :func:`_wanted`): an
    archive's other members, however large, are never read.
    """
    with parsing(path, "a NumPy .npz archive"):
        loaded = np.load(path, allow_pickle=False)
        if not hasattr(loaded, "files"):
            raise DataError(f"{path} holds a single array (.npy), not an .npz archive of named "
                            "arrays; save it with numpy.savez(path, u=..., y=...)")
        with loaded as archive:
            stored = list(archive.files)
            other = next((name for name in archive.zip.namelist() if not name.endswith(".npy")), None)
            if other is not None:
                raise DataError(f"{path} is a zip archive but not a NumPy .npz: its member {other!r} "
                                "is not an array")
            if not stored:
                raise DataError(f"{path} holds no arrays")
            if needed(stored) is None and not set(MARKED) <= set(stored):
                raise _unmarked(path, stored)
            wanted = _wanted(stored, lambda name: _npz_shape(archive, name), needed, str(path))
            arrays = {name: archive[name] for name in wanted}
    return array_table(arrays, str(path), stored)


def _matrix(value: object, what: str) -> np.ndarray:
    """A MATLAB data matrix as floats of shape (N, channels)."""
    array = np.asarray(value)
    if array.dtype == object:
        raise DataError(f"{what} is a cell array of {array.size} experiments; moli reads one: "
                        "save each experiment (getexp) in its own file")
    if array.dtype.kind not in "biuf" or array.size == 0:
        raise DataError(f"{what} must be a non-empty numeric matrix, got {array.dtype} of shape {array.shape}")
    array = np.atleast_1d(array).astype(float)
    return array.reshape(len(array), -1)


def _channel_names(value: object, count: int, prefix: str) -> tuple[str, ...]:
    """Names from an iddata's cell of names; ``prefix1, ...`` when absent or blank."""
    names = tuple(str(name).strip() for name in np.atleast_1d(np.asarray(value, dtype=object))) \
        if value is not None else ()
    if len(names) != count or not all(names) or len(set(names)) != count:
        return tuple(f"{prefix}{k + 1}" for k in range(count))
    return names


def iddata_table(name: str, struct: object, source: str) -> Table:
    """The channels, names and period of an iddata saved as a MATLAB struct."""
    where = f"{source} ({name})"
    y = _matrix(getattr(struct, "OutputData"), f"{where}.OutputData")
    u = _matrix(getattr(struct, "InputData"), f"{where}.InputData")
    outputs = _channel_names(getattr(struct, "OutputName", None), y.shape[1], "y")
    inputs = _channel_names(getattr(struct, "InputName", None), u.shape[1], "u")
    if set(outputs) & set(inputs):
        outputs = tuple(f"y{k + 1}" for k in range(y.shape[1]))
        inputs = tuple(f"u{k + 1}" for k in range(u.shape[1]))
    columns = {**dict(zip(outputs, y.T)), **dict(zip(inputs, u.T))}
    Ts = _stored_period(getattr(struct, "Ts", None), f"{where}.Ts")
    instants = getattr(struct, "SamplingInstants", None)
    if Ts is None and instants is not None and "time" not in columns:
        columns["time"] = np.asarray(instants, dtype=float).ravel()  # non-uniform iddata: the time axis
    return Table(columns, source, _sample, Ts, inputs, outputs)


def read_mat(path: Path, needed: Needed) -> Table:
    """The variables of a MATLAB ``.mat`` file (v4 to v7), or the iddata struct it holds.

    Only the variables ``needed`` asks for (see :func:`_wanted`) are read, and structs
    (an iddata may be one) only when those variables cannot give the channels: with
    channels named, when one of them is not a variable; with none named, when ``u`` or
    ``y`` is missing.
    """
    from scipy.io import loadmat, whosmat
    from scipy.io.matlab import mat_struct

    with parsing(path, "a MATLAB .mat file"):
        try:
            listed = whosmat(path)
            stored = [name for name, _, _ in listed]
            shapes = {name: tuple(shape) for name, shape, _ in listed}
            wanted = set(_wanted(stored, shapes.__getitem__, needed, str(path)))
            kept = needed(stored)
            covered = set(MARKED) <= wanted if kept is None else kept <= _columns(shapes)
            if not covered:  # the channels can only come from an iddata struct
                wanted |= {name for name, _, kind in listed if kind == "struct"}
            content = loadmat(path, squeeze_me=True, struct_as_record=False,
                              variable_names=[name for name in stored if name in wanted])
        except NotImplementedError:  # scipy's answer to the HDF5-based v7.3 format
            raise DataError(f"{path} is a MATLAB v7.3 (HDF5) file; save it in MATLAB with "
                            "save(name, ..., '-v7')") from None
    if not stored:
        raise DataError(f"{path} holds no variables")
    variables = {key: value for key, value in content.items() if not key.startswith("__")}
    structs = {key: value for key, value in variables.items()
               if isinstance(value, mat_struct) and IDDATA_FIELDS <= set(value._fieldnames)}
    if len(structs) > 1:
        raise DataError(f"{path} holds several iddata structs ({', '.join(structs)}); keep one per file")
    if structs:
        return iddata_table(*structs.popitem(), str(path))
    if kept is None and not set(MARKED) <= set(stored):
        raise _unmarked(path, stored)
    return array_table(variables, str(path), stored)
