"""Result-record I/O: atomic JSON/CSV writes and the package versions stamped into records.

Writes go to a temporary file in the target directory, are fsynced and then renamed over the
target with :func:`os.replace`, so a reader (or a crash) only ever sees the old file or the
complete new one. Serialisation happens before any file is touched.

JSON is written with Python's defaults for non-finite floats (``NaN``, ``Infinity``,
``-Infinity``): not strict RFC 8259, but it round-trips through :func:`read_json`, and an
optimiser's ``-inf`` best fitness is information worth keeping.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import platform
import tempfile
from collections.abc import Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "package_versions",
    "read_json",
    "to_jsonable",
    "write_csv_atomic",
    "write_json_atomic",
    "write_text_atomic",
]

# Record key -> distribution name on the package index.
_PACKAGES = {
    "numpy": "numpy",
    "scipy": "scipy",
    "gymnasium": "gymnasium",
    "stable_baselines3": "stable-baselines3",
    "torch": "torch",
    "numba": "numba",
}


def to_jsonable(obj: Any) -> Any:
    """Convert ``obj`` to plain JSON types (dict, list, str, int, float, bool, None).

    numpy scalars become Python scalars, arrays become nested lists, tuples become lists,
    :class:`~pathlib.Path` becomes str and objects with a ``to_dict()`` method are converted
    through it. Anything else raises TypeError.
    """
    if obj is None or isinstance(obj, str | bool | int | float):
        return obj
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, Mapping):
        return {_json_key(key): to_jsonable(value) for key, value in obj.items()}
    if isinstance(obj, list | tuple):
        return [to_jsonable(item) for item in obj]
    to_dict = getattr(obj, "to_dict", None)
    if callable(to_dict):
        return to_jsonable(to_dict())
    raise TypeError(f"cannot convert {type(obj).__name__} to JSON: {obj!r}")


def _json_key(key: Any) -> str | int | float | bool | None:
    key = key.item() if isinstance(key, np.generic) else key
    if key is None or isinstance(key, str | bool | int | float):
        return key
    raise TypeError(f"JSON object keys must be str, int, float, bool or None, got {key!r}")


def write_json_atomic(path: str | os.PathLike[str], obj: Any, *, indent: int | None = 2) -> None:
    """Write ``obj`` as JSON to ``path`` atomically (parent directories are created).

    Raises TypeError for values :func:`to_jsonable` cannot convert, before touching the disk.
    """
    text = json.dumps(to_jsonable(obj), indent=indent, sort_keys=False) + "\n"
    write_text_atomic(Path(path), text)


def read_json(path: str | os.PathLike[str]) -> Any:
    """Read a JSON file written by :func:`write_json_atomic`."""
    with open(path, encoding="utf-8") as handle:
        return json.load(handle)


def write_csv_atomic(path: str | os.PathLike[str], rows: Sequence[Mapping[str, Any]]) -> None:
    """Write ``rows`` as CSV to ``path`` atomically.

    Columns are the union of the rows' keys in order of first appearance; a missing key or a
    None value is an empty cell. numpy scalars are written as plain numbers and list-, dict- or
    array-valued cells as JSON text.
    """
    columns: dict[str, None] = {}  # an ordered set
    for row in rows:
        columns.update(dict.fromkeys(row))
    buffer = io.StringIO()
    if columns:
        writer = csv.DictWriter(buffer, fieldnames=list(columns), lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({key: _csv_cell(value) for key, value in row.items()})
    write_text_atomic(Path(path), buffer.getvalue())


def _csv_cell(value: Any) -> Any:
    value = to_jsonable(value)
    if value is None:
        return ""
    if isinstance(value, list | dict):
        return json.dumps(value)
    return value


def package_versions() -> dict[str, str]:
    """Versions of the packages that determine results, plus the Python version.

    Keys: numpy, scipy, gymnasium, stable_baselines3, torch, numba, python. A package that is
    not installed is reported as ``"not installed"``.
    """
    versions: dict[str, str] = {}
    for key, distribution in _PACKAGES.items():
        try:
            versions[key] = metadata.version(distribution)
        except metadata.PackageNotFoundError:
            versions[key] = "not installed"
    versions["python"] = platform.python_version()
    return versions


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically: a temp file beside it, fsync, rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        # mkstemp creates the file 0600; keep an existing file's mode, else an ordinary 0644.
        os.chmod(tmp_name, path.stat().st_mode & 0o7777 if path.exists() else 0o644)
        # newline="" so the CSV writer's line endings are written as given on every platform.
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp_name, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp_name)
        raise
    _fsync_directory(path.parent)


def _fsync_directory(directory: Path) -> None:
    # Makes the rename itself durable on POSIX; directories cannot be opened this way on
    # Windows, where the rename is as durable as the platform makes it.
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
