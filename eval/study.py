"""``python -m eval study``: run the paper's studies (figures, tables, report) on the harness."""

from __future__ import annotations

import argparse
import os
import sys
import textwrap
from collections.abc import Sequence
from pathlib import Path

from agents.harness import prepare_job
from agents.jobs import Job
from agents.methods import get_method
from agents.runner import executor_spec, have_records
from agents.store import RecordStore
from eval.figures import FORMATS
from eval.optimize import (
    add_backend_arguments,
    add_insect_argument,
    add_scheduler_argument,
    backend_kwargs,
    run_reporting,
)
from eval.studies import STUDIES, readings
from eval.studies.base import StudyPlan
from eval.studies.claims import FLIP_THRESHOLD, VerdictCount
from eval.studies.presets import PRESETS, get_preset
from eval.studies.suite import expand, run_studies
from tandem_env.physics import N_PARAMETERS
from tandem_env.physics.insect import DRAGONFLY, describe_insect, load_insect

NAME = "study"
HELP = "reproduce the paper's figures: speed/power sweeps, kinematics, wing shape, report"
DESCRIPTION = (
    f"""\
Run the reproduction studies of Faisal & Filippone (2016) on the evaluation harness and
write, per study, the records (JSON), a tidy CSV, a summary CSV and paper-style figures (PNG;
--format svg or pdf), and DIR/report.md: every claim of the paper beside ours (median [IQR]
over seeds, best seed) with an explicit agreement rule, judged on the median and on the best
seed; a verdict that a bootstrap over the seeds flips in more than
{100 * FLIP_THRESHOLD:.0f} % of resamples is "undecided"; a claim about what the model does
not depend on under the options run (the fore/hind phase, K1-K3, under the default mean
slipstream) is "not identifiable".

Studies:
  speed        level flight at each speed, optimised for efficiency (Figs. 4-6)
  power        accelerating flight at each available power, F̄_v and F̄_h (Figs. 7-8)
  kinematics   tip paths, φ, η, phase, angle of attack of the optimised strokes (Figs. 9-13)
  wing-shape   tear-drop vs real planform (Figs. 14-16)
  all          the four above (one pool; shared optimisations run once)
  convergence  the budget study (PSO and CMA-ES) the presets' methods and budgets come from
  readings     the four paper studies under each reading of the paper's open decisions (the
               default, each decision changed alone, the combinations those results point
               to): readings.csv, a claims × readings matrix, report.md (default out
               results/readings)

Presets:
"""
    + "\n".join(
        textwrap.fill(
            p.description, 92, initial_indent=f"  {p.name:<12} ", subsequent_indent=" " * 15
        )
        for p in PRESETS.values()
    )
    + """

A killed run resumes: finished optimisations are recognised by their configuration hash and
not run again; a changed configuration never reuses old records.

The optimisations run here, one after another (default), or on Dask: --scheduler local:N
starts N worker processes here, --scheduler tcp://HOST:PORT uses a running Dask scheduler
and its workers, e.g. on a SLURM/PBS cluster (docs/scaling.md). The numbers and the report
are the same either way."""
)
EPILOG = """\
examples:
  python -m eval study all                       # quick preset into results/study
  python -m eval study all --preset paper --out results/study-paper
  python -m eval study speed --method cmaes --method pso --out results/study
  python -m eval study all --preset paper --scheduler tcp://scheduler-host:8786
  python -m eval study readings --preset quick   # into results/readings"""

