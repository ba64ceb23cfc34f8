"""``python -m eval study readings``: the readings study as a campaign of the command line
(:data:`eval.study.CAMPAIGNS`): its ``--continuation`` option, its plan and its
report (:mod:`eval.studies.readings`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping
from typing import Any

from agents.harness import prepare_job
from agents.store import RecordStore
from eval.studies.base import StudyPlan
from eval.studies.claims import VerdictCount
from eval.studies.paper_reading import DEFAULT
from eval.studies.readings.plan import (
    DEFAULT_OUT,
    NAME,
    SINGLES,
    Continuation,
    ReadingsResult,
    reading_jobs,
    single_readings,
)
from eval.studies.readings.run import ReadingsPlan


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
    for job in jobs.values():
        continued = continuation.job(job, None)  # the default's optima are not known yet
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
    options: Mapping[str, dict[str, Any]] = {
        "--continuation": {
            "type": continuation_option,
            "default": Continuation(),
            "metavar": "SHARE|none",
            "help": "readings study only: the other readings continue from the default's "
            f"optima on SHARE of the budget (default {Continuation().share:g}; "
            "docs/reproduction.md, Readings); none runs every reading in full",
        }
    }

    def plan(self, args: argparse.Namespace, plan: StudyPlan, out: RecordStore) -> ReadingsPlan:
        """The study of the readings ``--reading`` names (ValueError, before any work, for a
        bad one or a share whose continued jobs cannot run)."""
        chosen = single_readings(args.reading)
        singles = f"{len(chosen) - 1} single reading{'s' * (len(chosen) != 2)}"
        title = f"readings study (the default and {singles})"
        if args.continuation is not None:
            check_continuation(plan, args.continuation)
            title = (
                f"readings study (the default in full; {singles} continuing from its optima on "
                f"{args.continuation.share:g} of the budget, a task the bias check fails in full)"
            )
        return ReadingsPlan(
            plan, out, chosen, args.continuation, progress=not args.quiet, title=title
        )

    def report(self, args: argparse.Namespace, result: ReadingsResult) -> None:
        """Print what the run did (stderr) and found (stdout)."""
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


#: The readings study's campaign (:data:`eval.study.CAMPAIGNS`).
READINGS = ReadingsCampaign()
