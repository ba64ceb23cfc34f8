"""The runner: a set of harness jobs run once each, resumably, here or on a Dask cluster.

A :class:`~agents.jobs.Job` is one harness run: one method, task, condition, budget and
seed, with its env keywords, method settings and preset. Its key hashes all of that plus the
package version, and its record is kept in the output directory's
:class:`~agents.store.RecordStore` as ``DIR/records/<key>.json``. So

* a killed run resumes: a job whose record is stored (and names the same job) is not run
  again;
* a changed configuration (budget, seeds, env keywords, model options, preset, package version)
  gives new keys, so old records are never mixed in: analyses load exactly the records of the
  jobs they ask for, and stale files in the directory are ignored;
* the same command gives the same numbers: every job is seeded and runs alone, so neither the
  order, the executor nor the number of workers changes a result.

Where the jobs run (``scheduler``, ``--scheduler`` on the command line):

``None``
    in this process, one after another, with numba's default threads (the default: it needs
    no cluster, and on 2 cores it is as fast as two one-thread processes);
``"local:N"``
    a Dask ``LocalCluster`` started here with N worker processes of one thread each, each
    with ``NUMBA_NUM_THREADS=1``; closed at the end;
``"tcp://HOST:PORT"`` (or ``"HOST:PORT"``)
    a running Dask scheduler and its workers (``dask scheduler``, ``dask worker``,
    dask-jobqueue on SLURM/PBS; docs/scaling.md). Every worker needs this project importable
    (the same environment on every node).

Every job to run is validated once, here, before any of them runs
(:func:`agents.harness.prepare_job`; a job already prepared, as ``python -m eval optimize``
prepares its seeds, is not validated again), and the workers are sent the prepared jobs. This
process is the one writer of the records (``python -m eval optimize``, the studies and
``python -m train.envelope`` all submit their jobs here): it writes each as its job finishes
(workers need no shared filesystem) and hands it back in the :class:`RunSummary` without
reading it again, one progress bar counts the evaluations of the finished jobs, a worker that
dies has its jobs rerun by Dask, and a job that raises is reported with its key and traceback
after the other jobs have finished (:class:`JobsFailed`).
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import os
import re
import signal
import socket
import sys
import threading
import time
import traceback
import warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from agents.harness import PreparedJob, prepare_job, run_job
from agents.jobs import Job
from agents.records import Record, RecordWarning
from agents.store import RECORDS_DIR, RecordStore
from tandem_env.io.progress_bar import ProgressBar, Reporter

if TYPE_CHECKING:
    from distributed import Client

__all__ = [
    "JobFailure",
    "JobsFailed",
    "RunSummary",
    "SchedulerUnreachable",
    "dask_client",
    "executor_spec",
    "have_records",
    "load_records",
    "parse_scheduler",
    "run_jobs",
]

#: Seconds to wait for a Dask scheduler to answer before giving up [s].
CONNECT_TIMEOUT = 10.0
#: Prefix of the Dask task keys (``harness-<job key>``; the dashboard groups tasks by it).
TASK_PREFIX = "harness"
#: Most worker processes ``local:N`` starts on this machine [-].
MAX_LOCAL_WORKERS = 1024
#: TCP ports a scheduler address may name [-].
PORTS = (1, 65535)
#: The one transport the runner connects to (Dask's tls:// needs certificates it does not take).
SCHEME = "tcp"
_ALLOWED = (
    f"local:N (N = 1 to {MAX_LOCAL_WORKERS} worker processes started here) or the address of a "
    f"running Dask scheduler, {SCHEME}://HOST:PORT or HOST:PORT with PORT {PORTS[0]} to "
    f"{PORTS[1]}, e.g. {SCHEME}://HOST:8786"
)
#: What the bar of a Dask run shows until the first job finishes.
DASK_WAITING = "waiting for the first job to finish (workers compile the model on first use)…"
#: A host name or IPv4 address of a scheduler address (RFC 1123 lengths; '_' as resolvers allow).
_HOST = re.compile(
    r"(?=.{1,253}$)[A-Za-z0-9_](?:[A-Za-z0-9_-]{0,61}[A-Za-z0-9_])?"
    r"(?:\.[A-Za-z0-9_](?:[A-Za-z0-9_-]{0,61}[A-Za-z0-9_])?)*\.?"
)
# The largest first frame a Dask scheduler's handshake can plausibly have [bytes] (_probe).
_HANDSHAKE_BYTES = 1 << 24


def _short(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else f"{text[:limit]}…"


class SchedulerUnreachable(ConnectionError):
    """No Dask scheduler answers at the address given."""


def parse_scheduler(text: str) -> str:
    """Validate a ``--scheduler`` value; returns it normalised (``HOST:PORT`` -> ``tcp://...``).

    Raises ValueError naming the value and what is allowed.
    """
    if not isinstance(text, str):
        raise ValueError(f"scheduler = {text!r}; allowed: a string, {_ALLOWED}")
    text = text.strip()
    if text.startswith("local:"):
        count = text.partition(":")[2]
        if not count.isdigit() or not 1 <= int(count) <= MAX_LOCAL_WORKERS:
            raise ValueError(
                f"--scheduler {text!r}: local:N needs a whole number N of worker processes from "
                f"1 to {MAX_LOCAL_WORKERS}; allowed: {_ALLOWED}"
            )
        return f"local:{int(count)}"
    scheme, _, rest = text.rpartition("://")
    if scheme and scheme != SCHEME:
        raise ValueError(
            f"--scheduler {text!r}: the scheme {scheme + '://'!r} is not supported; allowed: "
            f"{_ALLOWED}"
        )
    match = re.fullmatch(r"(\[[0-9a-fA-F:]+\]|[^\s/:\[\]]+):(\d{1,6})", rest)
    if match is None:
        raise ValueError(f"--scheduler {text!r}; allowed: {_ALLOWED}")
    host, port = match.groups()
    if not host.startswith("[") and not _HOST.fullmatch(host):
        # The resolver refuses other names with a codec error ("label too long") or a NUL.
        raise ValueError(
            f"--scheduler {text!r}: {_short(host)!r} is not a host name (letters, digits, '-', "
            f"'.', '_'; labels of 1 to 63, at most 253 in all) nor an IP address; allowed: "
            f"{_ALLOWED}"
        )
    if not PORTS[0] <= int(port) <= PORTS[1]:
        raise ValueError(
            f"--scheduler {text!r}: port {int(port)} is outside {PORTS[0]} to {PORTS[1]}; "
            f"allowed: {_ALLOWED}"
        )
    return f"{SCHEME}://{host}:{int(port)}"


def executor_spec(scheduler: str | None, workers: int = 1) -> str | None:
    """The executor from ``scheduler`` and the shorthand ``workers=N`` (N > 1 means ``local:N``).

    ``workers=1`` (the default) leaves ``scheduler`` as given (None: serially, here).
    """
    if (
        isinstance(workers, bool)
        or not isinstance(workers, int)
        or not 1 <= workers <= MAX_LOCAL_WORKERS
    ):
        raise ValueError(
            f"workers = {workers!r}; allowed: an integer from 1 to {MAX_LOCAL_WORKERS} (N > 1 "
            "means local:N)"
        )
    if workers == 1:
        return None if scheduler is None else parse_scheduler(scheduler)
    if scheduler is not None:
        raise ValueError(
            f"workers = {workers} and scheduler = {scheduler!r}; give one (workers N is local:N)"
        )
    return f"local:{workers}"


@dataclass(frozen=True)
class JobFailure:
    """A job that raised: its key, label and the error's traceback."""

    key: str
    label: str
    error: str
    """``Type: message`` of the exception."""
    traceback: str

    def describe(self) -> str:
        return f"{self.label} (key {self.key}): {self.error}\n{self.traceback}".rstrip()


@dataclass(frozen=True)
class RunSummary:
    """How a call of :func:`run_jobs` went."""

    total: int
    """Distinct jobs asked for."""
    reused: int
    """Jobs whose records already existed (resumed)."""
    ran: int
    """Jobs run now (including failed ones)."""
    wall_time: float
    """Seconds spent [s]."""
    executor: str = "serial"
    """Where the jobs ran: ``serial``, ``local:N`` or the scheduler's address."""
    failures: tuple[JobFailure, ...] = field(default=())
    """Jobs that raised."""
    records: Mapping[str, Record] = field(default_factory=dict, repr=False, compare=False)
    """The record of every job that has one, by key: those reused (read once, to check them)
    and those run now (as saved, not read back)."""

    def to_dict(self) -> dict[str, Any]:
        """The run as the manifests record it."""
        return {
            "jobs": self.total,
            "ran": self.ran,
            "reused": self.reused,
            "executor": self.executor,
            "wall_time_s": round(self.wall_time, 1),
        }


class JobsFailed(RuntimeError):
    """Some jobs raised; the others finished and their records are stored."""

    def __init__(self, summary: RunSummary) -> None:
        self.summary = summary
        failures = summary.failures
        lines = [
            f"{len(failures)} of {summary.ran} optimisations failed (the others finished and "
            "their records are stored; rerun the same command to retry the failed ones):"
        ]
        lines += [f"--- {f.describe()}" for f in failures]
        super().__init__("\n".join(lines))


# The serial executor's live progress: what the job running now reports to (module level, so
# tests can wrap _harness_run(job) and still see progress).
_REPORTER: contextvars.ContextVar[Reporter | None] = contextvars.ContextVar(
    "harness_reporter", default=None
)


def _harness_run(job: PreparedJob) -> Record:
    """One harness call (module level so tests can count calls and workers can import it)."""
    return run_job(job, _REPORTER.get())


def _on_worker(job: PreparedJob) -> Record:
    """What a Dask worker runs: the harness call, with one numba thread per job.

    numba's thread count is per calling thread; a worker runs as many jobs at once as it has
    threads, so one numba thread each keeps a node's cores from being oversubscribed. A worker
    started with ``NUMBA_NUM_THREADS`` set keeps numba's default (that many) instead.
    """
    if "NUMBA_NUM_THREADS" not in os.environ:
        import numba

        numba.set_num_threads(1)
    return _harness_run(job)


Outcome = Record | JobFailure


def _failure(job: Job, error: BaseException, tb: Any) -> JobFailure:
    return JobFailure(
        key=job.key,
        label=job.label(),
        error=f"{type(error).__name__}: {error}",
        traceback="".join(traceback.format_exception(type(error), error, tb)),
    )


def _run_serially(todo: Sequence[PreparedJob], display: _Display) -> Iterator[tuple[Job, Outcome]]:
    for prepared in todo:
        job = prepared.job
        token = _REPORTER.set(display.reporter(job))
        try:
            outcome: Outcome = _harness_run(prepared)
        except Exception as error:
            outcome = _failure(job, error, error.__traceback__)
        finally:
            _REPORTER.reset(token)
        yield job, outcome


def _run_on_dask(client: Client, todo: Sequence[PreparedJob]) -> Iterator[tuple[Job, Outcome]]:
    from distributed import as_completed

    futures = {
        client.submit(
            _on_worker, p, key=f"{TASK_PREFIX}-{p.job.key}", priority=p.job.budget, retries=0
        ): p.job
        for p in todo
    }
    for future in as_completed(futures):
        job = futures[future]
        if future.status == "finished":
            outcome: Outcome = future.result()
        elif future.status == "error":
            outcome = _failure(job, future.exception(), future.traceback())
        else:  # cancelled: the scheduler went away or gave up on the task
            outcome = JobFailure(
                job.key, job.label(), f"task {future.status} by the Dask scheduler", ""
            )
        future.release()
        yield job, outcome


def _probe(address: str) -> None:
    """Check that a Dask scheduler answers at ``address`` within :data:`CONNECT_TIMEOUT`.

    Fails fast (connection refused) where the Dask client would retry until its timeout, and
    bounds what the client cannot: a Dask scheduler speaks first (its handshake, framed by an
    8-byte little-endian length), so a port that accepts but stays silent (an HTTP server
    waits for a request) is reported after the timeout instead of hanging the client, and one
    that answers with something else (its first bytes read as an absurd frame length) instead
    of making the client allocate that length.
    """
    host, port = address.removeprefix(f"{SCHEME}://").rsplit(":", 1)
    deadline = time.monotonic() + CONNECT_TIMEOUT
    advice = (
        "start one with `dask scheduler` and workers with `dask worker ADDRESS` "
        "(docs/scaling.md), or run here with --scheduler local:N"
    )
    try:
        conn = socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT)
    except OSError as error:  # refused, unknown host, or no answer to connect (TimeoutError)
        raise SchedulerUnreachable(
            f"no Dask scheduler answers at {address} ({error.strerror or error}); {advice}"
        ) from None
    head = b""
    with conn:
        try:
            while len(head) < 8:
                conn.settimeout(max(deadline - time.monotonic(), 1e-3))
                chunk = conn.recv(8 - len(head))
                if not chunk:
                    break
                head += chunk
        except TimeoutError:
            raise SchedulerUnreachable(
                f"{address} accepts connections but sent no Dask handshake within "
                f"{CONNECT_TIMEOUT:g} s: not a Dask scheduler (or a stalled one); {advice}"
            ) from None
        except OSError as error:
            raise SchedulerUnreachable(
                f"{address} dropped the connection ({error.strerror or error}) before a Dask "
                f"handshake: not a Dask scheduler; {advice}"
            ) from None
    if len(head) < 8:
        raise SchedulerUnreachable(
            f"{address} accepted the connection and closed it without a Dask handshake: not a "
            f"Dask scheduler; {advice}"
        )
    if not 0 < int.from_bytes(head, "little") <= _HANDSHAKE_BYTES:
        raise SchedulerUnreachable(
            f"{address} answers, but not with the Dask protocol (first bytes {head!r}): not a "
            f"Dask scheduler; {advice}"
        )