DEFAULT_OUT = os.path.join("results", "study")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "study", choices=("all", *STUDIES, readings.NAME), help="which study to run"
    )
    parser.add_argument(
        "--preset", choices=tuple(PRESETS), default="quick", help="conditions, seeds, budgets"
    )
    parser.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help=f"output directory (default {DEFAULT_OUT}; {readings.DEFAULT_OUT} for readings)",
    )
    parser.add_argument(
        "--method",
        action="append",
        metavar="SPEC",
        help="harness method: cmaes, pso, random, policy:RUN_DIR, ...; repeat to run several "
        "side by side (default: the preset's method)",
    )
    add_insect_argument(parser)
    add_backend_arguments(parser)
    add_scheduler_argument(parser)
    parser.add_argument(
        "--workers",
        type=int,
        default=1,
        metavar="N",
        help="N > 1 is short for --scheduler local:N; 1 (default) runs in this process",
    )
    parser.add_argument(
        "--reading",
        action="append",
        metavar="NAME",
        help="readings study: run these single readings (repeat; the default is always "
        f"run; allowed: {', '.join(r.name for r in readings.SINGLES)}); any other study: run "
        "it under this one reading (paper, a single, or singles joined by '+'; "
        "docs/reproduction.md, Readings)",
    )
    parser.add_argument(
        "--continuation",
        type=_continuation,
        default=readings.Continuation(),
        metavar="SHARE|none",
        help="readings study only: the other readings continue from the default's optima on "
        f"SHARE of the budget (default {readings.Continuation().share:g}; docs/reproduction.md, "
        "Readings); none runs every reading in full",
    )
    parser.add_argument(
        "--format",
        choices=FORMATS,
        default=FORMATS[0],
        help=f"file format of the figures (default {FORMATS[0]}; svg and pdf are vector "
        "graphics, for print)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress display")


def _continuation(text: str) -> readings.Continuation | None:
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
        return readings.Continuation(share=share)
    except ValueError as error:
        raise argparse.ArgumentTypeError(
            f"{error} (got {text!r}; or none to run every reading in full)"
        ) from None


def _check_continuation(plan: StudyPlan, continuation: readings.Continuation) -> None:
    """Prepare the continued job of every configuration the default's jobs have (method,
    budget, settings) as the harness will, before any work: a share whose continued budget no
    method can run (below one population, or a part without evaluations) is refused now, not
    by every continued job after the default's phase has run. ValueError naming the share."""
    jobs = {
        (j.method, j.budget, j.method_config): j
        for j in readings.reading_jobs(plan, readings.DEFAULT)
    }
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


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    methods = tuple(dict.fromkeys(args.method)) if args.method else None
    if args.out is None:
        args.out = readings.DEFAULT_OUT if args.study == readings.NAME else DEFAULT_OUT
    if args.reading and args.study != readings.NAME and len(args.reading) > 1:
        parser.error(f"study {args.study!r} runs under one --reading, got {args.reading}")
    if args.continuation != readings.Continuation() and args.study != readings.NAME:
        parser.error(f"--continuation is for the readings study only (study {args.study!r})")
    try:
        scheduler = executor_spec(args.scheduler, args.workers)
        # Checked before any work: a file is refused, a read-only folder unless everything
        # is stored already (then the run only reports that).
        store = RecordStore(args.out)
        writable = store.check(write=False)
        plan = StudyPlan(
            get_preset(args.preset),
            methods,
            figure_format=args.format,
            execution=tuple(backend_kwargs(args).items()),
            insect=DRAGONFLY if args.insect is None else load_insect(args.insect),
            reading=readings.reading_by_name(args.reading[0])
            if args.reading and args.study != readings.NAME
            else readings.DEFAULT,
        )
        for method in plan.methods:  # an unknown method or bad setting, before any job
            get_method(method, dict(plan.method_config(method)))
        chosen = readings.single_readings(args.reading if args.study == readings.NAME else None)
        if args.study == readings.NAME and args.continuation is not None:
            _check_continuation(plan, args.continuation)
        if args.study == readings.NAME and args.continuation is not None:
            jobs = readings.reading_jobs(plan, readings.DEFAULT)
            title = (
                f"readings study, first phase (the default reading in full; then the bias "
                f"check, and {len(chosen) - 1} single readings continue from its optima on "
                f"{args.continuation.share:g} of the budget, a task the check fails in full; "
                "then the combinations their results point to)"
            )
        elif args.study == readings.NAME:
            jobs = [job for r in chosen for job in readings.reading_jobs(plan, r)]
            title = (
                f"readings study, first phase (the default and {len(chosen) - 1} single "
                "readings; the combinations their results point to follow)"
            )
        else:
            jobs = [job for name in expand([args.study]) for job in STUDIES[name].jobs(plan)]
            title = f"study {args.study} ({', '.join(expand([args.study]))})"
        unique = list({job.key: job for job in jobs}.values())
        writable = store.check(write=False, jobs=unique)  # and each record's path
        if not writable and (args.study == readings.NAME or not have_records(args.out, unique)):
            store.check(jobs=unique)  # raises, naming the folder and why
    except (ValueError, NotImplementedError) as error:
        parser.error(str(error))
    if not writable:
        print(
            f"all {len(unique)} optimisations are stored in {args.out}, which cannot be written: "
            "nothing to run, and its figures and report are left as they are"
            + (
                f" ({Path(args.out) / 'report.md'})"
                if (Path(args.out) / "report.md").exists()
                else ""
            ),
            file=sys.stderr,
        )
        return 0
    if not args.quiet:
        print(_announce(title, plan, unique, args.out), file=sys.stderr)
        if plan.insect != DRAGONFLY:
            print(f"insect: {describe_insect(plan.insect)}", file=sys.stderr)
    if args.study == readings.NAME:
        return _run_readings(args, parser, plan, scheduler, chosen)
    result = run_reporting(
        parser,
        lambda: run_studies(
            [args.study], plan, args.out, scheduler=scheduler, progress=not args.quiet
        ),
    )
    if isinstance(result, int):
        return result
    run = result.run
    print(
        f"{run.total} optimisations: {run.ran} run, {run.reused} reused from {args.out} "
        f"({run.executor}); {result.wall_time:.1f} s",
        file=sys.stderr,
    )
    for output in result.outputs:
        claims = (
            f"; claims on the median: {VerdictCount.of(output.claims).text()}; on the best "
            f"seed: {VerdictCount.of(output.claims, best=True).text()}"
            if output.claims
            else ""
        )
        print(f"{output.name}: {len(output.rows)} records, {len(output.figures)} figures{claims}")
    if result.report is not None:
        print(f"report: {result.report}")
    return 0


