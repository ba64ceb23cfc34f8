"""The record cache: one store of records shared by every output folder.

Its rules (where it is, what the runner does with it, what it never holds, how to turn it off)
are in docs/harness.md, "The record cache": a job with no record in ``--out`` takes the
cache's, and every record computed is written to the cache too (:func:`agents.runner.run_jobs`,
through a :class:`CacheWriter`). The folder and its files must be the user's own, writable by no
one else (:func:`record_cache`, :func:`agents.store.unsafe_path`), and what it serves is
re-evaluated first (:mod:`agents.verify`). A job whose method takes a path (``policy:RUN_DIR``)
is never cached (:func:`cacheable`): its result depends on files outside the output folder.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

from agents.jobs import Job, Work
from agents.records import Record, RecordWarning
from agents.store import (
    CACHE_ENV,
    RECORDS_DIR,
    RecordStore,
    StoreWriteError,
    cache_directory,
    unsafe_path,
)

CacheOption = bool | str | os.PathLike[str] | None
"""The record cache a call uses: True its folder (:func:`agents.store.cache_directory`), a path
another folder, False or None none."""


def record_cache(cache: CacheOption = True) -> RecordStore | None:
    """The record cache as a store whose files must be the user's own (``strict``), or None:
    when off, or (said once per process, in one :class:`RecordWarning` line) when its folder
    cannot be used or trusted: not a folder, or a folder (or its ``records``) that
    :func:`~agents.store.unsafe_path` refuses, owned by another user or writable by others, as
    ssh refuses such keys."""
    if cache is None or cache is False:
        return None
    directory = Path(cache_directory() if cache is True else cache)
    why = None
    for path in (directory, directory / RECORDS_DIR):
        try:
            if path.exists():
                why = unsafe_path(path, path.stat()) if path.is_dir() else f"{path} is not a folder"
        except OSError as error:
            why = f"{path}: {error.strerror or error}"
        if why is not None:
            break
    else:
        return RecordStore(directory, strict=True)
    message = (
        f"the record cache is not used: {why} (allowed: a folder of your own that only you can "
        f"write; set {CACHE_ENV} to one, or turn the cache off: --no-cache)"
    )
    if message not in _SAID:  # once, not once per phase of a command
        _SAID.add(message)
        warnings.warn(message, RecordWarning, stacklevel=3)
    return None


#: The warnings :func:`record_cache` has given in this process.
_SAID: set[str] = set()


def cacheable(job: Job | Work) -> bool:
    """Whether ``job``'s record may be kept in the record cache."""
    # A method that takes a path (policy:RUN_DIR) reads files relative to where it runs.
    return not isinstance(job, Job) or ":" not in job.method


class CacheWriter:
    """The record cache of one :func:`~agents.runner.run_jobs` call: read through the store's
    checks, written through its atomic save; a cache that cannot be written is said once and
    then left alone (the records are in ``--out``)."""

    def __init__(self, store: RecordStore | None) -> None:
        self.store = store

    def load(self, job: Job | Work) -> Record | None:
        if self.store is None or not cacheable(job):
            return None
        return self.store.load(job)

    def save(self, record: Record, *, unless_present: bool = False) -> None:
        store = self.store
        if store is None or not cacheable(record.job):
            return
        if unless_present and store.path(record.key).exists():
            return
        try:
            store.save(record)
        except (StoreWriteError, ValueError) as error:
            self.store = None
            warnings.warn(
                f"the record cache is not written ({error}); the records are in the output "
                "folder (--no-cache turns the cache off)",
                RecordWarning,
                stacklevel=4,
            )
