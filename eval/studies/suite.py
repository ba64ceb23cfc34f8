"""Run studies: gather their jobs, run the missing ones once, analyse, write the report; the
paper's studies as a campaign of the command line (:data:`SUITE`)."""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from agents.dask_cluster import executor_spec
from agents.jobs import Job
from agents.progress import CommandProgress, Phase
from agents.record_cache import CacheOption
from agents.runner import RunSummary, have_records, job_records, run_jobs
from eval.studies import PAPER_STUDIES, STUDIES, report
from eval.studies.base import StudyOutput, StudyPlan
from eval.studies.claims import VerdictCount
from eval.studies.paper_reading import DEFAULT, Reading
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


def expand(names: Sequence[str]) -> list[str]:
    """``all`` -> the paper's studies; otherwise the names, validated, duplicates dropped."""
    chosen = [n for name in names for n in (PAPER_STUDIES if name == "all" else [name])]
    for name in chosen:
        if name not in STUDIES:
            raise ValueError(f"unknown study {name!r}; allowed: all, {', '.join(STUDIES)}")
    return list(dict.fromkeys(chosen))


def run_studies(
    names: Sequence[str],
    plan: StudyPlan,
    out_dir: str | os.PathLike[str],
    *,
    scheduler: str | None = None,
    workers: int = 1,
    progress: bool = True,
    cache: CacheOption = True,
    command: CommandProgress | None = None,
) -> SuiteResult:
    """Run the studies ``names`` (or ``["all"]``) into ``out_dir``.

    All their jobs go into one run (shared optimisations run once) on ``scheduler`` (None:
    serially here; ``"local:N"``; a Dask scheduler's address; see
    :func:`agents.runner.run_jobs`); ``workers=N > 1`` is short for
    ``scheduler="local:N"``. Finished jobs from an earlier, killed or partial run with the same
    configuration are reused. The report covers every paper study whose records are all
    present, so running ``speed`` and then ``power`` into one directory gives one report with
    both. ``cache`` is the record cache and ``command`` the command's progress, as for
    :func:`~agents.runner.run_jobs`.
    """
    start = time.perf_counter()
    out = Path(out_dir)
    scheduler = executor_spec(scheduler, workers)
    asked = expand(names)
    # each study's jobs, built once: the asked ones first, then the other paper studies
    jobs_of = {name: STUDIES[name].jobs(plan) for name in dict.fromkeys([*asked, *PAPER_STUDIES])}
    jobs = [job for name in asked for job in jobs_of[name]]
    summary = run_jobs(
        jobs, out, scheduler=scheduler, progress=progress, cache=cache, command=command
    )
    # the studies asked, and every other paper study whose records are all present
    done = {
        name: STUDIES[name].analyse(plan, job_records(out, own), out)
        for name, own in jobs_of.items()
        if name in asked or have_records(out, own)
    }
    paper = [name for name in PAPER_STUDIES if name in done]
    report_path = None
    if paper:
        wall = time.perf_counter() - start
        report_path = report.write_report(
            out / "report.md", plan, [done[n] for n in paper], list(PAPER_STUDIES)
        )
        write_json_atomic(
            out / "manifest.json",
            {
                "preset": plan.preset.name,
                "methods": list(plan.methods),
                "studies": paper,
                "jobs": sorted({j.key for n in done for j in jobs_of[n]}),
                "last_run": {
                    "studies": asked,
                    **summary.to_dict(),
                    "wall_time_s": round(wall, 1),  # the whole call's, analysis included
                },
            },
        )
    return SuiteResult([done[n] for n in asked], summary, report_path, time.perf_counter() - start)


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
    refuse_read_only = False

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """No options of its own."""

    def misused(self, args: argparse.Namespace) -> str | None:
        return None

    def reading(self, args: argparse.Namespace) -> Reading:
        if not args.reading:
            return DEFAULT
        if len(args.reading) > 1:
            raise ValueError(f"study {args.study!r} runs under one --reading, got {args.reading}")
        return reading_by_name(args.reading[0])

    def first_jobs(self, args: argparse.Namespace, plan: StudyPlan) -> tuple[list[Job], str]:
        names = expand([args.study])
        jobs = [job for name in names for job in STUDIES[name].jobs(plan)]
        return jobs, f"study {args.study} ({', '.join(names)})"

    def plan_phases(
        self, args: argparse.Namespace, plan: StudyPlan, command: CommandProgress
    ) -> None:
        """One phase: every job of the studies asked for, in one pool."""
        jobs, _ = self.first_jobs(args, plan)
        command.plan([Phase(args.study, tuple(jobs))])

    def run(
        self,
        args: argparse.Namespace,
        plan: StudyPlan,
        scheduler: str | None,
        command: CommandProgress,
    ) -> SuiteResult:
        return run_studies(
            [args.study],
            plan,
            args.out,
            scheduler=scheduler,
            progress=not args.quiet,
            cache=args.cache,
            command=command,
        )

    def summarise(self, args: argparse.Namespace, result: SuiteResult) -> None:
        run = result.run
        print(
            f"{run.total} optimisations: {run.describe(args.out)} ({run.executor}); "
            f"{result.wall_time:.1f} s",
            file=sys.stderr,
        )
        for output in result.outputs:
            claims = (
                f"; claims on the median: {VerdictCount.of(output.claims).text()}; on the best "
                f"seed: {VerdictCount.of(output.claims, best=True).text()}"
                if output.claims
                else ""
            )
            print(
                f"{output.name}: {len(output.rows)} records, {len(output.figures)} figures{claims}"
            )
        if result.report is not None:
            print(f"report: {result.report}")


#: The paper studies' campaign (:data:`eval.studies.campaigns.CAMPAIGNS`).
SUITE = SuiteCampaign()
