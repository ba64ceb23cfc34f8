"""What the local polish optimises (:class:`Problem`, :func:`task_problem`) and its gradients:
:class:`CentralDifferences` (2k + 1 strokes in ONE model call), :class:`AutogradGradient` (ONE
torch evaluation); ``cost`` counts model evaluations against the polish's allowance
(docs/harness.md, "Local polish")."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

from agents.polish_config import PolishConfig
from agents.tasks import Condition, TaskSpec
from tandem_env.envs.problem import FlightProblem, ProblemEvaluation


@dataclass(frozen=True)
class BatchEvaluation:
    """What one batched model call gives for n strokes."""

    objective: np.ndarray
    """(n,) the task's objective, maximised [objective units]."""
    margins: np.ndarray
    """(n, m) signed constraint margins, >= 0 where a constraint holds [-]."""
    feasible: np.ndarray
    """(n,) bool, the task's exact feasibility test."""
    names: tuple[str, ...]
    """The m constraints' names."""


DifferentiateFunction = Callable[[np.ndarray], tuple[BatchEvaluation, np.ndarray, np.ndarray]]
"""Evaluates normalised strokes (n, dim) in one differentiable model call: the evaluation, the
objective's gradient (n, dim) and the margins' Jacobian (n, m, dim) w.r.t. every coordinate."""


@dataclass(frozen=True)
class Problem:
    """A maximisation over the box [-1, 1]^dim with constraints, some coordinates fixed."""

    evaluate: Callable[[np.ndarray], BatchEvaluation]
    """Evaluates normalised strokes (n, dim) in one model call."""
    dim: int
    free: tuple[int, ...]
    """The coordinates the polish moves (the others stay at the start's values)."""
    parameter_names: tuple[str, ...] = ()
    """Names of the dim coordinates (for the certificate's active bounds); default x0, x1..."""
    differentiate: DifferentiateFunction | None = None
    """The same evaluation with derivatives (autograd), or None where the model has none."""

    def __post_init__(self) -> None:
        if not self.free or any(not 0 <= j < self.dim for j in self.free):
            raise ValueError(f"free = {self.free!r}; allowed: indices in [0, {self.dim})")
        if not self.parameter_names:
            object.__setattr__(self, "parameter_names", tuple(f"x{j}" for j in range(self.dim)))


def env_problem(env: gym.Env) -> FlightProblem | None:
    """The optimisation problem ``env`` offers (its ``problem()``), or None for none."""
    view = getattr(env.unwrapped, "problem", None)
    return view() if callable(view) else None


def polishable(problem: FlightProblem | None) -> bool:
    """A task the polish can run on: one with constraints, each with a signed margin."""
    return problem is not None and bool(problem.constraints) and problem.has_margins


def task_problem(
    task: TaskSpec, condition: Condition, env_kwargs: Mapping[str, Any], env: gym.Env | None = None
) -> Problem:
    """The polish problem of a harness task: its env's problem view (:func:`env_problem`) at
    ``condition``, so the polish optimises exactly what the env rewards; free coordinates
    those not in ``task.discrete_actions``; ``env``, if given,
    is used (and left open) instead of making one."""
    with contextlib.ExitStack() as stack:
        if env is None:
            env = gym.make(task.env_id, disable_env_checker=True, **dict(env_kwargs))
            stack.callback(env.close)
        view = env_problem(env)
    if view is None or not polishable(view):
        raise ValueError(f"{task.env_id}: its task declares no constraint margins; cannot polish")
    names = view.constraint_names

    def batch(found: ProblemEvaluation) -> BatchEvaluation:
        assert found.margins is not None  # polishable: every constraint has a margin
        return BatchEvaluation(found.objective, found.margins, found.feasible, names)

    def evaluate(actions: np.ndarray) -> BatchEvaluation:
        return batch(view.evaluate(actions, condition.value))

    def differentiate(actions: np.ndarray) -> tuple[BatchEvaluation, np.ndarray, np.ndarray]:
        found = view.differentiate(actions, condition.value)
        return batch(found.evaluation), found.objective_gradient, found.margin_jacobian

    discrete = {i for i, _ in task.discrete_actions}
    free = tuple(j for j in range(view.dim) if j not in discrete)
    return Problem(evaluate, view.dim, free, view.parameter_names, differentiate)


