"""Files written whole or not at all, and output paths checked before any work.

Every file moli writes (a model, a report page and its figures, a fleet summary, the
DaISy cache) goes through :func:`atomic_file`: the bytes go to a temporary file in the
target's own folder, are flushed to disk (``fsync``) and only then renamed over the
target with :func:`os.replace`, which is atomic on POSIX and Windows. A process killed
mid-write, a full disk or a failing encoder leaves the previous file as it was (or no
file), never a truncated one; two writers racing on one path leave one complete file.

A process killed before its rename leaves its temporary file behind. A process's first
write into that folder removes such leftovers (:func:`remove_leftovers`): only files named
as moli names them, and only when their writer is gone, so a save running at the same
time in another process keeps its file.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import tempfile
import time
from pathlib import Path
from typing import IO, Iterable, Iterator

from ..errors import DataError, ModelFileError, MoliError

__all__ = ["atomic_file", "write_atomic", "write_json", "remove_leftovers", "check_output_file", "check_output_folder"]

# A temporary file is ``.<target name>.<writer's process id>.<mkstemp's 8 characters>.part``.
TEMPORARY = re.compile(r"\..+\.(?P<pid>[1-9]\d{0,9})\.[a-z0-9_]{8}\.part")
# A temporary file whose writer has ended is left alone this many seconds after its last
# change: its process id means nothing to a writer on another machine sharing the folder,
# which is still writing if it changed the file that recently.
GRACE_SECONDS = 60.0
# The umask when this module was imported (set and set back while no file of moli's is being
# written): what _umask falls back to where /proc does not state it.
IMPORT_UMASK = os.umask(0)
os.umask(IMPORT_UMASK)
# Folders this process has already rid of leftovers: one look per folder and process, so
# a fleet writing thousands of models into one folder does not list it at every save.
_SWEPT: set[str] = set()
# A temporary file unchanged this long is a leftover whatever its process id says: that
# id may have been given to another process since, and no write of moli pauses for a day.
STALE_SECONDS = 86400.0


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike[str], mode: str = "w", encoding: str | None = "utf-8",
                newline: str | None = None) -> Iterator[IO]:
    """A handle on a temporary sibling of ``path``, renamed onto ``path`` when the block ends.

    Parameters
    ----------
    path : path
        The file to (re)place. Its folder must exist. A symbolic link at ``path`` is
        replaced by the file, never followed.
    mode : {"w", "wb"}
        Text or binary.
    encoding, newline : str, optional
        As :func:`open`, for text mode.

    Yields
    ------
    file object
        Write the whole content to it; an exception in the block removes the
        temporary file and leaves ``path`` untouched.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> with atomic_file(target) as handle:
    ...     _ = handle.write("whole")
    >>> target.read_text()
    'whole'
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb', got {mode!r}")
    target = Path(path)
    if _special(target):        # the file would replace it: /dev/null gone, for one
        raise OSError(f"{target} is a device, a pipe or a socket, not a file to write")
    folder = os.path.abspath(target.parent)
    if folder not in _SWEPT:
        remove_leftovers(folder)
        _SWEPT.add(folder)
    fd, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.{os.getpid()}.", suffix=".part")
    try:
        text = {"encoding": encoding, "newline": newline} if mode == "w" else {}
        with os.fdopen(fd, mode, **text) as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        _keep_mode(target, temporary)
        os.replace(temporary, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


def _running(pid: int) -> bool:
    """Whether process ``pid`` runs on this machine; True when that cannot be told."""
    if os.name != "posix":
        return True  # os.kill there would end the process, not probe it
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):  # another user's process, or an id no process can have
        return True
    return True


def remove_leftovers(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files that killed writes left in ``folder``; return them.

    A file is removed when its name is one :func:`atomic_file` gives (``.NAME.PID.XXXXXXXX.part``)
    and either its writing process ``PID`` no longer runs and the file has not changed for
    :data:`GRACE_SECONDS`, or it has not changed for :data:`STALE_SECONDS` (its writer's
    id since given to another process). A write in progress, in this process or another,
    is never touched. Files that vanish or cannot be removed meanwhile are skipped: the
    caller's own write is what matters.
    """
    removed = []
    now = time.time()
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        found = entry.name.endswith(".part") and TEMPORARY.fullmatch(entry.name)
        if not found:
            continue
        try:
            if not entry.is_file(follow_symlinks=False):
                continue
            age = now - entry.stat(follow_symlinks=False).st_mtime
            if age > STALE_SECONDS or age > GRACE_SECONDS and not _running(int(found["pid"])):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        except OSError:
            continue
    return removed


def _keep_mode(target: Path, temporary: str) -> None:
    """The new file gets the old one's permissions, else the usual ones (mkstemp's are 0600)."""
    try:
        mode = target.stat().st_mode & 0o777 if target.is_file() and not target.is_symlink() else None
    except OSError:
        mode = None
    if mode is None:
        mode = 0o666 & ~_umask()
    os.chmod(temporary, mode)


def _umask() -> int:
    """The process's umask, read without setting it: os.umask can only be read by setting it
    and back, and a file another thread creates in between would get mode 0666. Linux states
    it in /proc; elsewhere the value read when this module was imported."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    return IMPORT_UMASK


