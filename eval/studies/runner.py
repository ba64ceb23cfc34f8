"""Run a set of harness jobs once each, in parallel, resumably.

A :class:`Job` is one harness run: one method, task, condition, budget and seed, with its env
keywords and method settings. Its :attr:`Job.key` hashes all of that plus the preset name and
the package version, and its record is stored as ``DIR/records/<key>.json`` (the harness
record with the job added, written atomically). So

* a killed run resumes: a job whose record file exists (and names the same job) is not run
  again;
* a changed configuration (budget, seeds, env keywords, model options, preset, package version)
  gives new keys, so old records are never mixed in: analyses load exactly the records of the
  jobs they ask for, and stale files in the directory are ignored;
* the same command gives the same numbers: every job is seeded and runs alone, so neither the
  order nor the number of workers changes a result.

Jobs run in this process, one after another, with numba's default threads (``workers=1``,
the default), or in a ``spawn`` process pool whose workers use one numba thread each (so the
cores are not oversubscribed). On the 2-core machine the two are within 10 % of each other, the
serial mode slightly ahead (2 730 against 2 550-2 680 evaluations/s on 8 × 12 000-evaluation
optimisations, ``python -m eval.studies.bench_workers``), so serial is the default; the pool is
for machines with more cores than numba's threads use well at the PSO's batch of 40 strokes.
"""

from __future__ import annotations

import hashlib
import json
import math
import multiprocessing
import os
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

from tqdm.auto import tqdm

import tandem_env
from agents.records import read_json, write_json_atomic
from agents.run_record import SCHEMA, Record

Task = Literal["level", "accelerate"]
RECORDS_DIR = "records"


