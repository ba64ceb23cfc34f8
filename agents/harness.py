"""The one path that runs a search method on a task and records what it found.

::

    from agents.harness import run

    records = run("pso", "level", 1.5, budget=12_000, seeds=[0, 1, 2])

:func:`prepare_job` validates a :class:`~agents.jobs.Job` once, before any evaluation;
:func:`run_job` runs it and returns its record, writing nothing: the reported stroke
(:mod:`agents.selection`), polished (:mod:`agents.polish`), is re-evaluated in the job's single
env, and the record's results come from that (docs/harness.md).
"""

from __future__ import annotations

import functools
import time
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np
from threadpoolctl import threadpool_limits

from agents.evaluator import Reevaluation, reevaluate
from agents.jobs import Job
from agents.methods import Method, get_method
from agents.parts import (
    Part,
    PreparedJob,
    finish_part,
    gradient_cost,
    initial_part,
    plan_parts,
    search_history,
    search_part,
)
from agents.polish_config import split_settings
from agents.polish_gradients import env_problem, polishable, task_problem
from agents.records import CERTIFICATE, STARTS, Record, package_versions
from agents.tasks import TaskSpec, get_task
from agents.verify import stepped_results
from tandem_env.envs.base import ACTION_HIGH, ACTION_LOW, as_action_type
from tandem_env.io.files import to_jsonable
from tandem_env.io.progress_bar import ProgressBar, Reporter


def prepare_job(
    job: Job, *, task: TaskSpec | None = None, method: Method | None = None
) -> PreparedJob:
    """Validate ``job`` and resolve it, making its env once (it rejects bad keywords and
    conditions); ValueError saying what is wrong and allowed. ``task`` and ``method`` are the
    job's when the caller holds them (not in the registries)."""
    spec = get_task(job.task) if task is None else task
    if spec.name != job.task:
        raise ValueError(f"task {spec.name!r} given for a job of task {job.task!r}")
    cond = spec.condition(job.condition)
    kwargs = dict(job.env_kwargs)
    if clash := sorted(set(kwargs) & set(spec.forbidden_kwargs)):
        raise ValueError(
            f"env_kwargs {clash} are set by the harness for task {spec.name!r}; give the "
            f"condition ({cond.name} [{cond.unit}]) as the condition argument"
        )
    objective_name = spec.objective_metric(kwargs)
    kwargs[cond.name] = cond.value
    try:
        env = gym.make(spec.env_id, disable_env_checker=True, **kwargs)
    except gym.error.Error as error:
        raise ValueError(f"cannot make {spec.env_id}: {error}") from error
    with env:
        space = env.action_space
        box = isinstance(space, gym.spaces.Box) and len(space.shape) == 1
        if not (box and np.all(space.low == ACTION_LOW) and np.all(space.high == ACTION_HIGH)):
            raise ValueError(f"{spec.env_id}: action space {space}; allowed: Box(-1, 1, (d,))")
        dim = int(space.shape[0])
        # The polish needs the task's constraints with margins (the env's problem view).
        can_polish = polishable(env_problem(env))
    polish_config, own_config = split_settings(job.method, dict(job.method_config))
    if polish_config.enabled and not can_polish:
        given = dict(job.method_config)
        if "polish" in given or "initial" in given:
            raise ValueError(
                f"polish = {polish_config.method!r}: task {spec.name!r} declares no constraints "
                "with margins for a local polish (Constraint.margin); allowed: 'none'"
            )
        # the default polish needs a flight task
        polish_config = replace(polish_config, method="none")
    if wrong := [len(stroke) for stroke in polish_config.initial if len(stroke) != dim]:
        raise ValueError(
            f"initial stroke of length {wrong[0]}; allowed: {dim} values (the action box)"
        )
    plan = plan_parts(polish_config, job.budget)
    if any(part_budget < 1 for _, part_budget, _ in plan):
        raise ValueError(
            f"budget {job.budget} leaves a part of the run without evaluations ({len(plan)} "
            "parts: starts + initial strokes, split by initial_share if given); allowed: a "
            "budget of at least one evaluation per part"
        )
    # The smallest search part and what its polish keeps back decide what the method can run.
    part = min(part_budget for kind, part_budget, _ in plan if kind == "search")
    reserve = polish_config.reserve(part, gradient_cost(dim, spec))
    method_obj = get_method(job.method, own_config) if method is None else method
    # optional: a method that can tell it cannot run this budget on this box (a budget smaller
    # than one CMA-ES population) says so here, not mid-run
    check = getattr(method_obj, "check", None)
    if callable(check):
        check(part - reserve, dim, spec)
    return PreparedJob(job, method_obj, spec, cond, kwargs, objective_name, dim, polish_config)


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
) -> list[PreparedJob]:
    """The validated jobs, one per seed, of ``method`` (a registered name or a
    :class:`~agents.methods.Method`) on ``task`` at ``condition`` [the task's unit] with
    ``budget`` model evaluations; ``objective``: the task's objective, ``env_kwargs``: further
    ``gym.make`` keywords, ``method_config``: the method's settings, ``preset``: the study preset
    (part of each job's key). ValueError saying what is wrong and allowed.
    """
    spec = get_task(task)
    kwargs = dict(env_kwargs or {})
    if objective is not None:
        keyword = spec.declared_objectives.keyword
        if keyword is None:
            raise ValueError(
                f"task {spec.name!r} has one objective ({spec.declared_objectives.default}); "
                "objective cannot be chosen"
            )
        given = kwargs.get(keyword)
        if given is not None and given != objective:
            raise ValueError(f"objective = {objective!r} but env_kwargs[{keyword!r}] = {given!r}")
        kwargs[keyword] = objective
    seed_list = list(seeds)
    if not seed_list:
        raise ValueError("seeds is empty; allowed: one or more integers >= 0")
    # A method given by name is resolved, its settings checked, with the job (prepare_job).
    method_obj, settings = None, dict(method_config or {})
    if not isinstance(method, str):
        method_obj = get_method(method, split_settings(getattr(method, "name", ""), settings)[1])
    name = method if method_obj is None else method_obj.name
    first = Job(name, spec.name, condition, budget, seed_list[0], kwargs, settings, preset)
    jobs = [first, *(replace(first, seed=seed) for seed in seed_list[1:])]
    if len({job.seed for job in jobs}) != len(jobs):
        raise ValueError(f"seeds {seed_list} repeat; allowed: distinct integers >= 0")
    prepared = prepare_job(first, task=spec, method=method_obj)
    return [replace(prepared, job=job) for job in jobs]


