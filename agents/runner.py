"""The runner: a plan's phases of jobs run once each, resumably, here or on Dask.

A plan (:data:`Plan`, :func:`run_plan`) yields phases (:class:`~agents.progress.Phase`) of
keyed jobs computed from the records of the phases before it; :func:`run_jobs` runs one list.
Each record is kept in the output's :class:`~agents.store.RecordStore` under its job's key
(the hash of its configuration and the package version), so a killed run resumes and neither
order, executor nor worker count changes a result (docs/harness.md, "The record and the
store"). Jobs are validated all before any runs (:func:`agents.harness.prepare_job`); this
process alone writes the records, as each job finishes; a job that raises is reported with its
key and traceback after the others finish (:class:`JobsFailed`).
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import os
import sys
import time
import traceback
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import tandem_env
from agents.dask_cluster import dask_client, parse_scheduler
from agents.harness import PreparedJob, prepare_job, run_job
from agents.jobs import Job, Work
from agents.progress import CommandProgress, Phase
from agents.record_cache import CacheOption, CacheWriter, cacheable, record_cache
from agents.records import Record, RecordWarning
from agents.store import RECORDS_DIR, SUMMARY_NAME, RecordStore
from agents.verify import refuted
from tandem_env.io.progress_bar import ProgressBar, Reporter

if TYPE_CHECKING:
    from distributed import Client


#: Prefix of the Dask task keys (``harness-<job key>``; the dashboard groups tasks by it).
TASK_PREFIX = "harness"
#: What the bar of a Dask run shows until the first job finishes.
DASK_WAITING = "waiting for the first job to finish (workers compile the model on first use)…"


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
    """The record of every job that has one, by key (reused ones read once, new ones as saved)."""
    cached: int = 0
    """Of the reused jobs, those whose records came from the record cache."""
    replaced: int = 0
    """Of the jobs run, those whose record in ``--out`` was replaced (``rerun``)."""
    noun: str = "optimisation"
    """What the jobs are (:attr:`agents.jobs.Work.noun`)."""

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
        """``N run, M reused from OUT`` (and from the cache), the commands' last line."""
        parts = [f"{self.ran} run"]
        if self.replaced:
            parts[0] += f" again (--rerun: {self.replaced} record(s) in {out_dir} replaced)"
        if self.reused > self.cached or not self.cached:
            parts.append(f"{self.reused - self.cached} reused from {out_dir}")
        if self.cached:
            parts.append(f"{self.cached} reused from the cache")
        return ", ".join(parts)


class OutputNotWritable(ValueError):
    """The output folder is a file, or cannot be written while some jobs have no record
    there: nothing ran (:func:`run_jobs` with ``summary_csv``)."""


class JobsFailed(RuntimeError):
    """Some jobs raised; the others finished and their records are stored."""

    def __init__(self, summary: RunSummary) -> None:
        self.summary = summary
        head = (
            f"{len(summary.failures)} of {summary.ran} {summary.noun}s failed (the others finished"
            " and their records are stored; rerun the same command to retry the failed ones):"
        )
        super().__init__("\n--- ".join([head, *(f.describe() for f in summary.failures)]))


# The serial executor's live progress: what the job running now reports to.
_REPORTER: contextvars.ContextVar[Reporter | None] = contextvars.ContextVar(
    "harness_reporter", default=None
)


def _harness_run(job: PreparedJob | Work) -> Record:
    """One harness call, or a job of another kind run (module level: workers import it)."""
    return run_job(job, _REPORTER.get()) if isinstance(job, PreparedJob) else job.compute()


def _on_worker(job: PreparedJob | Work) -> Record:
    """What a Dask worker runs: the harness call, with one numba thread for the calling
    thread's job (a worker runs a job per thread, so cores are not oversubscribed), unless the
    worker was started with ``NUMBA_NUM_THREADS`` set."""
    if "NUMBA_NUM_THREADS" not in os.environ:
        import numba

        numba.set_num_threads(1)
    return _harness_run(job)


Outcome = Record | JobFailure
#: A job as the runner takes it: the harness's (prepared or not) or another kind's.
Given = Job | PreparedJob | Work


def _failure(job: Job | Work, error: BaseException, tb: Any) -> JobFailure:
    trace = "".join(traceback.format_exception(type(error), error, tb))
    return JobFailure(job.key, job.label(), f"{type(error).__name__}: {error}", trace)


def _run_serially(
    todo: Sequence[PreparedJob | Work], display: _Display
) -> Iterator[tuple[Job | Work, Outcome]]:
    for prepared in todo:
        job = _job_of(prepared)
        token = _REPORTER.set(display.reporter(job))
        try:
            outcome: Outcome = _harness_run(prepared)
        except Exception as error:
            outcome = _failure(job, error, error.__traceback__)
        finally:
            _REPORTER.reset(token)
        yield job, outcome


