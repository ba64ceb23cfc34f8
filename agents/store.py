"""The record store: a job's record kept as ``DIR/records/<key>.json``, found by its job's key
(:attr:`agents.jobs.Job.key`), written atomically by the runner alone
(:func:`agents.runner.run_jobs`), so a killed run resumes; a file that is not a valid record of
its job is recomputed with a :class:`~agents.records.RecordWarning`. ``DIR/summary.csv``
summarises it. The record cache is a store too, shared by every output folder of a user
(:func:`cache_directory`; docs/harness.md, "The record cache").
"""

from __future__ import annotations

import json
import os
import re
import stat
import warnings
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from agents.jobs import OLD_SCHEMAS, SCHEMA, Job, Work
from agents.records import (
    OutdatedRecordError,
    Record,
    RecordChecksumError,
    RecordError,
    RecordMismatchError,
    RecordWarning,
    UnsafeFileError,
)
from tandem_env.io.files import output_directory, write_csv_atomic, write_json_atomic

#: A store's records folder, ``DIR/records``.
RECORDS_DIR = "records"
#: A store's CSV summary over its records, ``DIR/summary.csv``.
SUMMARY_NAME = "summary.csv"
#: The environment variable that moves the record cache (:func:`cache_directory`).
CACHE_ENV = "TANDEM_CACHE_DIR"


def cache_directory() -> Path:
    """The record cache's folder, a store shared by every output folder (read at each call):
    ``$TANDEM_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/tandem_env``, else
    ``~/.cache/tandem_env``; its records are ``<folder>/records/<key>.json``."""
    if given := os.environ.get(CACHE_ENV):
        return Path(given).expanduser()
    base = os.environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):  # unset, empty or relative: the XDG spec says ignore it
        base = os.path.join("~", ".cache")
    return Path(base).expanduser() / "tandem_env"


class StoreWriteError(OSError):
    """A store's file could not be written (a full disk, a folder made read-only, a directory
    in a file's place): the file is as it was (writes are atomic), the records already stored
    are kept, and the same command resumes from them once the cause is fixed."""

    def __init__(self, path: Path, error: OSError) -> None:
        super().__init__(
            error.errno,
            f"cannot write {path} ({error.strerror or error}); it is left as it was and the "
            "records already stored are kept: fix that and run the same command again to resume",
        )
        self.path = path

    def __str__(self) -> str:
        return str(self.strerror)


#: A store's file name for a record: its key (:attr:`Job.key`, 20 hex digits).
_KEY_NAME = re.compile(r"[0-9a-f]{20}")


def read_record(
    path: str | os.PathLike[str], *, strict: bool = False, kind: Any = Record
) -> Record:
    """The record in a record file, read by ``kind.from_dict`` (a :class:`~agents.jobs.Work`
    kind's ``record_type``); :class:`~agents.records.RecordError` naming the file for anything
    else (OSError if it cannot be opened; ``strict``: :func:`unsafe_path`'s refusals too)."""
    data = _read_json(path, strict=strict)
    try:
        return kind.from_dict(data)
    except RecordError as error:
        raise type(error)(f"{path}: {error}") from None


def unsafe_path(path: str | os.PathLike[str], status: os.stat_result) -> str | None:
    """Why a file or folder of status ``status`` is not to be trusted, as ssh judges its keys:
    owned by another user (nor root), or writable by its group or by others; None if it is
    safe. Such a file may hold anything anyone wrote."""
    if status.st_uid not in (os.geteuid(), 0):
        return f"{path} is owned by uid {status.st_uid}, not by you (uid {os.geteuid()})"
    if status.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return f"{path} is writable by others (mode {stat.filemode(status.st_mode)})"
    return None