@dataclass(frozen=True)
class Gradient:
    """Value and first derivatives at one point, w.r.t. the free coordinates."""

    objective: float
    margins: np.ndarray
    """(m,)"""
    feasible: bool
    objective_gradient: np.ndarray
    """(k,) d objective / d x_free."""
    jacobian: np.ndarray
    """(m, k) d margins / d x_free."""
    names: tuple[str, ...]
    evaluations: int
    """Model evaluations it took (at most its function's ``cost``)."""


class GradientFunction(Protocol):
    """``gradient(x) -> Gradient`` at the full point x (dim,); ``cost``: model evaluations per call
    at most (kept back; ``Gradient.evaluations`` are counted); ``name`` for the certificate."""

    cost: int
    name: str

    def __call__(self, x: np.ndarray) -> Gradient: ...


@dataclass(frozen=True)
class CentralDifferences:
    """Central differences of a :class:`Problem`: x and x ± h e_j for every free j in ONE call
    (at a bound the step is cut to stay inside [-1, 1], one-sided: ``cost`` is the most, a
    point on k' bounds takes 2k + 1 − k')."""

    problem: Problem
    step: float = 1e-5
    cost: int = field(init=False)
    name: str = field(init=False, default="central differences")

    def __post_init__(self) -> None:
        object.__setattr__(self, "cost", 1 + 2 * len(self.problem.free))

    def __call__(self, x: np.ndarray) -> Gradient:
        x = np.asarray(x, dtype=np.float64)
        free = np.asarray(self.problem.free)
        k = free.size
        up = np.minimum(x[free] + self.step, 1.0)
        down = np.maximum(x[free] - self.step, -1.0)
        # On a bound that side's neighbour is x itself: row 0, not evaluated twice (an optimum
        # has a dozen bounds active, a fifth of the 53 strokes).
        moved = np.concatenate([up, down]) != np.tile(x[free], 2)
        rows = np.zeros(2 * k, dtype=int)
        rows[moved] = 1 + np.arange(moved.sum())
        points = np.repeat(x[None, :], 1 + moved.sum(), axis=0)
        points[rows[moved], np.tile(free, 2)[moved]] = np.concatenate([up, down])[moved]
        batch = self.problem.evaluate(points)
        width = up - down
        d_obj = (batch.objective[rows[:k]] - batch.objective[rows[k:]]) / width
        d_margins = (batch.margins[rows[:k]] - batch.margins[rows[k:]]) / width[:, None]
        return _gradient(batch, d_obj, d_margins.T, len(points))


@dataclass(frozen=True)
class AutogradGradient:
    """The gradient of a :class:`Problem` by autograd: value, objective gradient and margin
    Jacobian from ONE differentiable model evaluation (``problem.differentiate``, the torch
    backend), so ``cost`` is 1."""

    problem: Problem
    cost: int = field(init=False, default=1)
    name: str = field(init=False, default="autograd")

    def __post_init__(self) -> None:
        if self.problem.differentiate is None:
            raise ValueError("AutogradGradient: the problem has no differentiate function")

    def __call__(self, x: np.ndarray) -> Gradient:
        free = np.asarray(self.problem.free)
        differentiate = self.problem.differentiate
        assert differentiate is not None  # checked in __post_init__
        batch, d_obj, d_margins = differentiate(np.asarray(x, dtype=np.float64)[None, :])
        return _gradient(batch, d_obj[0, free], d_margins[0][:, free], 1)


def _gradient(
    batch: BatchEvaluation, d_obj: np.ndarray, jacobian: np.ndarray, evaluations: int
) -> Gradient:
    """The :class:`Gradient` at the batch's first stroke, which took ``evaluations``."""
    value = (float(batch.objective[0]), batch.margins[0].copy(), bool(batch.feasible[0]))
    return Gradient(*value, d_obj.copy(), jacobian.copy(), batch.names, evaluations)


def finishable(problem: Problem, gradient: str, config: PolishConfig) -> bool:
    """A polish by ``gradient`` (its name) keeps ``config.finish`` of its allowance back for
    :func:`agents.harness.finish`: not autograd, ``problem`` differentiates, KKT stop on."""
    return (
        gradient != AutogradGradient.name
        and problem.differentiate is not None
        and config.finish > 0.0
        and config.optimality > 0.0
    )
