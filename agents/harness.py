"""The one path that runs a search method on a task and records what it found.

::

    from agents.harness import run

    records = run("pso", "level", 1.5, budget=12_000, seeds=[0, 1, 2])

:func:`prepare_job` validates a :class:`~agents.jobs.Job` once, before any evaluation, into a
:class:`PreparedJob`; :func:`run_job` runs it and returns its record, writing nothing. Its budget
comes in parts (:func:`plan_parts`: per search and per initial stroke): :func:`search_part`
searches, selects and polishes, :func:`initial_part` polishes an initial stroke,
:func:`finish_part` finishes the chosen part's polish by autograd (:func:`finish`). The reported
stroke (:mod:`agents.selection`), polished (:mod:`agents.polish`), is re-evaluated in the job's
single env, and the record's results come from that (docs/harness.md).
"""

from __future__ import annotations

import functools
import math
import time
import warnings
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import gymnasium as gym
import numpy as np
from threadpoolctl import threadpool_limits

from agents.evaluator import VectorEnvEvaluator, reevaluate
from agents.jobs import Job
from agents.methods import Method, SearchContext, SearchOutcome, get_method
from agents.polish import (
    AutogradGradient,
    Certificate,
    PolishConfig,
    PolishResult,
    Problem,
    certified,
    finishable,
    polish,
    split_settings,
    task_problem,
)
from agents.polish_config import env_problem, polishable
from agents.records import (
    CERTIFICATE,
    SELECTION_BEST_FEASIBLE,
    SELECTION_BEST_REWARD,
    SELECTION_INITIAL,
    SELECTION_INITIAL_POLISHED,
    SELECTION_METHOD,
    SELECTION_POLISHED,
    SELECTION_REWARD_POLISHED,
    STARTS,
    Record,
    package_versions,
)
from agents.tasks import Condition, TaskSpec, get_task
from tandem_env.envs.base import ACTION_HIGH, ACTION_LOW, as_action_type
from tandem_env.io.files import to_jsonable
from tandem_env.io.progress_bar import ProgressBar, Reporter


@dataclass(frozen=True, eq=False)
class PreparedJob:
    """A validated job, resolved into what running it needs (:func:`prepare_job`)."""

    job: Job
    method: Method
    task: TaskSpec
    condition: Condition
    env_kwargs: Mapping[str, Any]
    """Env constructor keywords, including the condition (and objective) keyword."""
    objective_name: str
    """The ``info`` metric the task maximises under these keywords."""
    dim: int
    """Dimension of the action box."""
    polish: PolishConfig
    """The local polish after the search (its settings are the ``polish*`` method settings)."""

    def describe(self) -> str:
        """E.g. ``pso on level (efficiency) at speed = 1.5 m/s, budget 12000 evaluations``."""
        return (
            f"{self.job.method} on {self.task.name} ({self.objective_name}) at "
            f"{self.condition.describe()}, budget {self.job.budget} evaluations"
        )


@dataclass(frozen=True)
class Part:
    """What one part of a run's budget found: a search (polished) or a polished initial stroke."""

    kind: str
    seed: int
    action: np.ndarray
    reward: float
    """Its reward as the search or the polish saw it (the objective where it is feasible)."""
    feasible: bool
    selection: str
    certificate: Certificate
    evaluations: int
    outcome: SearchOutcome | None = None

    def summary(self) -> dict[str, Any]:
        """The part's line in the record's ``starts``."""
        own = ("kind", "seed", "evaluations", "reward", "feasible", "selection")
        row = {name: getattr(self, name) for name in own}
        return row | {"polish": self.certificate.status, "gain": self.certificate.gain}