def _read_json(path: str | os.PathLike[str], *, strict: bool = False) -> Any:
    """The JSON in one of the store's files; RecordError naming the file for one that is not
    UTF-8 JSON, :class:`~agents.records.UnsafeFileError` for one that is not a regular file
    (never read) or, if ``strict``, that :func:`unsafe_path` refuses."""
    # O_NONBLOCK: opening a named pipe would wait for a writer; fstat judges what was opened.
    descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    with open(descriptor, encoding="utf-8") as handle:
        status = os.fstat(descriptor)
        if not stat.S_ISREG(status.st_mode):
            raise UnsafeFileError(f"{path} is not a regular file; it is not read")
        if strict and (why := unsafe_path(path, status)) is not None:
            raise UnsafeFileError(f"{why}; it is not trusted")
        try:
            return json.load(handle)
        except ValueError as error:  # not UTF-8, not JSON, truncated
            reason = str(error)
        except RecursionError:  # the decoder recurses per nesting level: a hand-made file
            reason = "JSON nested too deeply to read"
    raise RecordError(f"{path}: not a record file, cannot read JSON ({reason})")


def _check_name(path: Path, record: Record) -> Record:
    """``record`` if ``path`` is named by its key (``<key>.json``) or by no key at all;
    RecordError for one moved or copied to another job's name."""
    if _KEY_NAME.fullmatch(path.stem) and path.stem != record.key:
        raise RecordMismatchError(
            f"{path}: holds the record of key {record.key} ({record.label()}), not of the key "
            f"{path.stem} it is named by: moved or copied by hand; it is not used"
        )
    return record


class RecordStore:
    """Records keyed by configuration: ``DIR/records/<key>.json``, written atomically.

    Raises ValueError when ``directory`` (or its ``records``) exists and is not a directory.
    ``strict`` (the record cache, shared): a record file that :func:`unsafe_path` refuses is
    not trusted (:meth:`load`), and :meth:`save` writes folders and files that it accepts.
    """

    def __init__(self, directory: str | os.PathLike[str], *, strict: bool = False) -> None:
        self._given = os.fspath(directory)  # as given: Path("") would be the current folder
        self.directory = Path(directory)
        self.strict = strict
        for path in (self.directory, self.directory / RECORDS_DIR):
            if path.exists() and not path.is_dir():
                allowed = "allowed: a directory for the records (created if missing)"
                raise ValueError(f"{path} is a file; {allowed}")

    @classmethod
    def at(cls, out: str | os.PathLike[str] | RecordStore) -> RecordStore:
        """``out`` if it is a store (a command's one), else the store in folder ``out``."""
        return out if isinstance(out, RecordStore) else cls(out)

    def check(self, *, write: bool = True, jobs: Iterable[Job] = ()) -> bool:
        """Check every path the store writes before any work (:func:`output_directory`): the folder,
        its ``records``, ``summary.csv`` and the record files of ``jobs``; ValueError naming the
        path and what is allowed, or (without ``write``) False if it cannot be written now."""
        files = (SUMMARY_NAME, *(f"{RECORDS_DIR}/{job.key}.json" for job in jobs))
        return output_directory(
            self._given, "--out", write=write, folders=(RECORDS_DIR,), files=files
        )

    def path(self, key: str) -> Path:
        """Where the record with configuration hash ``key`` is stored."""
        return self.directory / RECORDS_DIR / f"{key}.json"

    def load(self, job: Job | Work) -> Record | None:
        """The stored record of ``job``, or None if it has not run with this configuration; a
        file that is not a valid, trusted record of ``job`` is said in a :class:`RecordWarning`
        and treated as missing, so the job runs again and its record replaces the file."""
        if not (path := self.path(job.key)).exists():
            return None
        try:
            record = read_record(path, strict=self.strict, kind=getattr(job, "record_type", Record))
        except (OutdatedRecordError, UnsafeFileError) as error:
            return _warn(f"{error}; {job.label()} is recomputed")
        except (OSError, RecordError) as error:
            reason = str(error).removeprefix(f"{path}: ")
            return _warn(f"{path}: corrupt record ({reason}); {job.label()} runs again")
        if record.key != job.key or record.job.configuration() != job.configuration():
            return _warn(
                f"{path}: holds {record.label()} (job {record.job.to_dict()}), not "
                f"{job.label()}; it runs again and its record replaces the file"
            )
        return record

    def save(self, record: Record) -> Path:
        """Write ``record`` as ``records/<record.key>.json`` atomically; returns the path."""
        path, data = self.path(record.key), record.to_dict()
        try:
            if self.strict:  # the user's alone (unsafe_path), whatever the umask
                self.directory.mkdir(mode=0o700, parents=True, exist_ok=True)
                path.parent.mkdir(mode=0o700, exist_ok=True)
            write_json_atomic(path, data)
            if self.strict:  # a new file, ours; not the mode of the one it replaced
                path.chmod(stat.S_IMODE(path.stat().st_mode) & ~(stat.S_IWGRP | stat.S_IWOTH))
        except OSError as error:
            raise StoreWriteError(path, error) from None
        return path

    def records(self, known: Mapping[str, Record] | None = None) -> list[Record]:
        """Every valid record in the store, in the summary's order (the others left out with a
        :class:`RecordWarning`); those ``known`` (key -> record) are not read again."""
        found = []
        for path in sorted((self.directory / RECORDS_DIR).glob("*.json")):
            if (record := (known or {}).get(path.stem)) is not None and record.key == path.stem:
                found.append(record)
                continue
            try:
                found.append(_check_name(path, read_record(path, strict=self.strict)))
            except (OSError, RecordError) as error:
                _warn(f"{error}; left out")
        return sorted(found, key=_summary_order)

    def outdated(self, skip: Iterable[str] = ()) -> list[Path]:
        """The store's files holding records of an earlier format (:data:`OLD_SCHEMAS`), but
        those of the keys ``skip`` (not read: :meth:`load` has read them)."""
        skip = set(skip)
        found = []
        for path in sorted((self.directory / RECORDS_DIR).glob("*.json")):
            if path.stem in skip:
                continue
            try:
                data = _read_json(path, strict=self.strict)
            except (OSError, RecordError):
                continue  # reported by load() when its job asks for it
            if isinstance(data, dict) and data.get("schema") in OLD_SCHEMAS:
                found.append(path)
        return found

    def write_summary(self, known: Mapping[str, Record] | None = None) -> Path:
        """Rewrite ``DIR/summary.csv`` atomically (its path returned): a row
        (:meth:`Record.summary_row`) per record, in :meth:`records`' order (each file read at
        most once, none of ``known``)."""
        path = self.directory / SUMMARY_NAME
        rows = [record.summary_row() for record in self.records(known)]
        try:
            write_csv_atomic(path, rows)
        except OSError as error:
            raise StoreWriteError(path, error) from None
        return path


