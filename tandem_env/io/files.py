"""File I/O the project shares: one JSON converter (:func:`to_jsonable`), one atomic writer
(:func:`atomic_path`), one output-folder check (:func:`output_directory`). JSON keeps Python's
non-finite floats (not strict RFC 8259): an optimiser's ``-inf`` best is worth keeping.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import errno
import fcntl
import io
import json
import os
import stat
import tempfile
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np


def to_jsonable(obj: Any, default: Callable[[Any], Any] | None = None) -> Any:
    """Convert ``obj`` to plain JSON types (numpy values, tuples, paths, ``to_dict()``
    objects, dataclasses; mapping keys as JSON writes them); anything else goes to ``default``
    (as in :func:`json.dumps`), else TypeError."""
    if obj is None or isinstance(obj, str | bool | int | float):
        return obj
    if isinstance(obj, np.generic | np.ndarray):  # a numpy scalar's tolist is its item
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, Mapping):
        return {_json_key(key): to_jsonable(value, default) for key, value in obj.items()}
    if isinstance(obj, list | tuple):
        return [to_jsonable(item, default) for item in obj]
    if not isinstance(obj, type):  # a class's to_dict is not the object's
        to_dict = getattr(obj, "to_dict", None)
        if callable(to_dict):
            return to_jsonable(to_dict(), default)
        if dataclasses.is_dataclass(obj):
            return {
                f.name: to_jsonable(getattr(obj, f.name), default) for f in dataclasses.fields(obj)
            }
    if default is not None:
        return default(obj)
    raise TypeError(f"cannot convert {type(obj).__name__} to JSON: {obj!r}")


def _json_key(key: Any) -> str:
    # As json.dumps writes it (3 -> "3", True -> "true"), so a converted object equals its
    # round trip through a file.
    key = key.item() if isinstance(key, np.generic) else key
    if isinstance(key, str):
        return key
    if key is None or isinstance(key, bool | int | float):
        return json.dumps(key)
    raise TypeError(f"JSON object keys must be str, int, float, bool or None, got {key!r}")


def output_directory(
    path: str | os.PathLike[str],
    option: str = "--out",
    *,
    write: bool = True,
    folders: Sequence[str] = (),
    files: Sequence[str] = (),
) -> bool:
    """Check ``path`` (need not exist) and the ``folders`` and ``files`` a command writes in
    it as an output folder before any work; whether it can be written now. ValueError naming
    ``option``, the path and what is allowed for an empty path, a file where a folder goes (or
    the reverse), a broken symlink, and, with ``write``, a folder that cannot be written
    (tried with a temporary file); without ``write`` that returns False instead.
    """
    text = os.fspath(path)
    if not text:
        raise ValueError(
            f"{option} '': an empty path; allowed: a directory path (. for the current folder)"
        )
    path = Path(text)
    given, writable = f"{option} {str(path)!r}", True
    for folder in (path, *(path / name for name in folders)):
        writable = _check_folder(folder, given, write) and writable
    for name in files:
        target = path / name
        _check_link(target, given)
        if target.is_dir():
            raise ValueError(
                f"{given}: {target} is a directory; allowed: a file the command writes (remove or "
                "rename the directory)"
            )
    return writable


def _check_link(target: Path, given: str) -> None:
    """ValueError for a symlink that resolves to nothing (dangling) or into a loop."""
    if not target.is_symlink():
        return
    try:
        target.stat()
    except OSError as error:
        what = f"a dangling symlink (to {os.readlink(target)!r})"
        what = "a symlink loop" if error.errno == errno.ELOOP else what
        raise ValueError(
            f"{given}: {target} is {what}; allowed: a directory this user can write, or a "
            "symlink to one"
        ) from None


def _check_folder(folder: Path, given: str, write: bool) -> bool:
    existing = folder
    allowed = "allowed: a directory this user can write (created if missing)"
    try:
        while not os.path.lexists(existing) and existing.parent != existing:
            existing = existing.parent
        _check_link(existing, given)
        is_dir = existing.is_dir()
    except OSError as error:
        why = error.strerror or error
        raise ValueError(f"{given}: cannot look into {existing} ({why}); {allowed}") from None
    if not is_dir:
        raise ValueError(
            f"{given}: {existing} is a file; allowed: a directory (created if missing)"
        )
    try:
        fd, name = tempfile.mkstemp(prefix=".write-check.", dir=existing)
        os.close(fd)
        os.unlink(name)
    except OSError as error:
        if write:
            why = error.strerror or error
            raise ValueError(f"{given}: cannot write into {existing} ({why}); {allowed}") from None
        return False
    return True


def new_file_mode() -> int:
    """The mode a newly created file gets under the process's umask (``0o666 & ~umask``)."""
    # The umask read without changing it where the platform says it (Linux >= 4.7); otherwise
    # set and restored under a lock, the one way the os module offers.
    with contextlib.suppress(OSError, ValueError), open("/proc/self/status", encoding="ascii") as f:
        for line in f:
            if line.startswith("Umask:"):
                return 0o666 & ~int(line.split()[1], 8)
    with _UMASK_LOCK:
        mask = os.umask(0o022)
        os.umask(mask)
    return 0o666 & ~mask


