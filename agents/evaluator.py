"""Evaluating batches of normalised actions through a task's native vector env: every batch is
one ``step`` (one env per batch size, reset with the condition first), so a fitness is exactly
the reward an agent would get and one stroke evaluated is one unit of budget (docs/harness.md,
"How a run evaluates strokes").
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from agents.optimiser import Tally
from agents.selection import BestStroke
from agents.tasks import Condition, TaskSpec
from tandem_env.envs.base import as_action_type
from tandem_env.io.files import to_jsonable
from tandem_env.io.progress_bar import Reporter

#: How the harness makes a task's vector env: its native one (one model call per step), each
#: sub-env reset by the harness (with the condition) rather than on its own.
NATIVE_VECTOR_ENV = {"vectorization_mode": "vector_entry_point", "autoreset_mode": "Disabled"}


class BudgetExceededError(RuntimeError):
    """A method asked for more evaluations than its budget."""


@dataclass(frozen=True)
class EvaluatedBatch:
    """What one vector-env step returned for a batch, as (n,) arrays."""

    rewards: np.ndarray
    """Rewards (the penalised objective) [reward units]."""
    objective: np.ndarray
    """The task's raw objective (``info["objective"]``; the reward if the env has none)."""
    feasible: np.ndarray
    """``info["feasible"]`` (all True if the env has none)."""


class VectorEnvEvaluator(Tally, contextlib.AbstractContextManager):
    """Budgeted, batched fitness through the task's native vector env, made with ``env_kwargs`` and
    reset with ``condition`` (``seed`` seeds the first reset). Calling it with actions (n, dim)
    returns their rewards (n,) and counts them: more than ``budget`` raises
    :class:`BudgetExceededError`; ``on_batch(iteration, evaluations, best)`` follows every batch."""

    def __init__(
        self,
        task: TaskSpec,
        condition: Condition,
        env_kwargs: Mapping[str, Any],
        seed: int,
        budget: int,
        on_batch: Reporter | None = None,
    ) -> None:
        super().__init__()
        self.task = task
        self.condition = condition
        self._options = {task.declared_condition.keyword: condition.value}  # each reset's
        self.env_kwargs = dict(env_kwargs)
        self.seed = int(seed)
        self.budget = int(budget)
        self._on_batch = on_batch
        self._envs: dict[int, gym.vector.VectorEnv] = {}
        self._best = BestStroke()
        self._best_stroke_action: np.ndarray | None = None
        self.step_time = 0.0
        """Wall time spent in the vector envs' reset and step [s] (for overhead accounting)."""

    def _env(self, n: int) -> gym.vector.VectorEnv:
        if (env := self._envs.get(n)) is None:
            env = gym.make_vec(self.task.env_id, num_envs=n, **NATIVE_VECTOR_ENV, **self.env_kwargs)
            # the seed only matters for sampled conditions (none here), but a seeded first
            # reset keeps every generator the env owns reproducible
            env.reset(seed=self.seed, options=self._options)
            self._envs[n] = env
        return env

    def close(self) -> None:
        """Close every vector env made so far."""
        for env in self._envs.values():
            env.close()
        self._envs.clear()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def evaluate_batch(self, actions: np.ndarray) -> EvaluatedBatch:
        """Evaluate a batch (n, dim) in one vector-env step, as the action type carries it
        (:func:`~tandem_env.envs.base.as_action_type`); rewards, objectives, feasibility."""
        actions = as_action_type(actions)
        if actions.ndim != 2 or actions.shape[0] < 1:
            raise ValueError(f"actions must have shape (n, dim) with n >= 1; got {actions.shape}")
        if self.evaluations + (n := actions.shape[0]) > self.budget:
            used = f"the budget of {self.budget} ({self.evaluations} used)"
            raise BudgetExceededError(f"{n} more evaluations would exceed {used}")
        start = time.perf_counter()
        env = self._env(n)
        env.reset(options=self._options)
        _, rewards, _, _, infos = env.step(actions)
        self.step_time += time.perf_counter() - start
        # the env reports the condition it used: a wrong one would optimise the wrong problem
        seen = np.asarray(infos.get(self.condition.name, self.condition.value), dtype=np.float64)
        if seen.shape == (n,) and not np.all(seen == self.condition.value):
            raise RuntimeError(
                f"the env evaluated {self.condition.name} = {np.unique(seen)} but the harness "
                f"asked for {self.condition.describe()}"
            )
        rewards = np.asarray(rewards, dtype=np.float64).copy()
        objective = np.asarray(infos.get("objective", rewards), dtype=np.float64)
        feasible = np.asarray(infos.get("feasible", np.ones(n, dtype=bool)), dtype=bool)
        # the best reward so far, feasible or not, as the optimisers count it (the history)
        self.add(actions, rewards)
        # the best stroke by the selection rule (feasible first) too, so the harness can
        # return a stroke that flies (a penalised reward can rank an infeasible one above)
        if (j := self._best.offer(feasible, rewards)) is not None:
            self._best_stroke_action = actions[j].copy()
        if self._on_batch is not None:
            self._on_batch(self.iterations, self.evaluations, self.best_value)
        return EvaluatedBatch(rewards, objective, feasible)

    def __call__(self, actions: np.ndarray) -> np.ndarray:
        """Rewards (n,) of a batch of actions (n, dim): the fitness a method maximises."""
        return self.evaluate_batch(actions).rewards

    @property
    def best_feasible(self) -> tuple[np.ndarray, float] | None:
        """(action, reward) of the best feasible stroke so far (a copy), or None if none was
        (by the selection rule, :mod:`agents.selection`)."""
        if self._best_stroke_action is None or not self._best.feasible:
            return None
        return self._best_stroke_action.copy(), self._best.reward


def reevaluate(
    env: gym.Env, task: TaskSpec, condition: Condition, seed: int, action: np.ndarray
) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """Evaluate ``action`` once more in ``env``, a single env of the task reset with ``seed``:
    the same reward as in the search (one shared core), independent of the search's state. Its
    :func:`stepped_results` and the env's configuration as plain JSON (insect, model options,
    penalty, ...; None for an env without one)."""
    env.reset(seed=seed, options={task.declared_condition.keyword: condition.value})
    _, reward, _, _, info = env.step(np.asarray(action, dtype=np.float64))
    config = getattr(env.unwrapped, "config", None)  # a dataclass, as plain JSON, if it has one
    env_config = None
    if config is not None and dataclasses.is_dataclass(config):
        env_config = to_jsonable(config)
        if callable(describe := getattr(config, "describe", None)):
            env_config["description"] = describe()
    return stepped_results(reward, info, action), env_config


def stepped_results(reward: float, info: Mapping[str, Any], action: Sequence[float]) -> dict:
    """The record's results that one env step of its stroke decides
    (:data:`agents.verify.CHECKED`): the record (:func:`agents.harness.run_job`) and its check
    (:mod:`agents.verify`) read a step one way."""
    info = dict(info)
    stroke = info.pop("stroke", None)
    if stroke is None:  # a task of another action (a plug-in) names its values a0, a1, ...
        stroke = {f"a{j}": float(v) for j, v in enumerate(action)}
    return {
        "reward": float(reward),
        "objective": float(info.get("objective", reward)),
        "feasible": bool(info.get("feasible", True)),
        "stroke": to_jsonable(stroke),
        "metrics": to_jsonable(info),
    }