def run(
    method: str | Method,
    task: str | TaskSpec,
    condition: float,
    budget: int,
    seeds: Iterable[int],
    *,
    progress: bool = True,
    **options: Any,
) -> list[Record]:
    """Run :func:`prepare`'s jobs here (a progress bar each if ``progress``); their records,
    stored nowhere."""
    return [
        run_job(job, progress=progress)
        for job in prepare(method, task, condition, budget, seeds, **options)
    ]


def run_job(
    job: Job | PreparedJob, reporter: Reporter | None = None, *, progress: bool = False
) -> Record:
    """Run one job (a plain :class:`~agents.jobs.Job` is validated first): search and polish
    each part of the budget (:mod:`agents.parts`), re-evaluate the best feasible stroke of all
    parts, build its record; writes nothing. Progress goes to ``reporter``, else to a bar of
    its own if ``progress``."""
    prepared = prepare_job(job) if isinstance(job, Job) else job
    start = time.perf_counter()
    with gym.make(prepared.task.env_id, disable_env_checker=True, **prepared.env_kwargs) as env:
        problem = functools.cache(
            lambda: task_problem(prepared.task, prepared.condition, prepared.env_kwargs, env)
        )
        budget = prepared.job.budget
        bar = ProgressBar(budget, prepared.job.label(), progress and reporter is None)
        report = bar.update if reporter is None else reporter
        parts: list[Part] = []
        # One BLAS thread: on d = 28 matrices more only cost (CMA-ES seed 0 at 60 W/kg:
        # 6.9-7.3 s against 5.5 s) and make the optimum depend on the machine's thread count.
        # The model's own threads (numba) are not BLAS threads.
        plan = enumerate(plan_parts(prepared.polish, budget))
        with bar, threadpool_limits(limits=1, user_api="blas"):
            for index, (kind, part_budget, stroke) in plan:
                offset = sum(part.evaluations for part in parts)
                if kind == "search":
                    parts.append(search_part(prepared, index, part_budget, offset, report, problem))
                else:
                    parts.append(initial_part(prepared, part_budget, stroke, problem()))
        index = max(range(len(parts)), key=lambda k: (parts[k].feasible, parts[k].reward))
        left = budget - sum(part.evaluations for part in parts)
        parts[index] = finish_part(prepared, parts[index], left, problem)
        # as the action type carries it, so the record's stroke stepped as a float32 action is
        # this stroke (a no-op for the evaluator's and the polish's strokes)
        chosen = replace(parts[index], action=as_action_type(parts[index].action))
        evaluations = sum(part.evaluations for part in parts)
        if evaluations > budget:  # every part counts its own; never over its share
            raise RuntimeError(f"search and polish used {evaluations} > budget {budget}")
        again = reevaluate(env, prepared.task, prepared.condition, prepared.job.seed, chosen.action)
        if not chosen.feasible and chosen.kind == "initial":
            # an infeasible initial stroke has no search reward: the re-evaluation's is its own
            chosen = replace(chosen, reward=again.reward)
        results = _results(prepared, chosen, parts, again, evaluations)
        results["wall_time"] = time.perf_counter() - start
        return Record(job=prepared.job, key=prepared.job.key, results=results)


def _results(
    prepared: PreparedJob, chosen: Part, parts: list[Part], again: Reevaluation, evaluations: int
) -> dict[str, Any]:
    """The record's results (:data:`agents.records.RESULTS`) from the re-evaluation."""
    action, search_reward, selection = chosen.action, chosen.reward, chosen.selection
    if not np.isclose(again.reward, search_reward, rtol=1e-12, atol=1e-12, equal_nan=True):
        warnings.warn(
            f"{prepared.job.label()}: re-evaluated reward {again.reward!r} differs from the "
            f"search's {search_reward!r}",
            RuntimeWarning,
            stacklevel=3,
        )
    return {
        "env_id": prepared.task.env_id,
        "objective_name": prepared.objective_name,
        "condition_name": prepared.condition.name,
        "condition_unit": prepared.condition.unit,
        "evaluations": int(evaluations),
        **stepped_results(again.reward, again.info, action),  # what a reuse checks again
        "search_reward": search_reward,
        "selection": selection,
        "normalised_stroke": action.tolist(),
        "history": [[int(e), float(b)] for e, b in search_history(parts)],
        "wall_time": 0.0,
        # a polished initial stroke: the method did not run there, so its name only
        "method_settings": to_jsonable(
            {"algorithm": prepared.job.method, "note": "initial stroke polished; no search"}
            if chosen.outcome is None
            else chosen.outcome.config
        ),
        "env": to_jsonable(again.env_config),
        "versions": package_versions(),
        CERTIFICATE: chosen.certificate.to_dict(),
        **({STARTS: [part.summary() for part in parts]} if len(parts) > 1 else {}),
    }