def write_atomic(path: str | os.PathLike[str], content: str | bytes) -> None:
    """Write ``content`` (text as UTF-8, or bytes) to ``path`` through :func:`atomic_file`."""
    with atomic_file(path, "wb") as handle:
        handle.write(content.encode("utf-8") if isinstance(content, str) else content)


def write_json(path: object, record: dict, what: str) -> None:
    """``record`` as JSON in ``path``, whole or not at all (:func:`write_atomic`).

    A value JSON cannot hold (an array, an object) is a :class:`DataError` naming ``what``; a
    folder, a missing folder or no permission a :class:`ModelFileError` naming the path.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise DataError(f"path must be a str or Path, got {type(path).__name__}")
    try:
        text = json.dumps(record, indent=1)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{what} holds a value JSON cannot store ({exc}): keep numbers, text, lists and "
                        "dicts in its info (an array as .tolist())") from None
    try:
        write_atomic(path, text)
    except OSError as exc:
        raise ModelFileError(f"cannot write {what} to {path}: {exc.strerror or exc}") from None


def _special(path: Path) -> bool:
    """Whether ``path`` is there and is neither a regular file nor a folder."""
    return path.exists() and not (path.is_file() or path.is_dir())


def _same_file(path: Path, other: Path) -> bool:
    try:
        return path.exists() and other.exists() and os.path.samefile(path, other)
    except OSError:
        return False


def check_output_file(path: str | os.PathLike[str], what: str,
                      inputs: Iterable[str | os.PathLike[str]] = ()) -> Path:
    """``path`` as a file moli may write, checked before any work.

    Refuses a folder, one of ``inputs``, and a folder that exists but cannot be
    written to. A missing parent folder is fine (it is created when writing).

    Parameters
    ----------
    path : path
    what : str
        How the error names it, e.g. ``"--out"``.
    inputs : paths
        Files the run reads: never overwritten.

    Returns
    -------
    Path

    Raises
    ------
    MoliError
        Naming ``what`` and the reason.
    """
    target = _not_an_input(Path(path), what, inputs)
    _check_writable(target.parent, what)
    return target


def _not_an_input(target: Path, what: str, inputs: Iterable[str | os.PathLike[str]]) -> Path:
    if target.is_dir():
        raise MoliError(f"{what}: {target} is a folder; give a file name")
    if _special(target):
        raise MoliError(f"{what}: {target} is a device, a pipe or a socket, which writing a file in its place "
                        "would destroy; give a file name")
    for source in inputs:
        if _same_file(target, Path(source)):
            raise MoliError(f"{what}: {target} is an input of this run; writing it would destroy it")
    return target


def check_output_folder(path: str | os.PathLike[str], what: str, names: Iterable[str] = (),
                        inputs: Iterable[str | os.PathLike[str]] = ()) -> Path:
    """``path`` as a folder moli may write ``names`` into, checked before any work.

    Raises :class:`MoliError` when ``path`` is a file, cannot be written to, or when
    one of ``folder/name`` is an input of the run.
    """
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise MoliError(f"{what}: {folder} is a file, not a folder")
    inputs = list(inputs)
    for name in names:
        _not_an_input(folder / name, what, inputs)
    _check_writable(folder, what)
    return folder


def _check_writable(folder: Path, what: str) -> None:
    """The nearest existing folder up from ``folder`` must take new files."""
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise MoliError(f"{what}: {existing} is a file, so {folder} cannot be a folder")
    try:  # a probe, not os.access: it also sees read-only mounts and full quotas
        fd, probe = tempfile.mkstemp(dir=existing, prefix=".moli-probe.")
    except OSError as exc:
        raise MoliError(f"{what}: cannot write in {existing} ({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)
