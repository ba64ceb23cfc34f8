"""The cross-check's runs: one JSON record per solver run, run once, in parallel, resumably.

A record is ``OUT/runs/<key>.json`` (the key: :meth:`~eval.crosscheck.case.Run.key`), written
atomically by the one process that holds the folder's lock and checked against a checksum when
read back; why it is not a :class:`~agents.store.RecordStore` record: docs/crosscheck.md, "What
it writes". Runs go where the studies' jobs go (``--scheduler``, :mod:`agents.dask_cluster`),
each Dask worker with one numba thread; this process writes each record as its run finishes.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import time
import traceback
import warnings
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from tandem_env.io.files import FolderLock, read_json, write_json_atomic

from .case import RUN_FORMAT, Run

#: A store's records folder, ``OUT/runs``.
RUNS_DIR = "runs"
#: The lock file of an output folder, held (``flock``) by the command writing there.
LOCK_FILE = ".crosscheck.lock"


class RunRecordWarning(UserWarning):
    """A stored record that is damaged or not of its run: the run is done again."""


class RunsFailed(RuntimeError):
    """Some runs raised; the others finished and their records are stored."""


def _checksum(body: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest()


class RunStore:
    """The records of one output folder for one solver version."""

    def __init__(self, out_dir: str | os.PathLike[str], solver_version: str) -> None:
        self.directory = Path(out_dir)
        self.solver_version = solver_version

    def path(self, run: Run) -> Path:
        return self.directory / RUNS_DIR / f"{run.key(self.solver_version)}.json"

    def load(self, run: Run) -> dict[str, Any] | None:
        """The stored result of ``run``, or None (absent, or damaged: warned, done again)."""
        path = self.path(run)
        if not path.exists():
            return None
        try:
            record = read_json(path)
            body = {k: record[k] for k in ("format", "key", "solver", "run", "result")}
            if record.get("checksum") != _checksum(body):
                raise ValueError("its checksum does not match its contents")
            if body["format"] != RUN_FORMAT or body["key"] != run.key(self.solver_version):
                raise ValueError("it is of another run or format")
        except (OSError, ValueError, KeyError, TypeError) as error:
            warnings.warn(
                f"{path}: not a valid record of {run.label()} ({error}); running it again",
                RunRecordWarning,
                stacklevel=2,
            )
            return None
        return record["result"]

    def save(self, run: Run, result: dict[str, Any]) -> None:
        body = {
            "format": RUN_FORMAT,
            "key": run.key(self.solver_version),
            "solver": self.solver_version,
            "run": asdict(run),
            "result": result,
        }
        # Through JSON first, so the checksum is of what a reader gets back.
        body = json.loads(json.dumps(body))
        write_json_atomic(self.path(run), {**body, "checksum": _checksum(body)})


def locked(out_dir: str | os.PathLike[str]) -> FolderLock:
    """The lock of ``OUT/.crosscheck.lock`` (made if absent), held while a command writes there;
    :class:`~tandem_env.io.files.FolderInUse` naming the folder if another process holds it."""
    directory = Path(out_dir)
    directory.mkdir(parents=True, exist_ok=True)
    return FolderLock(
        directory,
        LOCK_FILE,
        lambda pid: (
            f"--out {str(directory)!r}: another cross-check (pid {pid}) is writing there; "
            "allowed: one command per folder at a time (wait for it, or give another --out)"
        ),
    )


def _solve_on_worker(run: Run) -> dict[str, Any]:
    """What a Dask worker runs: one solve with one numba thread (one run per core)."""
    from agents.dask_cluster import set_worker_numba_threads

    set_worker_numba_threads()
    from .uvlm import solve

    return solve(run)


def run_all(
    runs: Sequence[Run],
    store: RunStore,
    *,
    scheduler: str | None = None,
    progress: bool = True,
) -> dict[Run, dict[str, Any]]:
    """The result of every run in ``runs``: stored ones read back, the others solved (here one
    after another, or on Dask) and stored as each finishes. Raises :class:`RunsFailed` after
    every other run has finished if any raised."""
    unique = list(dict.fromkeys(runs))
    results = {run: found for run in unique if (found := store.load(run)) is not None}
    todo = [run for run in unique if run not in results]
    if progress and unique:
        print(
            f"{len(unique)} solver runs: {len(results)} stored, {len(todo)} to run",
            file=sys.stderr,
        )
    failures: list[str] = []
    start = time.perf_counter()

    def finished(run: Run, outcome: dict[str, Any] | BaseException) -> None:
        if isinstance(outcome, BaseException):
            failures.append(f"--- {run.label()}: {type(outcome).__name__}: {outcome}")
            what = "failed"
        else:
            store.save(run, outcome)
            results[run] = outcome
            what = f"{outcome['wall_time']:.0f} s"
        if progress:
            print(
                f"[{len(results) + len(failures)}/{len(unique)}] {run.label()}: {what} "
                f"({time.perf_counter() - start:.0f} s so far)",
                file=sys.stderr,
            )

    if todo and scheduler is None:
        from .uvlm import solve

        for run in todo:
            try:
                outcome: dict[str, Any] | BaseException = solve(run)
            except Exception as error:
                outcome = error
                traceback.print_exc()
            finished(run, outcome)
    elif todo:
        from distributed import as_completed

        from agents.dask_cluster import dask_client

        with dask_client(scheduler, quiet=not progress) as client:
            # The tandem runs first: they take longest, so the workers stay busy to the end.
            ordered = sorted(todo, key=lambda r: r.kind != "tandem")
            futures = {
                client.submit(
                    _solve_on_worker, run, key=f"uvlm-{run.key(store.solver_version)}", retries=0
                ): run
                for run in ordered
            }
            for future in as_completed(futures):
                run = futures[future]
                if future.status == "finished":
                    finished(run, future.result())
                else:
                    finished(run, future.exception() or RuntimeError(f"task {future.status}"))
                future.release()
    if failures:
        raise RunsFailed(
            f"{len(failures)} of {len(todo)} solver runs failed (the others are stored; rerun "
            "the same command to retry):\n" + "\n".join(failures)
        )
    return results
