"""Files written whole or not at all, and output paths checked before any work.

Every file moli writes (a model, a report page and its figures, a fleet summary, the
DaISy cache) goes through :func:`atomic_file`: the bytes go to a temporary file in the
target's own folder, are flushed to disk (``fsync``) and only then renamed over the
target with :func:`os.replace`, which is atomic on POSIX and Windows. A process killed
mid-write, a full disk or a failing encoder leaves the previous file as it was (or no
file), never a truncated one; two writers racing on one path leave one complete file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import IO, Iterable, Iterator

from ..errors import MoliError

__all__ = ["atomic_file", "write_atomic", "check_output_file", "check_output_folder"]


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
    fd, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".part")
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


def _keep_mode(target: Path, temporary: str) -> None:
    """The new file gets the old one's permissions, else the usual ones (mkstemp's are 0600)."""
    try:
        mode = target.stat().st_mode & 0o777 if target.is_file() and not target.is_symlink() else None
    except OSError:
        mode = None
    if mode is None:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask
    os.chmod(temporary, mode)


def write_atomic(path: str | os.PathLike[str], content: str | bytes) -> None:
    """Write ``content`` (text as UTF-8, or bytes) to ``path`` through :func:`atomic_file`."""
    with atomic_file(path, "wb") as handle:
        handle.write(content.encode("utf-8") if isinstance(content, str) else content)


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