def _warn(message: str) -> None:
    """Say ``message`` in a :class:`RecordWarning` (None: what a record not served is)."""
    warnings.warn(message, RecordWarning, stacklevel=3)


def _summary_order(r: Record) -> tuple[Any, ...]:
    return (r.task, r.objective_name, r.condition.value, r.method, r.budget, r.seed, r.key)


def read_record_files(paths: Iterable[str | os.PathLike[str]]) -> list[Record]:
    """Every record in the given files and directories (searched recursively for ``*.json``):
    other JSON files are skipped, a record of an earlier format or failing its checksum is left
    out with a :class:`RecordWarning`, and a file that cannot be read or is a malformed record
    raises :class:`RecordError` naming it."""
    records: list[Record] = []
    for base in map(Path, paths):
        if not base.exists():
            raise ValueError(f"{base}: no such file or directory")
        for path in sorted(base.rglob("*.json")) if base.is_dir() else [base]:
            try:
                data = _read_json(path)
            except OSError as error:
                raise RecordError(f"{path}: cannot read JSON: {error}") from None
            if not isinstance(data, dict) or data.get("schema") not in (SCHEMA, *OLD_SCHEMAS):
                continue  # another JSON file
            try:
                records.append(_check_name(path, Record.from_dict(data)))
            except (OutdatedRecordError, RecordChecksumError, RecordMismatchError) as error:
                _warn(f"{path}: {str(error).removeprefix(f'{path}: ')}; left out")
            except RecordError as error:
                raise RecordError(f"{path}: malformed record: {error}") from None
    return records