_UMASK_LOCK = threading.Lock()


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same suffix); on success it is fsynced and
    replaces ``path`` atomically (keeping an existing file's mode if its owner can read and
    write it, else :func:`new_file_mode`), else it is removed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(
        prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=path.parent
    )
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        try:
            mode = stat.S_IMODE(path.stat().st_mode)
        except OSError:  # no file yet (or none that can be looked at)
            mode = 0
        owner = stat.S_IRUSR | stat.S_IWUSR
        os.chmod(tmp, mode if mode & owner == owner else new_file_mode())
        with open(tmp, "ab") as handle:
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    # The rename itself made durable on POSIX; directories cannot be opened this way on
    # Windows, where the rename is as durable as the platform makes it.
    with contextlib.suppress(OSError):
        fd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


class FolderInUse(ValueError):
    """Another process holds the folder's lock (:class:`FolderLock`)."""


class FolderLock:
    """The exclusive lock of a folder one command writes in (a context manager): an ``flock``
    on ``folder/name`` holding the holder's pid, released by the kernel however it exits;
    another process's :meth:`acquire` raises :class:`FolderInUse` with ``busy(pid)``."""

    def __init__(self, folder: str | os.PathLike[str], name: str, busy: Callable[[str], str]):
        self.path = Path(folder) / name
        self._busy = busy
        self._fd: int | None = None

    def acquire(self) -> FolderLock:
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as error:
            why = f"{self.path.parent} is not writable ({error.strerror})"
            raise ValueError(f"{why}; allowed: a folder you can write") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.read(fd, 32).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise FolderInUse(self._busy(holder)) from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._fd = fd
        return self

    def release(self) -> None:
        if self._fd is not None:
            fcntl.flock(self._fd, fcntl.LOCK_UN)
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> FolderLock:
        return self.acquire() if self._fd is None else self

    def __exit__(self, *exc: object) -> None:
        self.release()


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_path`)."""
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as handle:
        # newline="" so the CSV writer's line endings are written as given on every platform.
        handle.write(text)


def write_json_atomic(path: str | os.PathLike[str], obj: Any, *, indent: int | None = 2) -> None:
    """Write ``obj`` as JSON to ``path`` atomically (TypeError before touching the disk)."""
    text = json.dumps(to_jsonable(obj), indent=indent, sort_keys=False) + "\n"
    write_text_atomic(Path(path), text)


def read_json(path: str | os.PathLike[str]) -> Any:
    """Read a JSON file; ValueError for one that is not UTF-8 JSON (or nested too deeply)."""
    with open(path, encoding="utf-8") as handle:
        try:
            return json.load(handle)
        except RecursionError:  # the decoder recurses per level: a hand-made file can be deeper
            raise ValueError("JSON nested too deeply to read") from None


def write_csv_atomic(path: str | os.PathLike[str], rows: Sequence[Mapping[str, Any]]) -> None:
    """Write ``rows`` as CSV to ``path`` atomically: the union of their keys as columns, None
    as an empty cell, lists and dicts as JSON text."""
    columns: dict[str, None] = {}  # an ordered set
    for row in rows:
        columns.update(dict.fromkeys(row))
    buffer = io.StringIO()
    if columns:
        writer = csv.DictWriter(buffer, fieldnames=list(columns), lineterminator="\n")
        writer.writeheader()
        for row in rows:
            cells = {key: to_jsonable(value) for key, value in row.items()}
            text = {k: json.dumps(v) for k, v in cells.items() if isinstance(v, list | dict)}
            writer.writerow({**cells, **text})  # None an empty cell, as csv writes it
    write_text_atomic(Path(path), buffer.getvalue())