def _run_on_dask(
    client: Client, todo: Sequence[PreparedJob | Work]
) -> Iterator[tuple[Job | Work, Outcome]]:
    from distributed import as_completed

    jobs = [_job_of(p) for p in todo]
    futures = {
        client.submit(_on_worker, p, key=f"{TASK_PREFIX}-{j.key}", priority=j.budget, retries=0): j
        for p, j in zip(todo, jobs, strict=True)
    }
    for future in as_completed(futures):
        job = futures[future]
        if future.status == "finished":
            outcome: Outcome = future.result()
        elif future.status == "error":
            outcome = _failure(job, future.exception(), future.traceback())
        else:  # cancelled: the scheduler went away or gave up on the task
            why = f"task {future.status} by the Dask scheduler"
            outcome = JobFailure(job.key, job.label(), why, "")
        future.release()
        yield job, outcome


@dataclass
class _Display:
    """One progress bar over the evaluations of all jobs: finished jobs, best so far, ETA."""

    jobs: Sequence[Job | Work]
    enabled: bool
    done: int = 0
    evaluations: int = 0
    best: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        total, n = sum(j.budget for j in self.jobs), len(self.jobs)
        noun = getattr(self.jobs[0], "noun", "optimisation") if self.jobs else ""
        # On Dask the bar moves as jobs finish; serially, reporter() says what it waits for.
        label = f"{n} {noun}{'s' * (n != 1)}"
        self.bar = ProgressBar(total, label, self.enabled, waiting=DASK_WAITING)

    def reporter(self, job: Job | Work) -> Reporter:
        """Live progress of a job running in this process."""
        if self.done == 0:
            self.bar.waiting()
        return lambda i, done, b: self.bar.move_to(self.evaluations + min(done, job.budget))

    def finished(self, job: Job | Work, outcome: Outcome) -> None:
        self.done += 1
        self.evaluations += job.budget
        if isinstance(job, Job) and isinstance(outcome, Record) and outcome.feasible:
            series = " ".join([job.task, *(str(v) for k, v in job.env_kwargs if k == "objective")])
            self.best[series] = max(self.best.get(series, -math.inf), outcome.objective)
        bests = ", ".join(f"{k} {v:.3g}" for k, v in sorted(self.best.items()))
        best = f"; best feasible: {bests or '-'}" if isinstance(job, Job) else ""
        self.bar.move_to(self.evaluations, f"{self.done}/{len(self.jobs)} jobs{best}")


