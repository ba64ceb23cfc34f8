"""The record cache: one store of records shared by every output folder (docs/harness.md, "The
record cache"). Its folder and files must be the user's own (:func:`record_cache`); what it
serves is re-evaluated first (:mod:`agents.verify`); a method that takes a path is never cached
(:func:`cacheable`).
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
    """The record cache as a ``strict`` store, or None: when off, or (said once per process in
    a :class:`RecordWarning`) when its folder is not one or :func:`~agents.store.unsafe_path`
    refuses it or its ``records``."""
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
    """Whether ``job``'s record may be kept in the record cache (not a method taking a path,
    which reads files relative to where it runs)."""
    return not isinstance(job, Job) or ":" not in job.method


class CacheWriter:
    """The record cache of one :func:`~agents.runner.run_jobs` call; one that cannot be
    written is said once and then left alone (the records are in ``--out``)."""

    def __init__(self, store: RecordStore | None) -> None:
        self.store = store

    def load(self, job: Job | Work) -> Record | None:
        return None if self.store is None or not cacheable(job) else self.store.load(job)

    def save(self, record: Record, *, unless_present: bool = False) -> None:
        if (store := self.store) is None or not cacheable(record.job):
            return
        if unless_present and store.path(record.key).exists():
            return
        try:
            store.save(record)
        except (StoreWriteError, ValueError) as error:
            self.store = None
            where = "the records are in the output folder (--no-cache turns the cache off)"
            message = f"the record cache is not written ({error}); {where}"
            warnings.warn(message, RecordWarning, stacklevel=4)
