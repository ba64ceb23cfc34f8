"""``python -m eval study readings``: the readings study as a campaign of the command line
(:class:`eval.studies.campaigns.Campaign`): its ``--continuation`` option, its first phase and
its run in phases (:mod:`eval.studies.readings`)."""

from __future__ import annotations

import argparse
import sys

from agents.harness import prepare_job
from agents.jobs import Job
from agents.progress import CommandProgress
from eval.studies.base import StudyPlan
from eval.studies.claims import VerdictCount
from eval.studies.paper_reading import DEFAULT, Reading
from eval.studies.readings.plan import (
    DEFAULT_OUT,
    NAME,
    SINGLES,
    Continuation,
    ReadingsResult,
    reading_jobs,
    single_readings,
)
from eval.studies.readings.run import COMBINATIONS_LATER, planned_phases, run_readings
from tandem_env.physics import N_PARAMETERS


def continuation_option(text: str) -> Continuation | None:
    """``--continuation``: a share in (0, 1], or none."""
    if text.strip().lower() == "none":
        return None
    try:
        share = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a number; allowed: a share of the budget in (0, 1], or none to run "
            "every reading in full"
        ) from None
    try:
        return Continuation(share=share)
    except ValueError as error:
        raise argparse.ArgumentTypeError(
            f"{error} (got {text!r}; or none to run every reading in full)"
        ) from None


def check_continuation(plan: StudyPlan, continuation: Continuation) -> None:
    """Prepare the continued job of every configuration the default's jobs have (method,
    budget, settings) as the harness will, before any work: a share whose continued budget no
    method can run (below one population, or a part without evaluations) is refused now, not
    by every continued job after the default's phase has run. ValueError naming the share."""
    jobs = {(j.method, j.budget, j.method_config): j for j in reading_jobs(plan, DEFAULT)}
    placeholder = [[0.0] * N_PARAMETERS]  # the default's optima are not known yet
    for job in jobs.values():
        continued = continuation.job(job, placeholder)
        try:
            prepare_job(continued)
        except ValueError as error:
            raise ValueError(
                f"--continuation {continuation.share:g}: a continued {job.method} job "
                f"({continued.budget} of its {job.budget} evaluations, from the default's "
                f"optimum) cannot run: {error}; allowed: a share (and method) whose continued "
                "jobs run, or --continuation none to run every reading in full"
            ) from None


class ReadingsCampaign:
    """The readings study on the command line."""

    names = (NAME,)
    description = """\
  readings     the four paper studies under each reading of the paper's open decisions (the
               default, each decision changed alone, the combinations those results point
               to): readings.csv, a claims × readings matrix, report.md (default out
               results/readings)"""
    default_out = DEFAULT_OUT
    reading_help = (
        "readings study: run these single readings (repeat; the default is always "
        f"run; allowed: {', '.join(r.name for r in SINGLES)})"
    )
    refuse_read_only = True

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "--continuation",
            type=continuation_option,
            default=Continuation(),
            metavar="SHARE|none",
            help="readings study only: the other readings continue from the default's optima "
            f"on SHARE of the budget (default {Continuation().share:g}; docs/reproduction.md, "
            "Readings); none runs every reading in full",
        )

    def misused(self, args: argparse.Namespace) -> str | None:
        if args.continuation != Continuation():
            return f"--continuation is for the readings study only (study {args.study!r})"
        return None

    def reading(self, args: argparse.Namespace) -> Reading:
        return DEFAULT  # the readings are the study's own

    def first_jobs(self, args: argparse.Namespace, plan: StudyPlan) -> tuple[list[Job], str]:
        chosen = single_readings(args.reading)
        singles = f"{len(chosen) - 1} single reading{'s' * (len(chosen) != 2)}"
        if args.continuation is None:
            jobs = [job for r in chosen for job in reading_jobs(plan, r)]
            return jobs, f"readings study (the default and {singles})"
        check_continuation(plan, args.continuation)
        return reading_jobs(plan, DEFAULT), (
            f"readings study (the default in full; {singles} continuing from its optima on "
            f"{args.continuation.share:g} of the budget, a task the bias check fails in full)"
        )

    def plan_phases(
        self, args: argparse.Namespace, plan: StudyPlan, command: CommandProgress
    ) -> None:
        """The phases before the combinations (:func:`planned_phases`), then those."""
        phases = planned_phases(
            plan, args.out, single_readings(args.reading), args.continuation, args.cache
        )
        command.plan(phases, later=COMBINATIONS_LATER)

    def run(
        self,
        args: argparse.Namespace,
        plan: StudyPlan,
        scheduler: str | None,
        command: CommandProgress,
    ) -> ReadingsResult:
        return run_readings(
            plan,
            args.out,
            readings=single_readings(args.reading),
            scheduler=scheduler,
            progress=not args.quiet,
            continuation=args.continuation,
            cache=args.cache,
            command=command,
        )

    def summarise(self, args: argparse.Namespace, result: ReadingsResult) -> None:
        for phase, run in zip(result.phases, result.runs, strict=True):
            print(
                f"{phase}: {run.total} optimisations: {run.describe(args.out)} "
                f"({run.executor}); {run.wall_time:.1f} s",
                file=sys.stderr,
            )
        for r in result.results:
            print(f"{r.reading.name}: {VerdictCount.of(r.claims).text()}")
        print(f"best: {result.best.reading.name} ({result.best.agree} claims agree)")
        print(f"combinations: {result.combination_rule}")
        print(f"report: {result.files[-1]}; total {result.wall_time:.1f} s")


#: The readings study's campaign (:data:`eval.studies.campaigns.CAMPAIGNS`).
READINGS = ReadingsCampaign()
