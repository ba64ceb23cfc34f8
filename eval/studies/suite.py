"""Run studies: their jobs once, the analyses and the report; the paper's studies as a campaign of
the command line (:data:`SUITE`)."""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from agents.dask_cluster import executor_spec
from agents.progress import CommandProgress, Phase
from agents.record_cache import CacheOption
from agents.runner import PlanRun, RunSummary, find_records, run_plan
from agents.store import RecordStore
from eval.studies import PAPER_STUDIES, STUDIES, report
from eval.studies.base import StudyOutput, StudyPlan
from eval.studies.claims import VerdictCount
from eval.studies.paper_reading import DEFAULT
from eval.studies.readings.plan import reading_by_name
from tandem_env.io.files import write_json_atomic


@dataclass(frozen=True)
class SuiteResult:
    outputs: list[StudyOutput]
    """The studies asked for, analysed."""
    run: RunSummary
    report: Path | None
    wall_time: float
    """Seconds for the whole call, analysis included [s]."""


class SuitePlan:
    """The studies ``names`` (``all``: the paper's) as a plan of one phase, :attr:`phases`:
    all their jobs in one pool, shared optimisations run once; :meth:`finish` analyses them
    into ``out`` with every other paper study whose records are all there, so running ``speed``
    and then ``power`` into one folder gives one report with both."""

    def __init__(self, names: Sequence[str], plan: StudyPlan, out: Path) -> None:
        self.started = time.perf_counter()
        self.given = ", ".join(names)
        chosen = [n for name in names for n in (PAPER_STUDIES if name == "all" else [name])]
        if unknown := [name for name in chosen if name not in STUDIES]:
            raise ValueError(f"unknown study {unknown[0]!r}; allowed: all, {', '.join(STUDIES)}")
        self.asked = list(dict.fromkeys(chosen))
        self.plan, self.out = plan, out
        self.title = f"study {self.given} ({', '.join(self.asked)})"
        # each study's jobs, built once: the asked ones first, then the other paper studies
        studies = dict.fromkeys([*self.asked, *PAPER_STUDIES])
        self.jobs_of = {name: STUDIES[name].jobs(plan) for name in studies}
        jobs = tuple(job for name in self.asked for job in self.jobs_of[name])
        self.phases = [Phase(self.given, jobs)]

    def finish(self, run: PlanRun) -> SuiteResult:
        """Analyse the studies asked (and every other paper study whose records are all
        present), write the report and the manifest."""
        out = self.out
        done = {}
        for name, own in self.jobs_of.items():
            if name in self.asked:
                records = {job: run.records[job.key] for job in own}
            elif (records := find_records(out, own, cache=False)) is None:
                continue
            done[name] = STUDIES[name].analyse(self.plan, records, out)
        paper = [name for name in PAPER_STUDIES if name in done]
        summary = run.runs[self.given]
        path = None
        if paper:
            outputs = [done[n] for n in paper]
            path = report.write_report(out / "report.md", self.plan, outputs, list(PAPER_STUDIES))
            wall = round(time.perf_counter() - self.started, 1)  # the whole call's, analysis too
            last_run = {"studies": self.asked, **summary.to_dict(), "wall_time_s": wall}
            jobs = sorted({j.key for n in done for j in self.jobs_of[n]})
            manifest = {"preset": self.plan.preset.name, "methods": list(self.plan.methods)}
            manifest |= {"studies": paper, "jobs": jobs, "last_run": last_run}
            write_json_atomic(out / "manifest.json", manifest)
        wall = time.perf_counter() - self.started
        return SuiteResult([done[n] for n in self.asked], summary, path, wall)


def run_studies(
    names: Sequence[str],
    plan: StudyPlan,
    out_dir: str | os.PathLike[str] | RecordStore,
    *,
    scheduler: str | None = None,
    workers: int = 1,
    progress: bool = True,
    cache: CacheOption = True,
    rerun: bool = False,
    command: CommandProgress | None = None,
) -> SuiteResult:
    """Run the studies ``names`` (or ``["all"]``) into ``out_dir`` (:class:`SuitePlan`), reusing
    the stored records; ``workers=N > 1`` is short for ``scheduler="local:N"``; ``scheduler``,
    ``cache``, ``rerun`` and ``command`` as for :func:`~agents.runner.run_plan`."""
    store = RecordStore.at(out_dir)
    suite = SuitePlan(names, plan, store.directory)
    scheduler = executor_spec(scheduler, workers)
    done = run_plan(
        suite.phases, store, scheduler, cache, progress=progress, rerun=rerun, command=command
    )
    return suite.finish(done)


class SuiteCampaign:
    """The paper's studies on the command line (``all`` or one study; the report covers every
    paper study whose records are present)."""

    @property
    def names(self) -> tuple[str, ...]:
        """``all`` and every registered study (:data:`eval.studies.STUDIES`, read now)."""
        return ("all", *STUDIES)

    description = """\
  speed        level flight at each speed, optimised for efficiency (Figs. 4-6)
  power        accelerating flight at each available power, F̄_v and F̄_h (Figs. 7-8)
  kinematics   tip paths, φ, η, phase, angle of attack of the optimised strokes (Figs. 9-13)
  wing-shape   tear-drop vs real planform (Figs. 14-16)
  all          the four above (one pool; shared optimisations run once)
  convergence  the budget study (PSO and CMA-ES) the presets' methods and budgets come from"""
    default_out = os.path.join("results", "study")
    reading_help = (
        "all and each paper study: run it under this one reading (paper, a single, or singles "
        "joined by '+'; docs/reproduction.md, Readings)"
    )
    options: Mapping[str, dict[str, Any]] = {}

    def plan(self, args: argparse.Namespace, plan: StudyPlan, out: RecordStore) -> SuitePlan:
        """The study ``args.study`` under its ``--reading`` (ValueError naming a bad one)."""
        if args.reading and len(args.reading) > 1:
            raise ValueError(f"study {args.study!r} runs under one --reading, got {args.reading}")
        reading = reading_by_name(args.reading[0]) if args.reading else DEFAULT
        if args.budget is not None and reading.search is not None:
            raise ValueError(
                f"--budget {args.budget}: the reading {reading.name!r} runs its own search "
                f"({reading.search.describe()}); allowed: --budget or that reading"
            )
        return SuitePlan([args.study], replace(plan, reading=reading), out.directory)

    def report(self, args: argparse.Namespace, result: SuiteResult) -> None:
        """Print what the run did (stderr) and found (stdout)."""
        run = result.run
        done = f"{run.describe(args.out)} ({run.executor}); {result.wall_time:.1f} s"
        print(f"{run.total} optimisations: {done}", file=sys.stderr)
        for output in result.outputs:
            median, best = (VerdictCount.of(output.claims, best=b).text() for b in (False, True))
            claims = f"; claims on the median: {median}; on the best seed: {best}"
            counts = f"{len(output.rows)} records, {len(output.figures)} figures"
            print(f"{output.name}: {counts}{claims if output.claims else ''}")
        if result.report is not None:
            print(f"report: {result.report}")


#: The paper studies' campaign (:data:`eval.study.CAMPAIGNS`).
SUITE = SuiteCampaign()