def plan_parts(config: PolishConfig, budget: int) -> list[tuple[str, int, np.ndarray | None]]:
    """A run's parts: (kind, budget, initial stroke), initial strokes first; the budget split
    evenly, or ``initial_share`` of it over the initial strokes (remainders to the last)."""
    initial = [("initial", np.asarray(s)) for s in config.initial]
    searches: list[tuple[str, np.ndarray | None]] = [("search", None)] * config.starts
    if config.initial_share is None:
        groups = [(initial + searches, budget)]
    else:
        first = round(config.initial_share * budget)
        groups = [(initial, first), (searches, budget - first)]
    plan = []
    for parts, total in groups:
        share, rest = divmod(total, len(parts))
        for k, (kind, stroke) in enumerate(parts):
            plan.append((kind, share + (rest if k == len(parts) - 1 else 0), stroke))
    return plan


def search_part(
    prepared: PreparedJob,
    index: int,
    budget: int,
    offset: int,
    report: Reporter,
    problem: Callable[[], Problem],
) -> Part:
    """One search on ``budget`` evaluations less the polish's share, through the budgeted
    vector-env evaluator and checked (its best feasible stroke, else its best reward's), then
    its polish on what the search left, with its certificate."""
    job, task, kwargs, dim = prepared.job, prepared.task, prepared.env_kwargs, prepared.dim
    seed = job.seed  # part 0's (one start is the plain run); the others spawn from it
    if index > 0:
        seed = int(np.random.SeedSequence([seed, index]).generate_state(1)[0])
    reserve = (config := prepared.polish).reserve(budget, gradient_cost(dim, task))
    searched = budget - reserve

    def on_batch(iteration: int, evaluations: int, best: float) -> None:  # over the whole run
        report(iteration, offset + evaluations, best)

    evaluator = VectorEnvEvaluator(task, prepared.condition, kwargs, seed, searched, on_batch)
    with evaluator:
        where = (task, prepared.condition, task.env_id, kwargs)
        context = SearchContext(*where, searched, seed, dim, evaluator, on_batch)
        outcome = prepared.method.search(context)
    if not evaluator.evaluations <= outcome.evaluations <= searched:
        raise RuntimeError(
            f"{job.method} reported {outcome.evaluations} evaluations; it made "
            f"{evaluator.evaluations} through the harness and its budget is {searched}"
        )
    if outcome.best_action.shape != (dim,):
        raise RuntimeError(
            f"{job.method} returned a stroke of shape {outcome.best_action.shape}; "
            f"the action space has dimension {dim}"
        )
    found = (outcome.best_action, outcome.best_reward, False, SELECTION_BEST_REWARD)
    if evaluator.evaluations < outcome.evaluations:
        # the method evaluated strokes through its own envs (SB3): it chooses, by the same rule
        # (train/policies.py)
        found = (*found[:3], SELECTION_METHOD)
    elif evaluator.best_feasible is not None:
        found = (*evaluator.best_feasible, True, SELECTION_BEST_FEASIBLE)
    part = Part("search", seed, *found, Certificate.off(), outcome.evaluations, outcome)
    if not config.enabled:
        return part
    if reserve == 0 or part.selection == SELECTION_METHOD:
        why = "the method evaluates through its own envs"
        if reserve == 0:
            why = "the budget's polish share is below two gradients"
        certificate = Certificate(method=config.method, status=f"not applicable: {why}")
        return replace(part, certificate=certificate)
    # A search that saw no feasible stroke hands over its best-reward one, and the polish starts
    # there all the same, as from an initial stroke: a policy's stroke a hair outside a margin,
    # or a short search's, is moved onto the constraints.
    infeasible, made = part.selection == SELECTION_BEST_REWARD, problem()
    gradient = _gradient(prepared, made)
    allowance = budget - part.evaluations
    result = polish(made, part.action, allowance, config, gradient, infeasible_start=infeasible)
    evaluations = part.evaluations + result.certificate.evaluations
    part = replace(part, certificate=result.certificate, evaluations=evaluations)
    if not result.improved:
        return part
    # accepted strokes pass the task's feasibility test, so their reward is their objective
    polished = SELECTION_REWARD_POLISHED if infeasible else SELECTION_POLISHED
    return replace(
        part, action=result.stroke, reward=result.objective, feasible=True, selection=polished
    )


