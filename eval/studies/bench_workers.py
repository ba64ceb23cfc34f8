"""Measure a study preset serially and on Dask, and the speed-up its job lengths allow.

    python -m eval.studies.bench_workers [--preset quick] [--scheduler local:2] [--repeat 1]

Runs ``study all``'s optimisations for the preset serially and on ``--scheduler`` (alternating,
``--repeat`` times) and prints the wall times, the job lengths and the best speed-up W workers
can give (:func:`makespan`), measured and estimated for every preset (docs/scaling.md)."""

from __future__ import annotations

import argparse
import heapq
import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from agents.dask_cluster import parse_scheduler
from agents.jobs import Job
from agents.records import Record
from agents.runner import run_jobs
from eval.studies import PAPER_STUDIES
from eval.studies.base import StudyPlan
from eval.studies.presets import STUDY_PRESETS, get_preset

WORKERS: tuple[int, ...] = (1, 2, 4, 8, 16, 32, 64, 128)


def makespan(durations: Sequence[float], workers: int) -> float:
    """Wall time of ``durations`` [s] on ``workers`` when each job, in the given order, goes
    to the worker that is free first (list scheduling; no start-up or transfer costs)."""
    free = [0.0] * workers
    for duration in durations:
        heapq.heappush(free, heapq.heappop(free) + duration)
    return max(free)


def seconds_per_evaluation(records: Mapping[Job, Record]) -> dict[str, float]:
    """Per task (sorted): the median seconds per model evaluation of the jobs' records [s]."""
    rates = lambda task: [r.wall_time / j.budget for j, r in records.items() if j.task == task]  # noqa: E731
    return {task: float(np.median(rates(task))) for task in sorted({j.task for j in records})}


def _suite_jobs(plan: StudyPlan) -> list[Job]:
    """Every optimisation of ``study all`` under ``plan``, each once."""
    return list({j.key: j for s in PAPER_STUDIES.values() for j in s.jobs(plan)}.values())


def _speedups(name: str, durations: Sequence[float]) -> None:
    total = sum(durations)
    best = {w: total / makespan(durations, w) for w in WORKERS}
    cells = ", ".join(f"{w}: {b:.1f}x ({b / w:.0%})" for w, b in best.items())
    print(f"{name}, {len(durations)} jobs, {total:.0f} s serial; at most {cells}")


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", choices=tuple(STUDY_PRESETS), default="quick")
    parser.add_argument("--scheduler", default="local:2", type=parse_scheduler)
    parser.add_argument("--repeat", type=int, default=1, help="runs of each mode (alternating)")
    args = parser.parse_args(argv)
    jobs = _suite_jobs(StudyPlan(get_preset(args.preset)))
    evaluations = sum(j.budget for j in jobs)
    print(f"preset {args.preset}: {len(jobs)} optimisations, {evaluations} evaluations")
    serial = None
    with tempfile.TemporaryDirectory(prefix="bench_workers_", ignore_cleanup_errors=True) as root:
        for attempt in range(args.repeat):
            for scheduler in (None, args.scheduler):
                name = f"{scheduler or 'serial'}-{attempt}".replace(":", "_").replace("/", "")
                out = Path(root) / name
                start = time.perf_counter()
                summary = run_jobs(jobs, out, scheduler=scheduler, progress=False, cache=False)
                seconds = time.perf_counter() - start
                rate = f"{evaluations / seconds:.0f} evaluations/s"
                print(f"{scheduler or 'serial'}: {seconds:.1f} s = {rate}", flush=True)
                serial = serial or summary
    assert serial is not None
    ordered = sorted(jobs, key=lambda j: -j.budget)  # the runner's order
    times = {j: serial.records[j.key] for j in ordered}
    durations = [times[j].wall_time for j in ordered]
    for task in sorted({j.task for j in jobs}):
        own = [times[j].wall_time for j in jobs if j.task == task]
        budget = sorted({j.budget for j in jobs if j.task == task})
        q = np.percentile(own, [0, 25, 50, 75, 100])
        lengths = f"min {q[0]:.2f}, quartiles {q[1]:.2f} / {q[2]:.2f} / {q[3]:.2f}, max {q[4]:.2f}"
        print(f"{task} ({len(own)} jobs, budget {budget}): job length [s] {lengths}")
    per_eval = seconds_per_evaluation(times)
    print(f"measured: {durations and sum(durations):.1f} s of jobs (serial)")
    _speedups(f"{args.preset} (measured)", durations)
    for name, preset in STUDY_PRESETS.items():
        others = sorted(_suite_jobs(StudyPlan(preset)), key=lambda j: -j.budget)
        _speedups(f"{name} (estimated)", [per_eval[j.task] * j.budget for j in others])


if __name__ == "__main__":
    main()