def run_jobs(
    jobs: Iterable[Given],
    out_dir: str | os.PathLike[str] | RecordStore,
    *,
    scheduler: str | None = None,
    progress: bool = True,
    rerun: bool = False,
    cache: CacheOption = True,
    command: CommandProgress | None = None,
    summary_csv: bool = False,
) -> RunSummary:
    """Run every job (the harness's or another :class:`~agents.jobs.Work` kind's) that has no valid
    stored record yet, duplicates once, largest budget first.

    ``scheduler``: None runs here, one job after another, else :mod:`agents.dask_cluster`'s.
    ``rerun`` runs every job again, replacing its record. ``cache``
    (:data:`~agents.record_cache.CacheOption`): a job without a record in ``out_dir`` takes the
    cache's; every record computed goes to both. A reused record is re-evaluated first: one its
    stroke does not reproduce (:func:`agents.verify.refuted`) is said in a
    :class:`~agents.records.RecordWarning` and run again. ``command`` is told of every job finished.
    ``summary_csv`` rewrites ``out_dir``'s ``summary.csv`` when the call ends (after a failure too),
    the store's paths checked first (:class:`OutputNotWritable`; a store that cannot be written but
    holds every job is used as it is). Raises :class:`JobsFailed` after the other jobs finished if
    any job was rejected or raised, :class:`~agents.dask_cluster.SchedulerUnreachable`, and
    ValueError for a bad ``scheduler`` or an ``out_dir`` (or cache folder) that is a file. The
    summary's ``records`` are the jobs' records, each read at most once.
    """
    executor = "serial" if scheduler is None else parse_scheduler(scheduler)
    start = time.perf_counter()
    try:
        store = RecordStore.at(out_dir)
    except ValueError as error:
        if not summary_csv:
            raise
        raise OutputNotWritable(str(error)) from None
    shared = CacheWriter(record_cache(cache))
    given = {_job_of(job).key: job for job in jobs}
    records: dict[str, Record] = {}  # those in out_dir, then those copied from the cache
    cached: dict[str, Record] = {}
    for key, job in ({} if rerun else given).items():
        if (record := store.load(_job_of(job))) is not None:
            records[key] = record
        elif (record := shared.load(_job_of(job))) is not None:
            cached[key] = record
    reused = {k: r for k, r in {**records, **cached}.items() if isinstance(r, Record)}
    for key, why in refuted(reused, given).items():
        # never served: said, its job run again, its file replaced by the new record
        stored = records.pop(key, None) is not None
        cached.pop(key, None)
        path = store.path(key) if stored or shared.store is None else shared.store.path(key)
        message = f"{path}: {why}; it is not used and its job runs again"
        warnings.warn(message, RecordWarning, stacklevel=2)
    replaced = sum(store.path(key).exists() for key in given) if rerun else 0
    writable = True
    if summary_csv:  # every path checked before any work; one that cannot be written is
        jobs = [_job_of(job) for job in given.values()]  # refused unless it holds every job
        try:
            writable = store.check(write=False, jobs=jobs)
            if not writable and set(given) - set(records):
                store.check(jobs=jobs)  # raises, naming the folder and why
        except ValueError as error:
            raise OutputNotWritable(str(error)) from None
    try:
        for record in records.values():
            shared.save(record, unless_present=True)  # a store made before the cache feeds it
        for key, record in cached.items():
            store.save(record)  # the store's one atomic write: a copy, checksum and all
            records[key] = record
        missing = [job for key, job in given.items() if key not in records]
        failures: list[JobFailure] = []
        todo: list[PreparedJob | Work] = []
        for job in missing:  # validated once, all before any runs; a rejected job is a failure
            try:
                todo.append(prepare_job(job) if isinstance(job, Job) else job)
            except Exception as error:
                failures.append(_failure(_job_of(job), error, error.__traceback__))
        todo.sort(key=lambda p: -_job_of(p).budget)
        # their keys hash the earlier format, so no job finds them: said once (one at a job's
        # own key was reported by store.load)
        if todo and (old := store.outdated(skip=given)):
            message = (
                f"{len(old)} record file(s) of an earlier format in {old[0].parent} (e.g. "
                f"{old[0].name}) are not used: the jobs they held run again in this format"
            )
            warnings.warn(message, RecordWarning, stacklevel=2)
        # Records of an earlier model sit under the keys it gave them (Job.key_at; None: before
        # keys held the revision): no job finds them; said once per store.
        revisions = (None, *range(1, tandem_env.physics.MODEL_REVISION))
        earlier = [
            job.key_at(tandem_env.__version__, model)
            for job in map(_job_of, missing)
            if isinstance(job, Job) and not rerun
            for model in revisions
        ]
        for held in (store, shared.store):
            if old := [p for key in earlier if held is not None and (p := held.path(key)).exists()]:
                message = (
                    f"{len(old)} record file(s) in {old[0].parent} (e.g. {old[0].name}) were made "
                    "by an earlier model (tandem_env.physics.MODEL_REVISION): not used, their "
                    "jobs run again (the files are kept)"
                )
                warnings.warn(message, RecordWarning, stacklevel=2)
        with contextlib.ExitStack() as stack:
            client = None
            if todo and executor != "serial":
                client = stack.enter_context(dask_client(executor, quiet=not progress))
            display = _Display([_job_of(p) for p in todo], progress and bool(todo))
            stack.callback(display.bar.close)
            outcomes = (
                _run_serially(todo, display) if client is None else _run_on_dask(client, todo)
            )
            running = time.perf_counter()
            for job, outcome in outcomes:
                if isinstance(outcome, JobFailure):
                    failures.append(outcome)
                elif outcome.key != job.key:
                    wrong = f"record has key {outcome.key!r}"
                    failures.append(JobFailure(job.key, job.label(), wrong, ""))
                else:
                    store.save(outcome)
                    shared.save(outcome)
                    records[job.key] = outcome
                display.finished(job, outcome)
                now = time.perf_counter()
                if command is not None and isinstance(outcome, Record):
                    command.ran(job, now - running)
                running = now
        noun = next((getattr(_job_of(j), "noun", "optimisation") for j in given.values()), "")
        counts = (len(given), len(given) - len(missing), len(missing))  # total, reused, ran
        failed = tuple(sorted(failures, key=lambda f: f.key))
        end = (time.perf_counter() - start, executor, failed, records)
        summary = RunSummary(*counts, *end, len(cached), replaced, noun)
        if failures:
            raise JobsFailed(summary)
        return summary
    finally:
        if summary_csv and not writable:
            kept = f"every seed is stored there, {SUMMARY_NAME} is left as it is"
            print(f"{store.directory} cannot be written: {kept}", file=sys.stderr)
        elif summary_csv and store.directory.exists():
            store.write_summary(records)


def _job_of(job: Given) -> Job | Work:
    return job.job if isinstance(job, PreparedJob) else job