@contextlib.contextmanager
def _workers_ignore_interrupts() -> Iterator[None]:
    """Start worker processes that ignore Ctrl-C (SIGINT), so only this process handles it.

    A Ctrl-C in a terminal goes to the whole process group: the local workers would die at once
    and their nannies log tracebacks while this process closes the cluster in order. A process
    started while SIGINT is ignored inherits that (POSIX; Python then leaves it ignored).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def dask_client(scheduler: str, *, quiet: bool = False) -> Iterator[Client]:
    """A client of ``scheduler`` (``local:N`` or an address), closed (with its cluster) at exit.

    Raises :class:`SchedulerUnreachable` naming the address if no scheduler answers within
    :data:`CONNECT_TIMEOUT` seconds.
    """
    import logging

    from distributed import Client, LocalCluster

    spec = parse_scheduler(scheduler)
    with contextlib.ExitStack() as stack:
        if spec.startswith("local:"):
            with _workers_ignore_interrupts():
                cluster = LocalCluster(
                    n_workers=int(spec.partition(":")[2]),
                    threads_per_worker=1,
                    processes=True,
                    host="127.0.0.1",
                    dashboard_address="127.0.0.1:0",  # a free port (the dashboard needs bokeh)
                    # One numba thread per worker process (a job per core, see _on_worker).
                    env={"NUMBA_NUM_THREADS": "1"},
                    # The runner reports every failed job itself (key and traceback) and
                    # Dask reruns a dead worker's jobs: the cluster's own ERROR logs are noise
                    # then, e.g. a busy worker's heartbeat to a scheduler closed by Ctrl-C.
                    silence_logs=logging.CRITICAL,
                )
            stack.enter_context(cluster)
            client = stack.enter_context(Client(cluster))
        else:
            _probe(spec)
            try:
                client = stack.enter_context(Client(spec, timeout=CONNECT_TIMEOUT))
            except OSError as error:
                raise SchedulerUnreachable(
                    f"cannot connect to the Dask scheduler at {spec}: {error}"
                ) from None
        if not quiet:
            workers = len(client.scheduler_info().get("workers", {}))
            where = f"Dask scheduler {client.scheduler.address}, {workers} workers"
            if workers == 0:
                where += " (jobs wait until workers connect)"
            if dashboard_link := _dashboard(client):
                where += f", dashboard {dashboard_link}"
            print(where, file=sys.stderr)
        yield client


def _dashboard(client: Client) -> str | None:
    try:
        return client.dashboard_link if client.scheduler_info().get("services") else None
    except Exception:  # no dashboard service (bokeh missing)
        return None


@dataclass
class _Display:
    """One progress bar over the evaluations of all jobs: finished jobs, best so far, ETA."""

    jobs: Sequence[Job]
    enabled: bool
    done: int = 0
    evaluations: int = 0
    best: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        total = sum(j.budget for j in self.jobs)
        n = len(self.jobs)
        # On Dask the bar moves as jobs finish; serially, reporter() says what it waits for.
        self.bar = ProgressBar(
            total, f"{n} optimisation{'s' * (n != 1)}", self.enabled, waiting=DASK_WAITING
        )

    def reporter(self, job: Job) -> Reporter:
        """Live progress of a job running in this process."""
        if self.done == 0:
            self.bar.waiting()
        return lambda iteration, evaluations, best: self.bar.move_to(
            self.evaluations + min(evaluations, job.budget)
        )

    def finished(self, job: Job, outcome: Outcome) -> None:
        self.done += 1
        self.evaluations += job.budget
        if isinstance(outcome, Record) and outcome.feasible:
            series = " ".join([job.task, *(str(v) for k, v in job.env_kwargs if k == "objective")])
            if outcome.objective > self.best.get(series, -math.inf):
                self.best[series] = outcome.objective
        bests = ", ".join(f"{k} {v:.3g}" for k, v in sorted(self.best.items()))
        self.bar.move_to(
            self.evaluations, f"{self.done}/{len(self.jobs)} jobs; best feasible: {bests or '-'}"
        )

    def close(self) -> None:
        self.bar.close()


def run_jobs(
    jobs: Iterable[Job | PreparedJob],
    out_dir: str | os.PathLike[str],
    *,
    scheduler: str | None = None,
    progress: bool = True,
    rerun: bool = False,
) -> RunSummary:
    """Run every job that has no valid stored record yet; duplicates run once.

    ``scheduler`` chooses where (module docstring): None runs them here, one after another;
    ``"local:N"`` or a scheduler address runs them on Dask. The jobs to run are validated
    first, all of them before any runs (a :class:`~agents.harness.PreparedJob` is validated
    already; a job :func:`~agents.harness.prepare_job` rejects is a failure and does not run);
    they start largest budget first, so the workers stay busy to the end. Each record is stored
    as its job finishes, by this function alone. Raises :class:`JobsFailed` (after every other
    job has finished) if any job was rejected or raised, :class:`SchedulerUnreachable` if the
    scheduler does not answer, ValueError for a bad ``scheduler`` or an ``out_dir`` that is a
    file. ``rerun`` runs every job again, its record replacing the stored one (a trained
    policy's run folder may hold a newer model under the same name). The summary's
    ``records`` are the jobs' records, each read at most once.
    """
    executor = "serial" if scheduler is None else parse_scheduler(scheduler)
    start = time.perf_counter()
    store = RecordStore(out_dir)
    given = {_job_of(job).key: job for job in jobs}
    records: dict[str, Record] = {}
    for key, job in given.items():
        if not rerun and (record := store.load(_job_of(job))) is not None:
            records[key] = record
    missing = [job for key, job in given.items() if key not in records]
    failures: list[JobFailure] = []
    todo: list[PreparedJob] = []
    for job in missing:  # validated once, all before any runs; a rejected job is a failure
        try:
            todo.append(job if isinstance(job, PreparedJob) else prepare_job(job))
        except Exception as error:
            failures.append(_failure(_job_of(job), error, error.__traceback__))
    todo.sort(key=lambda p: -p.job.budget)
    if todo and (old := store.outdated(skip=given)):
        # Their keys hash the earlier format, so no job finds them: say so once (one at a
        # job's own key was reported by store.load).
        warnings.warn(
            f"{len(old)} record file(s) of an earlier format in {old[0].parent} (e.g. "
            f"{old[0].name}) are not used: the jobs they held run again in this format",
            RecordWarning,
            stacklevel=2,
        )
    with contextlib.ExitStack() as stack:
        client = None
        if todo and scheduler is not None:
            client = stack.enter_context(dask_client(executor, quiet=not progress))
        display = _Display([p.job for p in todo], progress and bool(todo))
        stack.callback(display.close)
        outcomes = _run_serially(todo, display) if client is None else _run_on_dask(client, todo)
        for job, outcome in outcomes:
            if isinstance(outcome, JobFailure):
                failures.append(outcome)
            elif outcome.key != job.key:
                failures.append(
                    JobFailure(job.key, job.label(), f"record has key {outcome.key!r}", "")
                )
            else:
                store.save(outcome)
                records[job.key] = outcome
            display.finished(job, outcome)
    summary = RunSummary(
        total=len(given),
        reused=len(given) - len(missing),
        ran=len(missing),
        wall_time=time.perf_counter() - start,
        executor=executor,
        failures=tuple(sorted(failures, key=lambda f: f.key)),
        records=records,
    )
    if failures:
        raise JobsFailed(summary)
    return summary


def _job_of(job: Job | PreparedJob) -> Job:
    return job.job if isinstance(job, PreparedJob) else job


def load_records(out_dir: str | os.PathLike[str], jobs: Iterable[Job]) -> dict[Job, Record]:
    """The records of ``jobs`` (all must have run); raises naming the first missing one."""
    store = RecordStore(out_dir)
    found: dict[Job, Record] = {}
    for job in jobs:
        record = store.load(job)
        if record is None:
            raise FileNotFoundError(
                f"no record for {job.label()} (key {job.key}) in "
                f"{Path(out_dir) / RECORDS_DIR}; run the study"
            )
        found[job] = record
    return found


def have_records(out_dir: str | os.PathLike[str], jobs: Iterable[Job]) -> bool:
    """Whether every job has a stored record with its current configuration."""
    store = RecordStore(out_dir)
    return all(store.load(job) is not None for job in jobs)