@dataclass(frozen=True)
class Job:
    """One harness run (one seed) and everything that decides its result."""

    method: str
    """Harness method spec, e.g. ``"pso"``, ``"random"``, ``"policy:runs/ppo"``."""
    task: Task
    condition: float
    """Flight speed [m/s] (level) or available power [W/kg] (accelerate)."""
    budget: int
    """Model evaluations."""
    seed: int
    env_kwargs: tuple[tuple[str, Any], ...] = ()
    """Env keywords besides the condition, sorted by name (objective, planform, options)."""
    method_config: tuple[tuple[str, Any], ...] = ()
    """Method settings, sorted by name (e.g. ``swarm_size``)."""
    preset: str = ""
    """The preset the job belongs to (part of the key, so presets never share records)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "condition", float(self.condition))
        object.__setattr__(self, "env_kwargs", tuple(sorted(self.env_kwargs)))
        object.__setattr__(self, "method_config", tuple(sorted(self.method_config)))

    def to_dict(self) -> dict[str, Any]:
        """JSON form (tuples become lists); what the key hashes, besides the version."""
        out = asdict(self)
        out["env_kwargs"] = {k: v for k, v in self.env_kwargs}
        out["method_config"] = {k: v for k, v in self.method_config}
        return out

    @property
    def key(self) -> str:
        """Configuration hash: the job, the preset, the tandem_env version and record format."""
        payload = {**self.to_dict(), "tandem_env": tandem_env.__version__, "record": SCHEMA}
        text = json.dumps(payload, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:20]

    def env(self, name: str, default: Any = None) -> Any:
        """One env keyword (``objective``, ``planform``, ...) or ``default``."""
        return dict(self.env_kwargs).get(name, default)

    def label(self) -> str:
        """Short human label, e.g. ``pso level V=1.5 seed 0``."""
        unit = "V=" if self.task == "level" else "P="
        extra = [str(v) for k, v in self.env_kwargs if k in ("objective", "planform")]
        return " ".join(
            [self.method, self.task, *extra, f"{unit}{self.condition:g}", f"seed {self.seed}"]
        )


@dataclass(frozen=True)
class JobOutcome:
    """What a finished job reports back to the progress display."""

    key: str
    objective: float
    feasible: bool
    wall_time: float


def record_path(out_dir: Path, job: Job) -> Path:
    return out_dir / RECORDS_DIR / f"{job.key}.json"


def load_record(out_dir: Path, job: Job) -> Record | None:
    """The stored record of ``job``, or None if it has not run with this configuration."""
    path = record_path(out_dir, job)
    if not path.exists():
        return None
    try:
        data = read_json(path)
        # Guards against a truncated hash colliding or a hand-edited file: the stored job must
        # be this job exactly.
        if data.get("study_job") != json.loads(json.dumps(job.to_dict(), default=str)):
            return None
        return Record.from_dict(data)
    except (OSError, ValueError, TypeError):
        return None


def _harness_run(job: Job) -> Record:
    """One harness call (module level so tests can count calls)."""
    from agents.harness import run

    (record,) = run(
        job.method,
        job.task,
        job.condition,
        job.budget,
        [job.seed],
        env_kwargs=dict(job.env_kwargs),
        method_config=dict(job.method_config),
        progress=False,
    )
    return record


def run_job(job: Job, out_dir: str) -> JobOutcome:
    """Run one job through the harness and store its record atomically."""
    record = _harness_run(job)
    data = record.to_dict()
    data["study_job"] = job.to_dict()
    data["study_key"] = job.key
    write_json_atomic(record_path(Path(out_dir), job), data)
    return JobOutcome(job.key, record.objective, record.feasible, record.wall_time)


def _init_worker() -> None:
    # One numba thread per process: with as many processes as cores, extra threads only
    # oversubscribe the cores (and numba's threading at batch 40 costs more than it gains).
    import numba

    numba.set_num_threads(1)


@dataclass
class _Display:
    """Progress over jobs: evaluations done, conditions done, best so far, time left."""

    jobs: Sequence[Job]
    enabled: bool
    done: int = 0
    best: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        total = sum(j.budget for j in self.jobs)
        self.bar = (
            tqdm(
                total=total,
                unit="eval",
                unit_scale=True,
                desc=f"{len(self.jobs)} optimisations",
                file=sys.stderr,
                dynamic_ncols=True,
                mininterval=1.0,
            )
            if self.enabled
            else None
        )

    def finished(self, job: Job, outcome: JobOutcome) -> None:
        self.done += 1
        series = " ".join([job.task, *(str(v) for k, v in job.env_kwargs if k == "objective")])
        if outcome.feasible and outcome.objective > self.best.get(series, -math.inf):
            self.best[series] = outcome.objective
        if self.bar is not None:
            bests = ", ".join(f"{k} {v:.3g}" for k, v in sorted(self.best.items()))
            self.bar.set_postfix_str(
                f"{self.done}/{len(self.jobs)} done; best feasible: {bests or '-'}", refresh=False
            )
            self.bar.update(job.budget)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


@dataclass(frozen=True)
class RunSummary:
    """How a call of :func:`run_jobs` went."""

    total: int
    """Distinct jobs asked for."""
    reused: int
    """Jobs whose records already existed (resumed)."""
    ran: int
    """Jobs run now."""
    wall_time: float
    """Seconds spent [s]."""


def run_jobs(
    jobs: Iterable[Job],
    out_dir: str | os.PathLike[str],
    *,
    workers: int = 1,
    progress: bool = True,
    runner: Callable[[Job, str], JobOutcome] = run_job,
) -> RunSummary:
    """Run every job that has no stored record yet; duplicates run once.

    ``workers > 1`` uses a spawn process pool with one numba thread per worker; ``workers ==
    1`` runs in this process. Jobs are started largest budget first so the pool stays busy to
    the end.
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers = {workers!r}; allowed: an integer >= 1")
    start = time.perf_counter()
    out = Path(out_dir)
    unique = list({job.key: job for job in jobs}.values())
    todo = [job for job in unique if load_record(out, job) is None]
    todo.sort(key=lambda j: -j.budget)
    display = _Display(todo, progress and bool(todo))
    try:
        if workers == 1 or len(todo) <= 1:
            for job in todo:
                display.finished(job, runner(job, str(out)))
        else:
            context = multiprocessing.get_context("spawn")
            with ProcessPoolExecutor(
                max_workers=min(workers, len(todo)), mp_context=context, initializer=_init_worker
            ) as pool:
                pending = {pool.submit(runner, job, str(out)): job for job in todo}
                while pending:
                    finished, _ = wait(pending, return_when=FIRST_COMPLETED)
                    for future in finished:
                        job = pending.pop(future)
                        display.finished(job, future.result())
    finally:
        display.close()
    return RunSummary(
        total=len(unique),
        reused=len(unique) - len(todo),
        ran=len(todo),
        wall_time=time.perf_counter() - start,
    )


def load_records(out_dir: str | os.PathLike[str], jobs: Iterable[Job]) -> dict[Job, Record]:
    """The records of ``jobs`` (all must have run); raises naming the first missing one."""
    out = Path(out_dir)
    found: dict[Job, Record] = {}
    for job in jobs:
        record = load_record(out, job)
        if record is None:
            raise FileNotFoundError(
                f"no record for {job.label()} (key {job.key}) in {out / RECORDS_DIR}; run the study"
            )
        found[job] = record
    return found


def have_records(out_dir: str | os.PathLike[str], jobs: Iterable[Job]) -> bool:
    """Whether every job has a stored record with its current configuration."""
    out = Path(out_dir)
    return all(load_record(out, job) is not None for job in jobs)
