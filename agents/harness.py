"""The one entry point that runs a search method on a task and records what it found.

::

    from agents.harness import run

    records = run("pso", "level", 1.5, budget=12_000, seeds=[0, 1, 2], out_dir="results/x")

For each seed the method searches the task's normalised action box [-1, 1]^28 with the given
budget of model evaluations, evaluating every batch through the task's native vector env (one
batched model call per iteration; fitness = the env's reward, the penalised objective an RL
agent sees). The best stroke is then re-evaluated in a fresh single env and a
:class:`~agents.run_record.Record` is built from that re-evaluation. With ``out_dir`` each
record is written atomically as it completes (a killed run keeps the finished seeds and leaves
no partial file), and ``summary.csv`` there is rewritten over every record in the directory.

:func:`prepare` validates everything (task, condition, env kwargs, method, budget, seeds)
before any work and returns a :class:`RunPlan`; :func:`execute` runs it; :func:`run` does both.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import gymnasium as gym
import numpy as np

import tandem_env
from agents.evaluator import VectorEnvEvaluator, reevaluate
from agents.methods import Method, SearchContext, SearchOutcome, get_method
from agents.progress import ProgressBar
from agents.records import package_versions, to_jsonable
from agents.run_record import (
    SELECTION_BEST_FEASIBLE,
    SELECTION_BEST_REWARD,
    SELECTION_METHOD,
    Record,
    load_records,
    write_summary,
)
from agents.tasks import Condition, TaskSpec, get_task

__all__ = ["SUMMARY_NAME", "RunPlan", "execute", "prepare", "run", "run_seed"]

#: File name of the CSV summary written next to the records.
SUMMARY_NAME = "summary.csv"


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
    progress: bool = True
    out_dir: Path | None = None

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
    progress: bool = True,
    out_dir: str | os.PathLike[str] | None = None,
) -> RunPlan:
    """Validate a run and return its plan; raises ValueError saying what is wrong and allowed.

    Parameters are those of :func:`run`. Building the env once here lets it reject bad
    keywords and out-of-range conditions before any evaluation.
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
        progress=bool(progress),
        out_dir=None if out_dir is None else Path(out_dir),
    )


def execute(plan: RunPlan) -> list[Record]:
    """Run every seed of ``plan``; write records (and the summary) when it has an out_dir."""
    records = []
    for seed in plan.seeds:
        record = run_seed(plan, seed)
        records.append(record)
        if plan.out_dir is not None:
            record.save(plan.out_dir)
            # Over the whole directory, so one summary covers every method run into it.
            write_summary(plan.out_dir / SUMMARY_NAME, load_records([plan.out_dir]))
    return records


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
        Write each record there (atomically) and ``summary.csv`` over the directory.
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
    """The stroke a record reports: the best feasible stroke the search evaluated, if any.

    A feasible stroke's reward is exactly its objective, so among feasible strokes the best
    reward is the best objective; a penalised reward can still rank a marginally infeasible
    stroke above all of them, which would report a stroke that does not fly.
    """
    if evaluator.evaluations < outcome.evaluations:
        # the method evaluated (some) strokes through its own envs (SB3): it chooses, by the
        # same rule (train/policies.py)
        return outcome.best_action, outcome.best_reward, SELECTION_METHOD
    best_feasible = evaluator.best_feasible
    if best_feasible is None:
        return outcome.best_action, outcome.best_reward, SELECTION_BEST_REWARD
    action, reward = best_feasible
    return action, reward, SELECTION_BEST_FEASIBLE


def run_seed(plan: RunPlan, seed: int) -> Record:
    """Search with one seed, re-evaluate the best stroke and build its record."""
    start = time.perf_counter()
    label = f"{plan.method_spec} {plan.task.name} {plan.condition.name}={plan.condition.value:g} seed {seed}"
    with (
        ProgressBar(plan.budget, label, plan.progress) as bar,
        VectorEnvEvaluator(
            plan.task, plan.condition, plan.env_kwargs, seed, plan.budget, bar.update
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
            _reporter=bar.update,
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
        stroke=_plain(stroke),
        normalised_stroke=tuple(action.tolist()),
        metrics=_plain(info),
        history=outcome.history,
        wall_time=wall_time,
        config={
            "method": _plain(outcome.config),
            "env_kwargs": _plain(dict(plan.env_kwargs)),
            "env": _plain(again.env_config),
            "evaluation": {
                "vectorization_mode": "vector_entry_point",
                "autoreset_mode": "Disabled",
                "reevaluation": "fresh single env, one step",
            },
        },
        versions={**package_versions(), "tandem_env": tandem_env.__version__},
    )


def _same(a: float, b: float) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b or math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)


def _plain(obj: Any) -> Any:
    """JSON-ready form; dataclasses (e.g. a Dragonfly in env_kwargs) become dicts."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return _plain(dataclasses.asdict(obj))
    if isinstance(obj, Mapping):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_plain(v) for v in obj]
    return to_jsonable(obj)
