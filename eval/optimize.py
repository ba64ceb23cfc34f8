"""``python -m eval optimize``: run one method on one condition for several seeds, each a job of
the resumable runner (:func:`agents.runner.run_jobs`) storing its record in ``--out``; with the
options every command that runs jobs shares (:data:`RUN_OPTIONS`, :func:`run_reporting`).
"""

from __future__ import annotations

import argparse
import sys
import textwrap
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from agents.dask_cluster import SchedulerUnreachable, parse_scheduler
from agents.harness import PreparedJob, prepare
from agents.jobs import MAX_BUDGET
from agents.methods import available_methods
from agents.optimiser import MAX_BATCH
from agents.polish import POLISH_DEFAULTS, POLISH_METHODS
from agents.polish import describe as describe_certificate
from agents.runner import JobsFailed, OutputNotWritable, run_jobs
from agents.store import StoreWriteError
from agents.tasks import TaskSpec, available_tasks, get_task
from eval.studies.paper_reading import Reading
from eval.studies.presets import WARM_SHARE, WARM_STARTS, warm_start
from eval.studies.readings import reading_by_name
from tandem_env.envs.config import EXECUTION_KWARGS, insect_keyword
from tandem_env.io.command import checked_by
from tandem_env.io.keyvalue import add_pairs_argument
from tandem_env.physics import BACKENDS
from tandem_env.physics.insect import describe_insect, load_insect


def _tasks() -> list[TaskSpec]:
    return [get_task(name) for name in available_tasks()]


def _tasks_text(width: int = 92) -> str:
    """The "Tasks and conditions" paragraph of ``--help``, from the tasks' declarations."""
    lines = []
    for task in _tasks():
        condition, objectives = task.declared_condition, task.declared_objectives
        low, high = condition.envelope
        what = f"{condition.label} [{condition.unit}] ({low:g}-{high:g})"
        text = f"{task.condition_flag} {condition.metavar}  {what}; {task.declaration.summary}"
        if objectives.keyword is not None:
            text += f" --objective: {', '.join(objectives.metrics)} (default {objectives.default})."
        indent = f"  {task.name:<11} "
        lines.append(textwrap.fill(text, width, initial_indent=indent, subsequent_indent=" " * 14))
    return "\n".join(lines)


NAME = "optimize"
HELP = (
    "run a method (cmaes, the default; pso, random, ...) on one flight condition for several seeds"
)


def description() -> str:
    """The ``--help`` description, built when the parser is (tasks registered later show up)."""
    return f"""\
Run one search method on one flight condition for a list of seeds. Every iteration's batch
of strokes is evaluated through the task's batched vector env (fitness = the env's reward,
the penalised objective); the best stroke of each seed is re-evaluated and stored as a JSON
record in --out, DIR/records/<key>.json with <key> the hash of the run's configuration (method,
task, condition, budget, seed, env and method settings, package version), plus
DIR/summary.csv over every record in DIR. A seed whose record is already there with the same
configuration is not run again (a killed run resumes); another budget or setting is another
record, beside it.

Tasks and conditions (from each env config's declaration; the condition may be widened
up to the model's limits with --env-kwargs, e.g. speed_envelope=(0.1,3)):
{_tasks_text()}

The budget counts model evaluations (= env steps = strokes evaluated). The seeds run here,
one after another (default), or on Dask: --scheduler local:N starts N worker processes here,
--scheduler tcp://HOST:PORT uses a running Dask scheduler (docs/scaling.md)."""


EPILOG = """\
examples:
  python -m eval optimize --task level --speed 1.5 --method pso --budget 12000 \\
      --seeds 0 1 2 3 4 --out results/level-1.5
  python -m eval optimize --task accelerate --power 70 --objective horizontal \\
      --method random --budget 4000 --seeds 0 --out results/acc --quiet
  python -m eval optimize --task level --speed 1.0 --method pso --budget 8000 --seeds 0 \\
      --out results/x --env-kwargs thrust_split=body --method-config velocity_clamp=0.2
  python -m eval optimize --task level --speed 1.5 --method pso --budget 30000 \\
      --seeds 0 1 2 3 4 5 6 7 --out results/v15 --scheduler local:2"""


T = TypeVar("T")