def initial_part(
    prepared: PreparedJob, budget: int, stroke: np.ndarray | None, problem: Problem
) -> Part:
    """One initial stroke polished on ``budget`` evaluations (it may start infeasible)."""
    assert stroke is not None
    gradient = _gradient(prepared, problem)
    result = polish(problem, stroke, budget, prepared.polish, gradient, infeasible_start=True)
    certificate = result.certificate
    evaluations = certificate.evaluations
    objective, feasible = certificate.objective_after, result.feasible
    if objective is None and budget >= 1:
        # an allowance too small to polish: the stroke is reported as given, evaluated once
        # so that its feasibility is known
        batch = problem.evaluate(np.asarray(result.stroke, dtype=np.float64)[None, :])
        objective, feasible = float(batch.objective[0]), bool(batch.feasible[0])
        evaluations += 1
    reward = float(objective) if objective is not None and feasible else -math.inf
    selection = SELECTION_INITIAL_POLISHED if result.improved else SELECTION_INITIAL
    found = (result.stroke, reward, feasible and objective is not None, selection)
    return Part("initial", prepared.job.seed, *found, certificate, evaluations)


def finish_part(
    prepared: PreparedJob, part: Part, allowance: int, problem: Callable[[], Problem]
) -> Part:
    """The run's chosen part with its polish finished by autograd where it ended short of the
    KKT stop (:func:`finish`), on the ``allowance`` the parts left of the
    budget (each kept ``polish_finish`` of its polish's back for it): the reported stroke is
    the one certified, so one finish serves the run, however many parts it has."""
    if not part.feasible or part.certificate.iterations == 0:  # finish checks the rest
        return part  # no climb: nothing to finish, the problem is not built
    started = PolishResult(part.action, part.reward, part.certificate, feasible=True)
    if (done := finish(problem(), started, allowance, prepared.polish)) is started:
        return part
    evaluations = part.evaluations + done.certificate.evaluations - part.certificate.evaluations
    selection = part.selection
    if done.certificate.status == "improved" and part.certificate.status != "improved":
        selection = SELECTION_INITIAL_POLISHED if part.kind == "initial" else SELECTION_POLISHED
    found = {"action": done.stroke, "reward": done.objective, "certificate": done.certificate}
    return replace(part, evaluations=evaluations, selection=selection, **found)


def finish(
    problem: Problem, result: PolishResult, budget: int, config: PolishConfig
) -> PolishResult:
    """``result``, a polish by central differences that ended short of the KKT stop (where the
    model's second derivative jumps within a step), polished on with autograd gradients (one
    evaluation each) on ``budget`` more evaluations; ``result`` itself where it is certified,
    infeasible, not :func:`finishable` or ``budget`` is below two gradients. The certificate
    covers both: evaluations, allowance and iterations summed, the stop and the KKT check the
    finish's, ``gradient`` ``"central differences, then autograd"``."""
    first = result.certificate
    if (
        certified(first)
        or not result.feasible
        or first.method == "none"
        or first.status.startswith("not applicable")
        or not finishable(problem, first.gradient, config)
        or budget < 2
    ):
        return result
    try:
        # one stroke is too small a tensor for threads to gain (and waiting threads cost):
        # torch's OpenMP pool on one thread, restored afterwards
        gradient = AutogradGradient(problem)
        with threadpool_limits(limits=1, user_api="openmp"):
            more = polish(problem, result.stroke, budget, config, gradient, keep_certified=True)
        failed = more.certificate.status
    except (ValueError, FloatingPointError, np.linalg.LinAlgError) as error:
        failed = f"failed: {type(error).__name__}: {error}"
    if failed.startswith("failed"):
        message = f"{first.message}; the finish {failed}"
        return replace(result, certificate=replace(first, message=message))
    last = more.certificate
    before = first.objective_before
    gain = first.gain
    if more.improved and before is not None and first.gain is not None and before != 0.0:
        gain = (more.objective - before) / abs(before)
    certificate = replace(
        last,
        status="improved" if more.improved or result.improved else first.status,
        gain=gain,
        objective_before=before,
        objective_after=more.objective if more.improved else first.objective_after,
        evaluations=first.evaluations + last.evaluations,
        allowance=first.allowance + last.allowance,
        iterations=first.iterations + last.iterations,
        gradient=f"{first.gradient}, then {last.gradient}",
    )
    kept = more if more.improved else result
    return PolishResult(kept.stroke, kept.objective, certificate, feasible=True)