def _announce(title: str, plan: StudyPlan, jobs: Sequence[Job], out: str) -> str:
    """What a study run will do, before it starts: optimisations, seeds, budgets, work left."""
    store = RecordStore(out)
    todo = [job for job in jobs if not store.path(job.key).exists()]
    seeds = sorted({job.seed for job in jobs})
    budgets = " / ".join(f"{b:,}" for b in sorted({job.budget for job in jobs}))
    return (
        f"{title}: preset {plan.preset.name}, method {', '.join(plan.methods)}; "
        f"{len(jobs)} optimisations over seeds {seeds}, budgets {budgets} model evaluations "
        f"each; {len(jobs) - len(todo)} stored in {out}, {len(todo)} to run "
        f"({sum(job.budget for job in todo):,} evaluations; the progress bar gives the time left)"
    )


def _run_readings(
    args: argparse.Namespace,
    parser: argparse.ArgumentParser,
    plan: StudyPlan,
    scheduler: str | None,
    chosen: tuple[readings.Reading, ...],
) -> int:
    result = run_reporting(
        parser,
        lambda: readings.run_readings(
            plan,
            args.out,
            readings=chosen,
            scheduler=scheduler,
            progress=not args.quiet,
            continuation=args.continuation,
        ),
    )
    if isinstance(result, int):
        return result
    for phase, run in zip(result.phases, result.runs, strict=True):
        print(
            f"{phase}: {run.total} optimisations: {run.ran} run, {run.reused} reused from "
            f"{args.out} ({run.executor}); {run.wall_time:.1f} s",
            file=sys.stderr,
        )
    for r in result.results:
        print(f"{r.reading.name}: {VerdictCount.of(r.claims).text()}")
    print(f"best: {result.best.reading.name} ({result.best.agree} claims agree)")
    print(f"combinations: {result.combination_rule}")
    print(f"report: {result.files[-1]}; total {result.wall_time:.1f} s")
    return 0