Out = str | os.PathLike[str] | RecordStore
"""An output folder, or its store (a command builds it once: :meth:`RecordStore.at`)."""


def job_records(out_dir: Out, jobs: Iterable[Job]) -> dict[Job, Record]:
    """The records of ``jobs`` in the store ``out_dir`` (all must have run); raises naming the
    first missing one."""
    store = RecordStore.at(out_dir)
    found: dict[Job, Record] = {}
    for job in jobs:
        if (record := store.load(job)) is None:
            raise FileNotFoundError(
                f"no record for {job.label()} (key {job.key}) in "
                f"{store.directory / RECORDS_DIR}; run the study"
            )
        found[job] = record
    return found


def find_records(
    out_dir: Out, jobs: Iterable[Job], cache: CacheOption = True
) -> dict[Job, Record] | None:
    """The records of ``jobs`` as :func:`run_jobs` would find them (``out_dir``, then the
    record cache), writing and warning nothing; None if any is missing."""
    stores = [s for s in (RecordStore.at(out_dir), record_cache(cache)) if s is not None]
    found: dict[Job, Record] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordWarning)  # said by run_jobs, when it runs them
        for job in jobs:
            for store in stores if cacheable(job) else stores[:1]:
                if store.path(job.key).exists() and (record := store.load(job)) is not None:
                    found[job] = record
                    break
            else:
                return None
    return found


@dataclass
class Lookup:
    """What a plan's next phases follow from: the records of some jobs, from the run so far
    (:attr:`running`) or, in a look-ahead, as far as the stores hold them (:func:`find_records`)."""

    store: RecordStore
    cache: CacheOption = True
    records: dict[str, Record] | None = None
    """The records of the run so far; None in a look-ahead, which runs and writes nothing."""

    @property
    def running(self) -> bool:
        """Whether the phases run (a plan analyses and says its results only then)."""
        return self.records is not None

    def __call__(self, jobs: Iterable[Job]) -> dict[Job, Record] | None:
        """The records of ``jobs`` (every one's, when running), or None."""
        if self.records is None:
            return find_records(self.store, jobs, self.cache)
        jobs = list(jobs)
        missing = [job for job in jobs if job.key not in self.records]
        self.records |= {job.key: r for job, r in job_records(self.store, missing).items()}
        return {job: self.records[job.key] for job in jobs}


Plan = Callable[[Lookup], Iterator[Phase]]
"""Resumable work in phases (:func:`run_plan`): called with a :class:`Lookup`, it yields each
phase once the records before it can be looked up. Phases that do not depend on records are
given as data instead, a sequence of :class:`Phase`."""


def look_ahead(plan: Plan | Sequence[Phase], out: Out, cache: CacheOption = True) -> list[Phase]:
    """``plan``'s phases as far as the records in ``out`` and the record cache decide them now,
    stand-ins after that (the cost line's; nothing runs or is written)."""
    return list(plan if isinstance(plan, Sequence) else plan(Lookup(RecordStore.at(out), cache)))


@dataclass(frozen=True)
class PlanRun:
    """How a call of :func:`run_plan` went."""

    runs: dict[str, RunSummary]
    """Each phase's :func:`run_jobs` call, by phase name, in order."""
    records: dict[str, Record]
    """Every record the phases found or made, by key."""
    wall_time: float
    """Seconds spent [s]."""


def run_plan(
    plan: Plan | Sequence[Phase],
    out: Out,
    scheduler: str | None = None,
    cache: CacheOption = True,
    *,
    progress: bool = True,
    rerun: bool = False,
    command: CommandProgress | None = None,
    summary_csv: bool = False,
) -> PlanRun:
    """Run ``plan``'s phases in order into the store ``out``, each in one :func:`run_jobs`
    call (the options as there); a killed run resumes phase by phase. ``command`` says each
    phase's start with the command's cost again; ``rerun`` runs every job again once."""
    start = time.perf_counter()
    store = RecordStore.at(out)
    found = Lookup(store, cache, {})
    runs: dict[str, RunSummary] = {}
    started: list[Phase] = []
    for phase in plan if isinstance(plan, Sequence) else plan(found):
        started.append(phase)
        if command is not None and len(started) > 1:
            command.start(look_ahead(plan, store, cache), started)
        assert found.records is not None
        jobs = [job for job in phase.jobs if not (rerun and job.key in found.records)]
        options = {"scheduler": scheduler, "progress": progress, "rerun": rerun, "cache": cache}
        runs[phase.name] = run_jobs(
            jobs, store, command=command, summary_csv=summary_csv, **options
        )
        found.records |= runs[phase.name].records
    return PlanRun(runs, found.records, time.perf_counter() - start)