def gradient_cost(dim: int, task: TaskSpec) -> int:
    """Model evaluations of one central-difference gradient: the point and two neighbours per
    continuous coordinate."""
    return 1 + 2 * (dim - len(task.discrete_actions))


def _gradient(prepared: PreparedJob, problem: Any) -> AutogradGradient | None:
    # the torch backend differentiates: one model evaluation per gradient instead of 2k + 1
    return AutogradGradient(problem) if prepared.env_kwargs.get("backend") == "torch" else None


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
        if {"polish", "initial"} & set(dict(job.method_config)):
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
    if callable(check := getattr(method_obj, "check", None)):
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
        if (keyword := spec.declared_objectives.keyword) is None:
            raise ValueError(
                f"task {spec.name!r} has one objective ({spec.declared_objectives.default}); "
                "objective cannot be chosen"
            )
        if (given := kwargs.get(keyword)) is not None and given != objective:
            raise ValueError(f"objective = {objective!r} but env_kwargs[{keyword!r}] = {given!r}")
        kwargs[keyword] = objective
    if not (seed_list := list(seeds)):
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
    each part of the budget (:func:`plan_parts`), re-evaluate the best feasible stroke of all
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
        seed, action = prepared.job.seed, chosen.action
        again, env_config = reevaluate(env, prepared.task, prepared.condition, seed, action)
        if not chosen.feasible and chosen.kind == "initial":
            # an infeasible initial stroke has no search reward: the re-evaluation's is its own
            chosen = replace(chosen, reward=again["reward"])
        search_reward = chosen.reward
        # the searches' (evaluations, best reward so far) one after another, over the whole run
        history: list[list[int | float]] = []
        offset, best = 0, -math.inf
        for part in parts:
            for e, value in () if part.outcome is None else part.outcome.history:
                best = max(best, value)
                history.append([int(offset + e), float(best)])
            offset += part.evaluations
        if not np.isclose(again["reward"], search_reward, rtol=1e-12, atol=1e-12, equal_nan=True):
            differs = f"re-evaluated reward {again['reward']!r} differs from the search's"
            message = f"{prepared.job.label()}: {differs} {search_reward!r}"
            warnings.warn(message, RuntimeWarning, stacklevel=2)
        # the record's results (:data:`agents.records.RESULTS`) from the re-evaluation
        results = {
            "env_id": prepared.task.env_id,
            "objective_name": prepared.objective_name,
            "condition_name": prepared.condition.name,
            "condition_unit": prepared.condition.unit,
            "evaluations": int(evaluations),
            **again,  # what a reuse checks again
            "search_reward": search_reward,
            "selection": chosen.selection,
            "normalised_stroke": action.tolist(),
            "history": history,
            "wall_time": time.perf_counter() - start,
            # a polished initial stroke: the method did not run there, so its name only
            "method_settings": to_jsonable(
                {"algorithm": prepared.job.method, "note": "initial stroke polished; no search"}
                if chosen.outcome is None
                else chosen.outcome.config
            ),
            "env": env_config,
            "versions": package_versions(),
            CERTIFICATE: chosen.certificate.to_dict(),
            **({STARTS: [part.summary() for part in parts]} if len(parts) > 1 else {}),
        }
        return Record(job=prepared.job, key=prepared.job.key, results=results)
