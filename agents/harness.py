"""The one entry point that runs a search method on a task and records what it found.

::

    from agents.harness import run

    records = run("pso", "level", 1.5, budget=12_000, seeds=[0, 1, 2], out_dir="results/x")

For each seed the method searches the task's normalised action box [-1, 1]^28 with the given
budget of model evaluations, evaluating every batch through the task's native vector env (one
batched model call per iteration; fitness = the env's reward, the penalised objective an RL
agent sees). The best stroke is then re-evaluated in a fresh single env and a
:class:`~agents.records.Record` is built from that re-evaluation; it carries its
:class:`~agents.records.Job` (the run's configuration) and the job's key. With ``out_dir`` each
record is written into that directory's :class:`~agents.records.RecordStore` as it completes
(``records/<key>.json``, atomically: a killed run keeps the finished seeds and leaves no partial
file), and ``summary.csv`` there is rewritten over every record in the store.

:func:`prepare` validates everything (task, condition, env kwargs, method, budget, seeds)
before any work and returns a :class:`RunPlan`; :func:`execute` runs it; :func:`run` does both.
:func:`run_job` runs one :class:`~agents.records.Job` (what the resumable, distributed runner
``eval.studies.runner`` sends to its workers).
"""

from __future__ import annotations

import math
import os
import time
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import gymnasium as gym
import numpy as np

import tandem_env
from agents.evaluator import VectorEnvEvaluator, reevaluate
from agents.methods import Method, SearchContext, SearchOutcome, get_method
from agents.records import (
    SELECTION_BEST_FEASIBLE,
    SELECTION_BEST_REWARD,
    SELECTION_METHOD,
    Job,
    Record,
    RecordStore,
    package_versions,
)
from agents.tasks import Condition, TaskSpec, get_task
from tandem_env.io.files import to_jsonable
from tandem_env.io.progress_bar import ProgressBar, Reporter

__all__ = ["RunPlan", "execute", "prepare", "run", "run_job", "run_seed"]


@dataclass(frozen=True, eq=False)
class RunPlan:
    """A validated run: one method, one task and condition, a budget, several seeds."""

    method: Method
    method_spec: str
    task: TaskSpec
    condition: Condition
    budget: int
    """Model evaluations per seed."""
    seeds: tuple[int, ...]
    env_kwargs: Mapping[str, Any]
    """Env constructor keywords, including the condition (and objective) keyword."""
    objective_name: str
    dim: int
    """Dimension of the action box."""
    method_config: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    """Method settings as given (part of each seed's :class:`Job`)."""
    preset: str = ""
    """Study preset the runs belong to (part of each seed's :class:`Job`); empty outside studies."""
    progress: bool = True
    out_dir: Path | None = None

    def job(self, seed: int) -> Job:
        """The configuration of one seed's run: what its record is stored under."""
        return Job(
            method=self.method_spec,
            task=self.task.name,
            condition=self.condition.value,
            budget=self.budget,
            seed=seed,
            env_kwargs={k: v for k, v in self.env_kwargs.items() if k != self.task.condition_kwarg},
            method_config=self.method_config,
            preset=self.preset,
        )

    def describe(self) -> str:
        return (
            f"{self.method_spec} on {self.task.name} ({self.objective_name}) at "
            f"{self.condition.describe()}, budget {self.budget} evaluations, seeds "
            f"{list(self.seeds)}"
        )


