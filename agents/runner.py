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

The record cache (``cache``, on by default; ``--no-cache`` on the command line) is a store
shared by every output folder (:func:`agents.store.cache_directory`): a job with no record in
``--out`` but one in the cache is not run, its record is copied into ``--out`` (and counted as
reused, "from the cache"), and every record computed (or found in ``--out`` alone) is written to
the cache too. An entry that is not a valid record of its job is ignored with a
:class:`~agents.records.RecordWarning` and recomputed. A job whose method takes a path
(``policy:RUN_DIR``) is never cached: its result depends on files its key does not hash.

A command of several phases (the readings study) says its whole cost up front and at each
phase's start through one :class:`CommandProgress` passed to each of its :func:`run_jobs`
calls.
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
from agents.store import (
    RECORDS_DIR,
    SUMMARY_NAME,
    RecordStore,
    StoreWriteError,
    cache_directory,
)
from tandem_env.io.progress_bar import ProgressBar, QuietStream, Reporter

if TYPE_CHECKING:
    from distributed import Client

__all__ = [
    "CacheOption",
    "CommandProgress",
    "JobFailure",
    "JobsFailed",
    "OutputNotWritable",
    "Phase",
    "RunSummary",
    "SchedulerUnreachable",
    "dask_client",
    "executor_spec",
    "find_records",
    "have_records",
    "job_records",
    "parse_scheduler",
    "record_cache",
    "run_jobs",
    "set_worker_numba_threads",
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
    """Jobs whose records already existed (resumed), in ``--out`` or the record cache."""
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
    cached: int = 0
    """Of the reused jobs, those whose records came from the record cache."""

    def to_dict(self) -> dict[str, Any]:
        """The run as the manifests record it."""
        return {
            "jobs": self.total,
            "ran": self.ran,
            "reused": self.reused,
            "cached": self.cached,
            "executor": self.executor,
            "wall_time_s": round(self.wall_time, 1),
        }

    def describe(self, out_dir: str | os.PathLike[str]) -> str:
        """``N run, M reused from OUT`` (with those reused from the cache), as the commands'
        last lines say it."""
        parts = [f"{self.ran} run"]
        if self.reused > self.cached or not self.cached:
            parts.append(f"{self.reused - self.cached} reused from {out_dir}")
        if self.cached:
            parts.append(f"{self.cached} reused from the cache")
        return ", ".join(parts)


class OutputNotWritable(ValueError):
    """The output folder is a file (or under one), or cannot be written while some jobs have no
    record there: nothing ran (:func:`run_jobs` with ``summary_csv``)."""


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


def set_worker_numba_threads() -> None:
    """On a Dask worker, before its job: one numba thread for the calling thread's job.

    numba's thread count is per calling thread; a worker runs as many jobs at once as it has
    threads, so one numba thread each keeps a node's cores from being oversubscribed. A worker
    started with ``NUMBA_NUM_THREADS`` set keeps numba's default (that many) instead. The
    runner's jobs and the crosscheck's solver runs (``eval.crosscheck.store``) both call it.
    """
    if "NUMBA_NUM_THREADS" not in os.environ:
        import numba

        numba.set_num_threads(1)


def _on_worker(job: PreparedJob) -> Record:
    """What a Dask worker runs: the harness call, with one numba thread per job
    (:func:`set_worker_numba_threads`)."""
    set_worker_numba_threads()
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


@dataclass(frozen=True)
class Phase:
    """One phase of a command of several (:class:`CommandProgress`): its jobs as known now."""

    name: str
    jobs: tuple[Job, ...]
    provisional: frozenset[str] = frozenset()
    """Keys of jobs that stand in for ones an earlier phase's results decide (their budgets are
    right, their keys not final: a continued job's start): counted as to run."""


def _duration(seconds: float) -> str:
    if seconds < 1:
        return "under 1 s"
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 90 * 60:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


class CommandProgress:
    """The whole cost of a command of several phases, each a :func:`run_jobs` call: its jobs,
    how many are stored in ``--out`` or the record cache and how many run, their model
    evaluations and the time left, said on one line before any work (:meth:`announce`) and
    again at each phase's start (:meth:`start`), on stderr (nothing when not ``enabled``).

    The time left is the evaluations left at the rate this command has measured so far (the
    jobs it ran, over the wall time they took, compilation included); before its first job
    finishes it says "estimating". A phase whose jobs follow from an earlier one's results is
    planned with stand-ins (:class:`Phase`) and re-planned (:meth:`plan`) when it starts;
    ``later`` says what no plan can count yet (the readings study's combinations). ``detail``
    follows the title on the first line (the preset and methods).
    """

    def __init__(
        self,
        title: str,
        out_dir: str | os.PathLike[str],
        *,
        cache: CacheOption = True,
        enabled: bool = True,
        detail: str = "",
    ) -> None:
        self.title = title
        self.name = title.partition(" (")[0]
        """The title less its parenthesis, as the phase lines name the command."""
        self.detail = detail
        self.out_dir = out_dir
        self._store = RecordStore(out_dir)
        self._cache = record_cache(cache)
        self.enabled = enabled
        self._phases: dict[str, Phase] = {}
        self._later = ""
        self._done: set[str] = set()
        self._evaluations = 0
        self._seconds = 0.0
        self.lines: list[str] = []
        """Every line said, in order (what a test or a log reads)."""

    def plan(self, phases: Iterable[Phase], later: str | None = None) -> None:
        """Set these phases' jobs (a phase of the same name is replaced, a new one added after
        the others); ``later`` replaces what is said of the work no phase counts yet."""
        for phase in phases:
            self._phases[phase.name] = phase
        if later is not None:
            self._later = later

    def counts(self) -> dict[str, int]:
        """The command's jobs (each key once) by state: ``done`` (run by this command),
        ``stored`` (in ``--out``), ``cached`` (in the record cache), ``todo`` (to run; also
        every stand-in), with ``evaluations`` (all jobs) and ``todo_evaluations``."""
        jobs: dict[str, tuple[Job, bool]] = {}
        for phase in self._phases.values():
            for job in phase.jobs:
                provisional = job.key in phase.provisional
                if job.key not in jobs or not provisional:
                    jobs[job.key] = (job, provisional)
        counts = dict.fromkeys(("done", "stored", "cached", "todo"), 0)
        counts |= {"evaluations": 0, "todo_evaluations": 0}
        for key, (job, provisional) in jobs.items():
            counts["evaluations"] += job.budget
            if key in self._done:
                state = "done"
            elif provisional:
                state = "todo"
            elif self._store.path(key).exists():
                state = "stored"
            elif self._cache is not None and _cacheable(job) and self._cache.path(key).exists():
                state = "cached"
            else:
                state = "todo"
            counts[state] += 1
            if state == "todo":
                counts["todo_evaluations"] += job.budget
        return counts

    def time_left(self, evaluations: int) -> str:
        """``evaluations`` at the rate measured so far, in words."""
        if evaluations == 0:
            return "none"
        if self._evaluations == 0 or self._seconds <= 0:
            return "estimating (from the speed of the first jobs to finish)"
        rate = self._evaluations / self._seconds
        return (
            f"about {_duration(evaluations / rate)} (at the {rate:,.0f} evaluations/s "
            "measured so far)"
        )

    def _jobs(self) -> dict[str, Job]:
        return {job.key: job for phase in self._phases.values() for job in phase.jobs}

    def _left(self, c: Mapping[str, int]) -> str:
        text = f"{c['todo']} to run ({c['todo_evaluations']:,} evaluations)"
        if self._later:
            text += f"; then {self._later}"
        return f"{text}; time left: {self.time_left(c['todo_evaluations'])}"

    def _say(self, line: str) -> None:
        self.lines.append(line)
        if self.enabled:
            stream = QuietStream()
            stream.write(line + "\n")
            stream.flush()

    def announce(self) -> None:
        """The first line: the whole command before any work (its phases, jobs, seeds, budgets,
        what is stored in ``--out`` or the cache, what runs, and the time left)."""
        c = self.counts()
        jobs = self._jobs().values()
        seeds = sorted({job.seed for job in jobs})
        budgets = " / ".join(f"{b:,}" for b in sorted({job.budget for job in jobs}))
        count = len(self._phases)
        phases = f"{count} phases ({', '.join(self._phases)}): " if count > 1 else ""
        self._say(
            f"{self.title}: {self.detail + '; ' if self.detail else ''}{phases}"
            f"{len(jobs)} optimisations over seeds {seeds}, budgets {budgets} model evaluations "
            f"each ({c['evaluations']:,} in all); {c['stored']} stored in {self.out_dir}, "
            f"{c['cached']} in the record cache, {self._left(c)}"
        )

    def start(self, name: str) -> None:
        """The line at the start of phase ``name`` (after :meth:`plan` gave its jobs); none for
        the first phase, which the first line has just announced."""
        names = list(self._phases)
        place = names.index(name) + 1 if name in names else len(names)
        if place == 1:
            return
        c = self.counts()
        finished = c["done"] + c["stored"] + c["cached"]
        self._say(
            f"phase {place}/{len(names)} ({name}) of the {self.name}: "
            f"{len(self._jobs())} optimisations ({c['evaluations']:,} evaluations), "
            f"{finished} done or stored, {self._left(c)}"
        )

    def ran(self, job: Job, seconds: float) -> None:
        """A job :func:`run_jobs` finished, after ``seconds`` of wall time since the previous
        one (or the call's start) [s]."""
        self._done.add(job.key)
        self._evaluations += job.budget
        self._seconds += seconds


CacheOption = bool | str | os.PathLike[str] | None
"""The record cache a call uses: True its folder (:func:`agents.store.cache_directory`), a path
another folder, False or None none."""


def record_cache(cache: CacheOption = True) -> RecordStore | None:
    """The record cache as a store (None when off); ValueError if its folder is a file."""
    if cache is None or cache is False:
        return None
    directory = cache_directory() if cache is True else cache
    try:
        return RecordStore(directory)
    except ValueError as error:
        raise ValueError(f"record cache: {error} (or turn the cache off: --no-cache)") from None


def _cacheable(job: Job) -> bool:
    # A method that takes a path (policy:RUN_DIR) reads files its key does not hash.
    return ":" not in job.method


class _Cache:
    """The record cache of one :func:`run_jobs` call: read through the store's checks, written
    through its atomic save; a cache that cannot be written is said once and then left alone
    (the records are in ``--out``)."""

    def __init__(self, store: RecordStore | None) -> None:
        self.store = store

    def load(self, job: Job) -> Record | None:
        if self.store is None or not _cacheable(job):
            return None
        return self.store.load(job)

    def save(self, record: Record, *, unless_present: bool = False) -> None:
        store = self.store
        if store is None or not _cacheable(record.job):
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


def run_jobs(
    jobs: Iterable[Job | PreparedJob],
    out_dir: str | os.PathLike[str],
    *,
    scheduler: str | None = None,
    progress: bool = True,
    rerun: bool = False,
    cache: CacheOption = True,
    command: CommandProgress | None = None,
    summary_csv: bool = False,
) -> RunSummary:
    """Run every job that has no valid stored record yet; duplicates run once.

    ``scheduler`` chooses where (module docstring): None runs them here, one after another;
    ``"local:N"`` or a scheduler address runs them on Dask. The jobs to run are validated
    first, all of them before any runs (a :class:`~agents.harness.PreparedJob` is validated
    already; a job :func:`~agents.harness.prepare_job` rejects is a failure and does not run);
    they start largest budget first, so the workers stay busy to the end. Each record is stored
    as its job finishes, by this function alone. Raises :class:`JobsFailed` (after every other
    job has finished) if any job was rejected or raised, :class:`SchedulerUnreachable` if the
    scheduler does not answer, ValueError for a bad ``scheduler`` or an ``out_dir`` (or cache
    folder) that is a file. ``rerun`` runs every job again, its record replacing the stored one
    (a trained policy's run folder may hold a newer model under the same name). The summary's
    ``records`` are the jobs' records, each read at most once.

    ``cache`` is the record cache (module docstring; :data:`CacheOption`): a job with no record
    in ``out_dir`` takes the cache's, copied into ``out_dir``; every record computed is written
    to both. ``command`` is the whole command's progress (:class:`CommandProgress`), told of
    every job this call finishes.

    ``summary_csv`` (``python -m eval optimize``) also keeps ``out_dir``'s ``summary.csv``
    over every record there, rewritten when the call ends (also after a failure or an
    interrupt; :meth:`~agents.store.RecordStore.write_summary`, the records of this call
    not read again). The store's paths are checked first, once its records are read and before
    any other work: :class:`OutputNotWritable` naming the path and what is allowed for a file
    where a folder goes, or a folder that cannot be written while a job has no record there;
    one that cannot be written but holds every job is used as it is, its summary left as it
    is (said on stderr).
    """
    executor = "serial" if scheduler is None else parse_scheduler(scheduler)
    start = time.perf_counter()
    try:
        store = RecordStore(out_dir)
    except ValueError as error:
        if not summary_csv:
            raise
        raise OutputNotWritable(str(error)) from None
    shared = _Cache(record_cache(cache))
    given = {_job_of(job).key: job for job in jobs}
    records: dict[str, Record] = {}
    for key, job in given.items():
        if not rerun and (record := store.load(_job_of(job))) is not None:
            records[key] = record
    writable = not summary_csv or _check_output(store, given, records)
    try:
        return _run(given, records, store, shared, executor, start, progress, command, rerun)
    finally:
        if summary_csv:
            _write_summary(store, records, writable)


def _check_output(
    store: RecordStore, given: Mapping[str, Job | PreparedJob], stored: Mapping[str, Record]
) -> bool:
    """Whether ``store`` can be written (its folder, records, summary and the jobs' record
    files); :class:`OutputNotWritable` naming the path and why if it cannot and a job is not
    ``stored`` there."""
    jobs = [_job_of(job) for job in given.values()]
    try:
        writable = store.check(write=False, jobs=jobs)
        if not writable and set(given) - set(stored):
            store.check(jobs=jobs)  # raises, naming the folder and why
    except ValueError as error:
        raise OutputNotWritable(str(error)) from None
    return writable


def _write_summary(store: RecordStore, records: Mapping[str, Record], writable: bool) -> None:
    """Rewrite ``store``'s summary over every record there (``records`` not read again), or say
    why it is left as it is."""
    if writable and store.directory.exists():
        store.write_summary(records)
    elif not writable:
        print(
            f"{store.directory} cannot be written: every seed is stored there, "
            f"{SUMMARY_NAME} is left as it is",
            file=sys.stderr,
        )


def _run(
    given: Mapping[str, Job | PreparedJob],
    records: dict[str, Record],
    store: RecordStore,
    shared: _Cache,
    executor: str,
    start: float,
    progress: bool,
    command: CommandProgress | None,
    rerun: bool,
) -> RunSummary:
    """:func:`run_jobs` once the stored ``records`` are read: the record cache's copied, the
    others run; ``records`` gains every record found or made."""
    cached = 0
    for key, job in given.items():
        if rerun:
            break
        if key in records:
            shared.save(records[key], unless_present=True)  # a store made before the cache feeds it
        elif (record := shared.load(_job_of(job))) is not None:
            store.save(record)  # the store's one atomic write: a copy, checksum and all
            records[key] = record
            cached += 1
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
            stacklevel=3,
        )
    with contextlib.ExitStack() as stack:
        client = None
        if todo and executor != "serial":
            client = stack.enter_context(dask_client(executor, quiet=not progress))
        display = _Display([p.job for p in todo], progress and bool(todo))
        stack.callback(display.close)
        outcomes = _run_serially(todo, display) if client is None else _run_on_dask(client, todo)
        running = time.perf_counter()
        for job, outcome in outcomes:
            if isinstance(outcome, JobFailure):
                failures.append(outcome)
            elif outcome.key != job.key:
                failures.append(
                    JobFailure(job.key, job.label(), f"record has key {outcome.key!r}", "")
                )
            else:
                store.save(outcome)
                shared.save(outcome)
                records[job.key] = outcome
            display.finished(job, outcome)
            now = time.perf_counter()
            if command is not None and isinstance(outcome, Record):
                command.ran(job, now - running)
            running = now
    summary = RunSummary(
        total=len(given),
        reused=len(given) - len(missing),
        ran=len(missing),
        wall_time=time.perf_counter() - start,
        executor=executor,
        failures=tuple(sorted(failures, key=lambda f: f.key)),
        records=records,
        cached=cached,
    )
    if failures:
        raise JobsFailed(summary)
    return summary


