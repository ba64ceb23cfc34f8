"""A harness run's budget in parts (:func:`plan_parts`: per search and per initial stroke):
:func:`search_part` searches, selects and polishes; :func:`initial_part` polishes an initial
stroke; :func:`finish_part` finishes the chosen part's polish by autograd (:func:`finish`);
:class:`PreparedJob` is the validated job.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from agents.evaluator import VectorEnvEvaluator
from agents.jobs import Job
from agents.methods import Method, SearchContext, SearchOutcome
from agents.polish import (
    AutogradGradient,
    Certificate,
    PolishConfig,
    PolishResult,
    Problem,
    certified,
    finishable,
    polish,
)
from agents.records import (
    SELECTION_BEST_FEASIBLE,
    SELECTION_BEST_REWARD,
    SELECTION_INITIAL,
    SELECTION_INITIAL_POLISHED,
    SELECTION_METHOD,
    SELECTION_POLISHED,
    SELECTION_REWARD_POLISHED,
)
from agents.tasks import Condition, TaskSpec
from tandem_env.io.progress_bar import Reporter


@dataclass(frozen=True, eq=False)
class PreparedJob:
    """A validated job, resolved into what running it needs (:func:`agents.harness.prepare_job`)."""

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
    polish: PolishConfig = field(default_factory=lambda: PolishConfig(method="none"))
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
    """One search on ``budget`` evaluations (less the polish's share), then its polish."""
    seed = prepared.job.seed  # part 0's (one start is the plain run); the others spawn from it
    if index > 0:
        seed = int(np.random.SeedSequence([seed, index]).generate_state(1)[0])
    reserve = prepared.polish.reserve(budget, gradient_cost(prepared.dim, prepared.task))
    outcome, evaluator = _search(
        prepared, seed, budget - reserve, lambda i, e, best: report(i, offset + e, best)
    )
    found = _select(outcome, evaluator, seed)
    return _polish(prepared, found, budget - outcome.evaluations, reserve, problem)


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
    feasible = feasible and objective is not None
    seed = prepared.job.seed
    return Part(
        "initial", seed, result.stroke, reward, feasible, selection, certificate, evaluations
    )


def finish_part(
    prepared: PreparedJob, part: Part, allowance: int, problem: Callable[[], Problem]
) -> Part:
    """The run's chosen part with its polish finished by autograd where it ended short of the
    KKT stop (:func:`finish`), on the ``allowance`` the parts left of the
    budget (each kept ``polish_finish`` of its polish's back for it): the reported stroke is
    the one certified, so one finish serves the run, however many parts it has."""
    ran = part.certificate.method != "none" and part.certificate.iterations > 0
    if not prepared.polish.enabled or not part.feasible or not ran or certified(part.certificate):
        return part  # nothing to finish: the problem is not built
    started = PolishResult(part.action, part.reward, part.certificate, feasible=True)
    done = finish(problem(), started, allowance, prepared.polish)
    if done is started:
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
    improved = more.improved or result.improved
    gain = first.gain
    if more.improved and before is not None and first.gain is not None and before != 0.0:
        gain = (more.objective - before) / abs(before)
    certificate = replace(
        last,
        status="improved" if improved else first.status,
        gain=gain,
        objective_before=before,
        objective_after=more.objective if more.improved else first.objective_after,
        evaluations=first.evaluations + last.evaluations,
        allowance=first.allowance + last.allowance,
        iterations=first.iterations + last.iterations,
        gradient=f"{first.gradient}, then {last.gradient}",
    )
    stroke = more.stroke if more.improved else result.stroke
    objective = more.objective if more.improved else result.objective
    return PolishResult(stroke, objective, certificate, feasible=True)


def gradient_cost(dim: int, task: TaskSpec) -> int:
    """Model evaluations of one central-difference gradient: the point and two neighbours per
    continuous coordinate."""
    return 1 + 2 * (dim - len(task.discrete_actions))


def _gradient(prepared: PreparedJob, problem: Any) -> AutogradGradient | None:
    # the torch backend differentiates: one model evaluation per gradient instead of 2k + 1
    return AutogradGradient(problem) if prepared.env_kwargs.get("backend") == "torch" else None


def search_history(parts: list[Part]) -> list[tuple[int, float]]:
    """The searches' (evaluations, best reward so far) one after another, over the whole run."""
    history: list[tuple[int, float]] = []
    offset, best = 0, -math.inf
    for part in parts:
        if part.outcome is not None:
            for evaluations, value in part.outcome.history:
                best = max(best, value)
                history.append((offset + evaluations, best))
        offset += part.evaluations
    return history


def _polish(
    prepared: PreparedJob,
    part: Part,
    allowance: int,
    reserve: int,
    job_problem: Callable[[], Problem],
) -> Part:
    """The search's part polished on ``allowance`` evaluations, with its certificate."""
    config = prepared.polish
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
    infeasible = part.selection == SELECTION_BEST_REWARD
    problem = job_problem()
    gradient = _gradient(prepared, problem)
    result = polish(problem, part.action, allowance, config, gradient, infeasible_start=infeasible)
    evaluations = part.evaluations + result.certificate.evaluations
    part = replace(part, certificate=result.certificate, evaluations=evaluations)
    if not result.improved:
        return part
    # accepted strokes pass the task's feasibility test, so their reward is their objective
    polished = SELECTION_REWARD_POLISHED if infeasible else SELECTION_POLISHED
    return replace(
        part, action=result.stroke, reward=result.objective, feasible=True, selection=polished
    )


def _select(outcome: SearchOutcome, evaluator: VectorEnvEvaluator, seed: int) -> Part:
    """The search's part, unpolished: its best feasible stroke, else its best reward's."""
    found = (outcome.best_action, outcome.best_reward, False, SELECTION_BEST_REWARD)
    if evaluator.evaluations < outcome.evaluations:
        # the method evaluated strokes through its own envs (SB3): it chooses, by the same rule
        # (train/policies.py)
        found = (*found[:3], SELECTION_METHOD)
    elif evaluator.best_feasible is not None:
        found = (*evaluator.best_feasible, True, SELECTION_BEST_FEASIBLE)
    return Part("search", seed, *found, Certificate.off(), outcome.evaluations, outcome)


def _search(
    prepared: PreparedJob, seed: int, budget: int, report: Reporter
) -> tuple[SearchOutcome, VectorEnvEvaluator]:
    """The method's search through the budgeted vector-env evaluator, checked."""
    job, task, kwargs, dim = prepared.job, prepared.task, prepared.env_kwargs, prepared.dim
    with VectorEnvEvaluator(task, prepared.condition, kwargs, seed, budget, report) as evaluator:
        where = (task, prepared.condition, task.env_id, kwargs)
        context = SearchContext(*where, budget, seed, dim, evaluator, report)
        outcome = prepared.method.search(context)
    if not evaluator.evaluations <= outcome.evaluations <= budget:
        raise RuntimeError(
            f"{job.method} reported {outcome.evaluations} evaluations; it made "
            f"{evaluator.evaluations} through the harness and its budget is {budget}"
        )
    if outcome.best_action.shape != (dim,):
        raise RuntimeError(
            f"{job.method} returned a stroke of shape {outcome.best_action.shape}; "
            f"the action space has dimension {dim}"
        )
    return outcome, evaluator