def prepare(
    method: str | Method,
    task: str | TaskSpec,
    condition: float,
    budget: int,
    seeds: Iterable[int],
    *,
    objective: str | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    method_config: Mapping[str, Any] | None = None,
    preset: str = "",
    progress: bool = True,
    out_dir: str | os.PathLike[str] | None = None,
) -> RunPlan:
    """Validate a run and return its plan; raises ValueError saying what is wrong and allowed.

    Parameters are those of :func:`run`, plus ``preset``: the study preset the runs belong to,
    part of each seed's :class:`Job` and so of its record's key (empty outside the studies).
    Building the env once here lets it reject bad keywords and out-of-range conditions before
    any evaluation.
    """
    spec = get_task(task)
    cond = spec.condition(condition)
    kwargs = dict(env_kwargs or {})
    clash = sorted(set(kwargs) & set(spec.forbidden_kwargs))
    if clash:
        raise ValueError(
            f"env_kwargs {clash} are set by the harness for task {spec.name!r}; give the "
            f"condition ({spec.condition_name} [{spec.condition_unit}]) as the condition argument"
        )
    if objective is not None:
        if spec.objective_kwarg is None:
            raise ValueError(
                f"task {spec.name!r} has one objective ({spec.default_objective}); "
                "objective cannot be chosen"
            )
        given = kwargs.get(spec.objective_kwarg)
        if given is not None and given != objective:
            raise ValueError(
                f"objective = {objective!r} but env_kwargs[{spec.objective_kwarg!r}] = {given!r}"
            )
        kwargs[spec.objective_kwarg] = objective
    objective_name = spec.objective_metric(kwargs)
    kwargs[spec.condition_kwarg] = cond.value

    try:
        env = gym.make(spec.env_id, disable_env_checker=True, **kwargs)
    except gym.error.Error as error:
        raise ValueError(f"cannot make {spec.env_id}: {error}") from error
    try:
        space = env.action_space
        if not (
            isinstance(space, gym.spaces.Box)
            and len(space.shape) == 1
            and np.all(space.low == -1.0)
            and np.all(space.high == 1.0)
        ):
            raise ValueError(f"{spec.env_id}: action space {space}; allowed: Box(-1, 1, (d,))")
        dim = int(space.shape[0])
    finally:
        env.close()

    if isinstance(budget, bool) or not isinstance(budget, int | np.integer) or budget < 1:
        raise ValueError(f"budget = {budget!r}; allowed: an integer >= 1 (model evaluations)")
    seed_list = list(seeds)
    if not seed_list:
        raise ValueError("seeds is empty; allowed: one or more integers >= 0")
    for seed in seed_list:
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
            raise ValueError(f"seed {seed!r}; allowed: integers >= 0")
    if len(set(seed_list)) != len(seed_list):
        raise ValueError(f"seeds {seed_list} repeat; allowed: distinct integers >= 0")

    method_obj = get_method(method, method_config)
    store = None if out_dir is None else RecordStore(out_dir)  # rejects a file as out_dir
    # Optional hook: a method that can tell before searching that it cannot run this budget on
    # this box (a budget smaller than one CMA-ES population) says so here, not mid-run.
    check = getattr(method_obj, "check", None)
    if callable(check):
        check(int(budget), dim, spec)
    return RunPlan(
        method=method_obj,
        method_spec=method if isinstance(method, str) else method_obj.name,
        task=spec,
        condition=cond,
        budget=int(budget),
        seeds=tuple(int(s) for s in seed_list),
        env_kwargs=MappingProxyType(kwargs),
        objective_name=objective_name,
        dim=dim,
        method_config=MappingProxyType(dict(method_config or {})),
        preset=preset,
        progress=bool(progress),
        out_dir=None if store is None else store.directory,
    )


def execute(plan: RunPlan) -> list[Record]:
    """Run every seed of ``plan``; store records (and the summary) when it has an out_dir.

    Every seed runs, also one whose record is stored already (its record is replaced by the
    rerun's, which has the same numbers); resuming is the runner's job
    (:func:`eval.studies.runner.run_jobs`, ``python -m eval optimize``).
    """
    store = None if plan.out_dir is None else RecordStore(plan.out_dir)
    records = []
    for seed in plan.seeds:
        record = run_seed(plan, seed)
        records.append(record)
        if store is not None:
            store.save(record)
            # Over the whole store, so one summary covers every method run into it.
            store.write_summary()
    return records


def run_job(job: Job, reporter: Reporter | None = None) -> Record:
    """Run one :class:`Job` (no progress bar; ``reporter`` gets the search's progress).

    Raises ValueError as :func:`prepare` does for a job it rejects.
    """
    plan = prepare(
        job.method,
        job.task,
        job.condition,
        job.budget,
        [job.seed],
        env_kwargs=dict(job.env_kwargs),
        method_config=dict(job.method_config),
        preset=job.preset,
        progress=False,
    )
    if plan.job(job.seed) != job:
        raise ValueError(f"job {job} does not round-trip through prepare: {plan.job(job.seed)}")
    return run_seed(plan, job.seed, reporter)


def run(
    method: str | Method,
    task: str | TaskSpec,
    condition: float,
    budget: int,
    seeds: Iterable[int],
    *,
    objective: str | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    method_config: Mapping[str, Any] | None = None,
    progress: bool = True,
    out_dir: str | os.PathLike[str] | None = None,
) -> list[Record]:
    """Run ``method`` on ``task`` at ``condition`` for each seed; one record per seed.

    Parameters
    ----------
    method : str or Method
        ``"pso"``, ``"random"``, or any registered method (``"ppo"``, ``"sac"``,
        ``"policy:RUN_DIR"`` once ``train`` provides them); see :mod:`agents.methods`.
    task : str or TaskSpec
        ``"level"`` or ``"accelerate"`` (or a registered/own :class:`TaskSpec`).
    condition : float
        Flight speed V [m/s] for level flight, available power [W/kg] for accelerating flight.
    budget : int
        Model evaluations per seed (one env step = one stroke evaluated = one unit).
    seeds : iterable of int
        One independent run, and one record, per seed.
    objective : str, optional
        Accelerating flight: ``"vertical"`` (default), ``"horizontal"`` or ``"resultant"``.
    env_kwargs : mapping, optional
        Further env keywords (model options, penalty, planform, ...), as for ``gym.make``.
    method_config : mapping, optional
        Method settings, e.g. ``{"swarm_size": 40, "velocity_clamp": 0.2}`` for PSO.
    progress : bool
        Show a progress bar per seed on stderr.
    out_dir : path, optional
        Store each record there (``records/<key>.json``, atomically) and write ``summary.csv``
        over the store. ValueError if it is a file.
    """
    return execute(
        prepare(
            method,
            task,
            condition,
            budget,
            seeds,
            objective=objective,
            env_kwargs=env_kwargs,
            method_config=method_config,
            progress=progress,
            out_dir=out_dir,
        )
    )