def run_reporting(parser: argparse.ArgumentParser, call: Callable[[], T]) -> T | int:
    """``call()`` (a run of jobs: optimize, study, reference or speed-change), or the exit
    status of how it stopped, said on stderr: the usage error (2) for an output folder the
    runner refuses before any job; 1 for an unreachable scheduler, failed jobs or a record that
    cannot be written (the store is as it was); 130 for an interrupt (records are kept). Any
    other OSError (a table or figure written after the records) is the command line's to say
    (:func:`tandem_env.io.command.run_command`)."""
    try:
        return call()
    except OutputNotWritable as error:  # nothing ran
        parser.error(str(error))
    except (SchedulerUnreachable, JobsFailed, StoreWriteError) as error:
        print(f"{parser.prog}: error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        resumes = "the finished records are stored; the same command resumes from them"
        print(f"{parser.prog}: interrupted; {resumes}", file=sys.stderr)
        return 130


def _check_reading_applies(
    name: str, reading: Reading, task: TaskSpec, objective: str | None
) -> None:
    """A reading's horizontal objective with no horizontal objective here to replace: refused
    if it is all the reading changes, a warning if its model options still apply."""
    objectives = task.declared_objectives
    given = objective if objective is not None else objectives.default
    if "horizontal" in (reading.horizontal_objective, given):
        return
    where = f"--task {task.name}" + (f" --objective {given}" if objectives.keyword else "")
    what = (
        f"its objective {reading.horizontal_objective} replaces only the horizontal one "
        f"(--task accelerate --objective horizontal), not {given} ({where})"
    )
    if not reading.env_kwargs():
        raise ValueError(
            f"--reading {name} changes nothing here: {what}; allowed: a reading that changes "
            "the model, or --objective horizontal"
        )
    warnings.warn(f"--reading {name}: {what}; its model options apply", UserWarning, stacklevel=2)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    tasks = _tasks()
    names = tuple(t.name for t in tasks)
    parser.add_argument("--task", required=True, choices=names, help="the flight task")
    condition = parser.add_mutually_exclusive_group(required=True)
    for flag in dict.fromkeys(t.condition_flag for t in tasks):
        declared = {t.name: t.declared_condition for t in tasks if t.condition_flag == flag}
        one = next(iter(declared.values()))  # the tasks of one flag share its keyword
        text = "; ".join(f"{name}: {c.label} [{c.unit}]" for name, c in declared.items())
        condition.add_argument(flag, type=float, dest=one.keyword, metavar=one.metavar, help=text)
    choosers = [t for t in tasks if t.declared_objectives.keyword is not None]
    choices = tuple(dict.fromkeys(c for t in choosers for c in t.declared_objectives.metrics))
    text = "; ".join(
        f"{t.name} only: the objective maximised (default {t.declared_objectives.default})"
        for t in choosers
    )
    parser.add_argument("--objective", choices=choices, help=text)
    text = (
        f"search method: {', '.join(available_methods())} (policy as policy:RUN_DIR; "
        "ppo, sac and policy come from train/)"
    )
    parser.add_argument("--method", required=True, metavar="METHOD", help=text)
    text = f"model evaluations per seed (1 to {MAX_BUDGET:,})"
    parser.add_argument("--budget", required=True, type=int, metavar="N", help=text)
    text = "one run per seed"
    parser.add_argument("--seeds", required=True, type=int, nargs="+", metavar="SEED", help=text)
    parser.add_argument("--out", required=True, metavar="DIR", help="directory for the records")
    text = "strokes per iteration: PSO particles / random-search batch (default 40, at most"
    parser.add_argument("--swarm-size", type=int, metavar="N", help=f"{text} {MAX_BATCH:,})")
    values = "(values: Python literals, e.g. 1.5 or (0.25,2.0), else YAML, else text)"
    pairs = {
        "--method-config": "method settings, e.g. velocity_clamp=0.2 boundary=reflect inertia=linear-decreasing",
        "--env-kwargs": "env options, e.g. thrust_split=body penalty_weight=20 planform=real n_time=256",
    }
    for option, what in pairs.items():
        add_pairs_argument(parser, option, f"{what} {values}")
    add_run_arguments(parser, "--insect", "--backend", "--device")
    text = (
        "local polish of each seed's best feasible stroke (agents/polish.py): "
        f"default {', '.join(f'{k} for {m}' for m, k in POLISH_DEFAULTS.items())}, none for "
        "the other methods; its evaluations count in --budget (the method setting "
        "polish_share sets its part)"
    )
    parser.add_argument("--polish", choices=POLISH_METHODS, help=text)
    text = (
        "table: polish the reference table's optimum at this condition and its grid "
        f"neighbours' first, on {WARM_SHARE:g} of --budget (counted in it; the job's "
        "initial strokes, docs/reference.md); an error where the table has no such point. "
        "Default none: a cold start"
    )
    parser.add_argument("--warm-start", choices=WARM_STARTS, default="none", help=text)
    text = (
        "run under a reading of the paper's open decisions (eval/studies/readings/): "
        "paper (the reading that reproduces the most claims, docs/reproduction.md), a single "
        "such as hover-none, or singles joined by '+'; sets its model options as env "
        "keywords and, for --objective horizontal, its F̄_h objective (a reading that changes "
        "only that objective is refused for any other objective; one that also changes the "
        "model runs with a warning)"
    )
    parser.add_argument("--reading", metavar="NAME", help=text)
    add_run_arguments(parser, "--scheduler", "--no-cache", "--rerun", "--quiet")


#: The options of the commands that run jobs (optimize, study, reference, speed-change,
#: crosscheck): the argparse keywords of each (``--no-cache`` sets ``args.cache``; ``--insect``,
#: optimize's and study's, is read when the command line is parsed).
RUN_OPTIONS: dict[str, dict[str, Any]] = {
    "--insect": {
        "metavar": "FILE",
        "action": checked_by(load_insect),
        "help": "YAML file of the insect: the fields that differ from the paper's specimen "
        "(body_mass, fore: {length, mean_chord, mass, planform, coefficients}, hind: {...}; "
        "docs/envs.md, e.g. examples/orthetrum_cancellatum.yaml); part of each record's key",
    },
    "--backend": {
        "choices": BACKENDS,
        "help": "the model's implementation (env keyword backend; default numba): the results "
        "agree within 1e-8, so records are shared between backends (docs/harness.md)",
    },
    "--device": {
        "metavar": "DEVICE",
        "help": "torch device of --backend torch: cpu (default), cuda, cuda:N",
    },
    "--scheduler": {
        "metavar": "WHERE",
        "action": checked_by(parse_scheduler),
        "help": "run the jobs (the optimisations, the solver runs) on Dask: local:N (N worker "
        "processes started here, one numba thread each) or the address of a running scheduler, "
        "e.g. tcp://HOST:8786 (docs/scaling.md); default: one after another in this process",
    },
    "--no-cache": {
        "dest": "cache",
        "action": "store_false",
        "help": "do not use the record cache shared by every output folder (by default a job "
        "whose record is there is copied into --out, not run, and every record computed is "
        "added to it; where it is and how to clear it: docs/harness.md, The record cache); a "
        "record already in --out is still reused (--rerun computes it again)",
    },
    "--rerun": {
        "action": "store_true",
        "help": "run every job again even where --out or the record cache holds its record; "
        "the new records replace the old ones (each file written atomically), said in the "
        "last line",
    },
    "--quiet": {"action": "store_true", "help": "no progress display"},
}


def add_run_arguments(parser: argparse.ArgumentParser, *flags: str) -> None:
    """The options ``flags`` of :data:`RUN_OPTIONS`, in that order."""
    for flag in flags:
        parser.add_argument(flag, **RUN_OPTIONS[flag])


def run_options(args: argparse.Namespace) -> dict[str, Any]:
    """The runner's keywords (``run_jobs``, ``run_plan``) of ``--scheduler``, ``--no-cache``,
    ``--rerun`` and ``--quiet`` as given."""
    return dict(
        scheduler=args.scheduler, cache=args.cache, rerun=args.rerun, progress=not args.quiet
    )


def plan_command(args: argparse.Namespace, parser: argparse.ArgumentParser) -> list[PreparedJob]:
    """The command's jobs, one per seed in the order given, validated once here
    (:func:`agents.harness.prepare`; the runner does not validate them again); the usage error
    (exit status 2) naming what is wrong and what is allowed, before any work."""
    tasks = _tasks()
    task = next(t for t in tasks if t.name == args.task)  # one of them: argparse's choices
    declared = task.declared_condition
    if (condition := getattr(args, declared.keyword)) is None:
        given = [
            t.condition_flag
            for t in tasks
            if getattr(args, t.declared_condition.keyword, None) is not None
        ]
        parser.error(
            f"--task {task.name} takes {task.condition_flag} {declared.metavar} "
            f"[{declared.unit}], not {' '.join(dict.fromkeys(given))}"
        )
    if task.declared_objectives.keyword is None and args.objective is not None:
        choosers = [t.name for t in tasks if t.declared_objectives.keyword is not None]
        parser.error(
            f"--objective is for --task {' or '.join(choosers)}; {task.name} maximises "
            f"{task.declared_objectives.default}"
        )
    try:
        # The env options and method settings, the reading's, then the jobs (the harness's
        # checks). The output folder is the runner's to check: it alone knows, once it has
        # read the stored records, whether a folder that cannot be written holds everything.
        # --backend / --device as given, checked with the env's keywords
        given = {k: getattr(args, k) for k in ("backend", "device") if getattr(args, k) is not None}
        env_kwargs, method_config = dict(args.env_kwargs), dict(args.method_config)
        if given and set(EXECUTION_KWARGS) & set(env_kwargs):
            raise ValueError("give --backend/--device or --env-kwargs backend=/device=, not both")
        env_kwargs.update(given)
        if args.insect is not None:  # given, even if it is the paper's specimen
            if "insect" in env_kwargs:
                raise ValueError("give --insect FILE or --env-kwargs insect=..., not both")
            if insect_keyword(args.insect) is not None:  # the specimen leaves keys as they were
                env_kwargs["insect"] = insect_keyword(args.insect)
        if args.swarm_size is not None:
            if "swarm_size" in method_config:
                raise ValueError("give --swarm-size or --method-config swarm_size=N, not both")
            method_config["swarm_size"] = args.swarm_size
        if args.polish is not None:
            if "polish" in method_config and method_config["polish"] != args.polish:
                raise ValueError("give --polish or --method-config polish=..., not both")
            method_config["polish"] = args.polish
        objective, reading_kwargs = args.objective, {}
        if args.reading is not None:
            reading = reading_by_name(args.reading)
            reading_kwargs = reading.env_kwargs()
            _check_reading_applies(args.reading, reading, task, objective)
            if objective is not None:
                objective = reading.objective(objective)
        if clash := sorted(set(env_kwargs) & set(reading_kwargs)):
            raise ValueError(
                f"--reading {args.reading} sets {clash}; give them there or in "
                "--env-kwargs, not both"
            )
        env_kwargs.update(reading_kwargs)
        if args.warm_start == "table":
            if {"initial", "initial_share"} & set(method_config):
                raise ValueError("give --warm-start table or --method-config initial=..., not both")
            with_objective = {**env_kwargs, **({"objective": objective} if objective else {})}
            try:
                method_config.update(warm_start(task.name, condition, with_objective))
            except ValueError as error:
                raise ValueError(f"--warm-start table: {error}") from None
        options = dict(objective=objective, env_kwargs=env_kwargs, method_config=method_config)
        return prepare(args.method, task, condition, args.budget, args.seeds, **options)
    except (ValueError, NotImplementedError) as error:
        parser.error(str(error))


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    jobs = plan_command(args, parser)
    if not args.quiet:
        seeds = [p.job.seed for p in jobs]
        print(f"optimize: {jobs[0].describe()}, seeds {seeds} -> {Path(args.out)}", file=sys.stderr)
        if "insect" in jobs[0].env_kwargs:
            print(f"insect: {describe_insect(jobs[0].env_kwargs['insect'])}", file=sys.stderr)
    # --out as given: an empty one is the runner's to refuse, not the current folder
    options = run_options(args)
    summary = run_reporting(parser, lambda: run_jobs(jobs, args.out, **options, summary_csv=True))
    if isinstance(summary, int):
        return summary
    for record in (summary.records[p.job.key] for p in jobs):
        power = record.metrics.get("power_per_mass")
        print(
            f"{record.method} seed {record.seed}: {record.objective_name} = "
            f"{record.objective:.5g}, reward = {record.reward:.5g}, feasible = {record.feasible}"
            + (f", P/m = {power:.4g} W/kg" if power is not None else "")
            + f", {record.evaluations} evaluations, {record.wall_time:.1f} s"
        )
        print(f"  {describe_certificate(record.certificate)}")
    hint = " (--rerun runs them again)" if summary.reused else ""
    seeds = f"{summary.total} seed{'s' * (summary.total != 1)}"
    print(f"{seeds}: {summary.describe(Path(args.out))}{hint}", file=sys.stderr)
    return 0