def _job_of(job: Job | PreparedJob) -> Job:
    return job.job if isinstance(job, PreparedJob) else job


def job_records(out_dir: str | os.PathLike[str], jobs: Iterable[Job]) -> dict[Job, Record]:
    """The records of ``jobs`` in the store ``out_dir`` (all must have run); raises naming the
    first missing one."""
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


def find_records(
    out_dir: str | os.PathLike[str], jobs: Iterable[Job], cache: CacheOption = True
) -> dict[Job, Record] | None:
    """The records of ``jobs`` as :func:`run_jobs` would find them (``out_dir`` first, then the
    record cache), writing nothing and warning of nothing; None if any is missing (a plan
    that looks ahead: those jobs still have to run)."""
    stores = [RecordStore(out_dir)]
    if (shared := record_cache(cache)) is not None:
        stores.append(shared)
    found: dict[Job, Record] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordWarning)  # said by run_jobs, when it runs them
        for job in jobs:
            for store in stores if _cacheable(job) else stores[:1]:
                if store.path(job.key).exists() and (record := store.load(job)) is not None:
                    found[job] = record
                    break
            else:
                return None
    return found


def have_records(out_dir: str | os.PathLike[str], jobs: Iterable[Job]) -> bool:
    """Whether every job has a stored record with its current configuration."""
    store = RecordStore(out_dir)
    return all(store.load(job) is not None for job in jobs)
