"""``python -m eval study``: run the paper's studies (figures, tables, report) on the harness."""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

from agents.dask_cluster import executor_spec
from agents.methods import get_method
from agents.progress import CommandProgress
from agents.runner import find_records, look_ahead, run_plan
from agents.store import RecordStore
from eval.figures import FORMATS
from eval.optimize import add_run_arguments, run_reporting
from eval.studies.base import StudyPlan
from eval.studies.claims import FLIP_THRESHOLD
from eval.studies.presets import OVERRIDES, STUDY_PRESETS, overridden
from eval.studies.readings.run import READINGS, ReadingsCampaign
from eval.studies.suite import SUITE, SuiteCampaign
from tandem_env.physics.insect import DRAGONFLY, describe_insect

#: What the command runs, in the order of its help: the paper's studies and the readings study.
#: Each has the study ``names`` that choose it, its help lines (``description``,
#: ``reading_help``), ``default_out``, its own ``options`` (flag -> ``add_argument`` keywords,
#: refused for another study), a plan (``plan(args, plan, store)``: ``phases`` for
#: :func:`agents.runner.run_plan`, a ``title`` and ``finish(run)``) and ``report(args, result)``.
CAMPAIGNS = (SUITE, READINGS)


def campaigns() -> dict[str, SuiteCampaign | ReadingsCampaign]:
    """Every study name the command offers -> its campaign (the names read now)."""
    return {name: campaign for campaign in CAMPAIGNS for name in campaign.names}


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
"""
    + "\n".join(c.description for c in CAMPAIGNS)
    + """

Presets:
"""
    + "\n".join(
        textwrap.fill(
            p.description, 92, initial_indent=f"  {p.name:<12} ", subsequent_indent=" " * 15
        )
        for p in STUDY_PRESETS.values()
    )
    + """

A killed run resumes: finished optimisations are recognised by their configuration hash and
not run again; a changed configuration never reuses old records. An optimisation another
output folder has run is copied from the record cache instead of run (--no-cache: not).
The first line gives the whole command's optimisations, what is stored and what runs, its
model evaluations and the time left; a command of several phases says it again at each
phase's start.

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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("study", choices=tuple(campaigns()), help="which study to run")
    text = "conditions, seeds, budgets"
    parser.add_argument("--preset", choices=tuple(STUDY_PRESETS), default="quick", help=text)
    shared = "wing-shape studies, readings"
    helps = {
        "speeds": ("V", float, f"the level-flight sweep [m/s] (speed and {shared})"),
        "powers": ("P", float, f"the available-power sweep [W/kg] (power and {shared})"),
        "seeds": ("SEED", int, "the seeds of every optimisation (convergence study: its runs)"),
        "budget": ("N", int, "model evaluations per optimisation, every task"),
    }
    for option, (metavar, kind, text) in helps.items():  # the preset's fields (OVERRIDES)
        text += "; default the preset's"
        nargs = None if option == "budget" else "+"  # one budget; a list of the others
        parser.add_argument(f"--{option}", type=kind, nargs=nargs, metavar=metavar, help=text)
    first, *rest = CAMPAIGNS  # the default folder, and each other campaign's
    out = f"default {first.default_out}" + "".join(
        f"; {c.default_out} for {', '.join(c.names)}" for c in rest
    )
    parser.add_argument("--out", default=None, metavar="DIR", help=f"output directory ({out})")
    text = "harness method: cmaes, pso, random, policy:RUN_DIR, ...; repeat to run several side"
    text += " by side (default: the preset's method)"
    parser.add_argument("--method", action="append", metavar="SPEC", help=text)
    add_run_arguments(parser, "--insect", "--backend", "--device", "--scheduler")
    add_run_arguments(parser, "--no-cache", "--rerun", "--quiet")
    text = "N > 1 is short for --scheduler local:N; 1 (default) runs in this process"
    parser.add_argument("--workers", type=int, default=1, metavar="N", help=text)
    text = "; ".join(c.reading_help for c in CAMPAIGNS)
    parser.add_argument("--reading", action="append", metavar="NAME", help=text)
    for campaign in CAMPAIGNS:
        for flag, option in campaign.options.items():
            parser.add_argument(flag, **option)
    text = f"file format of the figures (default {FORMATS[0]}; svg and pdf are vector graphics,"
    parser.add_argument("--format", choices=FORMATS, default=FORMATS[0], help=f"{text} for print)")


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    campaign = campaigns()[args.study]
    args.out = args.out or campaign.default_out
    for other in CAMPAIGNS:
        for flag, option in {} if other is campaign else other.options.items():
            if getattr(args, flag[2:].replace("-", "_")) != option["default"]:
                owner = ", ".join(other.names)
                parser.error(f"{flag} is for the {owner} study only (study {args.study!r})")
    try:
        plan = StudyPlan(
            overridden(STUDY_PRESETS[args.preset], **{o: getattr(args, o) for o in OVERRIDES}),
            tuple(dict.fromkeys(args.method)) if args.method else None,
            figure_format=args.format,
            execution=(("backend", args.backend), ("device", args.device)),
            insect=DRAGONFLY if args.insect is None else args.insect,
        )
        scheduler = executor_spec(args.scheduler, args.workers)
        # Checked before any work: a file is refused, a read-only folder unless everything
        # is stored already and the run only reports that. The one store of the command.
        store = RecordStore(args.out)
        store.check(write=False)
        study = campaign.plan(args, plan, store)
        for method in study.plan.methods:  # an unknown method or bad setting, before any job
            get_method(method, dict(study.plan.method_config(method)))
        phases = look_ahead(study.phases, store, args.cache)
        unique = list({job.key: job for job in phases[0].jobs}.values())
        writable = store.check(write=False, jobs=unique)  # and each record's path
        reports_only = len(phases) == 1 and not phases[0].later
        stored = writable or find_records(store, unique, cache=False) is not None
        if not writable and not (reports_only and stored):
            store.check(jobs=unique)  # raises, naming the folder and why
        detail = f"preset {study.plan.preset.name}, method {', '.join(study.plan.methods)}"
        # --quiet says no cost line, so none is made
        command = None
        if not args.quiet:
            command = CommandProgress(
                study.title, store, cache=args.cache, detail=detail, rerun=args.rerun
            )
    except (ValueError, NotImplementedError) as error:
        parser.error(str(error))
    if not writable:
        report = Path(args.out) / "report.md"
        print(
            f"all {len(unique)} optimisations are stored in {args.out}, which cannot be written: "
            "nothing to run, and its figures and report are left as they are"
            + (f" ({report})" if report.exists() else ""),
            file=sys.stderr,
        )
        return 0
    if command is not None:
        command.announce(phases)  # the first line
    if not args.quiet and plan.insect != DRAGONFLY:
        print(f"insect: {describe_insect(plan.insect)}", file=sys.stderr)

    def run() -> object:
        # the runner's keywords written out here: study all's route stays short (tests/route_count.py)
        done = run_plan(
            study.phases,
            store,
            scheduler,
            args.cache,
            progress=not args.quiet,
            rerun=args.rerun,
            command=command,
        )
        return study.finish(done)

    result = run_reporting(parser, run)
    if isinstance(result, int):
        return result
    campaign.report(args, result)
    return 0