def _select(outcome: SearchOutcome, evaluator: VectorEnvEvaluator) -> tuple[np.ndarray, float, str]:
    """The stroke a record reports: the best feasible stroke the search evaluated, if any
    (the selection rule, :mod:`agents.selection`), else the method's best-reward stroke."""
    if evaluator.evaluations < outcome.evaluations:
        # the method evaluated (some) strokes through its own envs (SB3): it chooses, by the
        # same rule (train/policies.py)
        return outcome.best_action, outcome.best_reward, SELECTION_METHOD
    best_feasible = evaluator.best_feasible
    if best_feasible is None:
        return outcome.best_action, outcome.best_reward, SELECTION_BEST_REWARD
    action, reward = best_feasible
    return action, reward, SELECTION_BEST_FEASIBLE


def run_seed(plan: RunPlan, seed: int, reporter: Reporter | None = None) -> Record:
    """Search with one seed, re-evaluate the best stroke and build its record.

    The search's progress goes to ``reporter`` when given, else to a progress bar of its own
    (if ``plan.progress``).
    """
    start = time.perf_counter()
    job = plan.job(seed)
    label = f"{plan.method_spec} {plan.task.name} {plan.condition.name}={plan.condition.value:g} seed {seed}"
    bar = ProgressBar(plan.budget, label, plan.progress and reporter is None)
    report = bar.update if reporter is None else reporter
    with (
        bar,
        VectorEnvEvaluator(
            plan.task, plan.condition, plan.env_kwargs, seed, plan.budget, report
        ) as evaluator,
    ):
        context = SearchContext(
            task=plan.task,
            condition=plan.condition,
            env_id=plan.task.env_id,
            env_kwargs=plan.env_kwargs,
            budget=plan.budget,
            seed=seed,
            dim=plan.dim,
            evaluator=evaluator,
            _reporter=report,
        )
        outcome = plan.method.search(context)
    if not evaluator.evaluations <= outcome.evaluations <= plan.budget:
        raise RuntimeError(
            f"{plan.method_spec} reported {outcome.evaluations} evaluations; it made "
            f"{evaluator.evaluations} through the harness and the budget is {plan.budget}"
        )
    if outcome.best_action.shape != (plan.dim,):
        raise RuntimeError(
            f"{plan.method_spec} returned a stroke of shape {outcome.best_action.shape}; "
            f"the action space has dimension {plan.dim}"
        )

    action, search_reward, selection = _select(outcome, evaluator)
    again = reevaluate(plan.task, plan.condition, plan.env_kwargs, seed, action)
    wall_time = time.perf_counter() - start
    if not _same(again.reward, search_reward):
        warnings.warn(
            f"{plan.method_spec} seed {seed}: re-evaluated reward {again.reward!r} differs from "
            f"the search's {search_reward!r}",
            RuntimeWarning,
            stacklevel=2,
        )
    info = dict(again.info)
    stroke = info.pop("stroke", None)
    if stroke is None:
        stroke = {f"a{j}": float(v) for j, v in enumerate(action)}
    return Record(
        method=plan.method_spec,
        task=plan.task.name,
        env_id=plan.task.env_id,
        objective_name=plan.objective_name,
        condition=plan.condition,
        seed=seed,
        budget=plan.budget,
        evaluations=outcome.evaluations,
        objective=float(info.get("objective", again.reward)),
        reward=again.reward,
        search_reward=search_reward,
        selection=selection,
        feasible=bool(info.get("feasible", True)),
        stroke=to_jsonable(stroke),
        normalised_stroke=tuple(action.tolist()),
        metrics=to_jsonable(info),
        history=outcome.history,
        wall_time=wall_time,
        config={
            "method": to_jsonable(outcome.config),
            "env_kwargs": to_jsonable(dict(plan.env_kwargs)),
            "env": to_jsonable(again.env_config),
            "evaluation": {
                "vectorization_mode": "vector_entry_point",
                "autoreset_mode": "Disabled",
                "reevaluation": "fresh single env, one step",
            },
        },
        versions={**package_versions(), "tandem_env": tandem_env.__version__},
        key=job.key,
        job=job.to_dict(),
    )


def _same(a: float, b: float) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b or math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)
