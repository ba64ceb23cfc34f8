"""The local polish's settings (:class:`PolishConfig`, validated where they enter;
:func:`split_settings` takes them out of a method's settings), what it optimises
(:class:`Problem`, :func:`task_problem`) and its gradients: :class:`CentralDifferences` (2k + 1
strokes in ONE model call), :class:`AutogradGradient` (ONE torch evaluation); ``cost`` counts
model evaluations against the polish's allowance (docs/harness.md, "Local polish")."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from agents.optimiser import check_settings, integer_setting, real_setting
from agents.tasks import Condition, TaskSpec
from tandem_env.envs.declaration import refusal
from tandem_env.envs.problem import FlightProblem, ProblemEvaluation
from tandem_env.physics.checks import count, finite_real, is_real

#: Local optimisers the polish offers ("none": no polish).
POLISH_METHODS: tuple[str, ...] = ("none", "slsqp", "trust-constr")
#: The polish each search method gets when none is given (others: none).
POLISH_DEFAULTS: Mapping[str, str] = {"cmaes": "slsqp", "pso": "slsqp"}
#: Method settings (``method_config`` keys, ``--method-config``) that configure the polish, by
#: the :class:`PolishConfig` field each sets: its numbers as ``polish_<field>``, the run's parts
#: by their own names.
POLISH_SETTINGS: Mapping[str, str] = {
    "polish": "method",
    "polish_iterations": "max_iterations",
    **{f"polish_{name}": name for name in ("share", "step", "tolerance", "optimality", "finish")},
    **{name: name for name in ("starts", "initial", "initial_share")},
}
#: Most independent searches one run may split its budget into (``starts``).
MAX_STARTS = 64
#: Allowed ``initial_share``: the initial strokes' fraction of a run's budget, low and high.
INITIAL_SHARE_RANGE = (0.05, 0.95)


@dataclass(frozen=True)
class PolishConfig:
    """Settings of the local polish (validated here, where they enter: the ranges of its
    numbers are their fields', :func:`~agents.optimiser.check_settings`)."""

    method: str = "slsqp"
    """The scipy optimiser (``minimize(method=...)``, :data:`POLISH_METHODS`); ``"none"``
    turns the polish off."""
    share: float = real_setting(0.01, 0.9, low_inclusive=True, default=0.4)
    """Fraction of the run's budget kept for the polish, in [0.01, 0.9], the search getting the
    rest; chosen by measurement (docs/harness.md, "Local polish")."""
    step: float = real_setting(1e-8, 1e-2, low_inclusive=True, default=1e-5)
    """Central-difference step in normalised units, in [1e-8, 1e-2] (gradients agree to ~1e-7
    relative between 1e-4 and 1e-5)."""
    tolerance: float = real_setting(1e-14, 1e-2, low_inclusive=True, default=1e-14)
    """Stopping tolerance (SLSQP ``ftol``, absolute; trust-constr ``gtol``/``xtol``), in
    [1e-14, 1e-2]: at 1e-10 SLSQP ended level-flight polishes at KKT residuals of 1.2-2.7e-4;
    at 1e-14 they run on to the KKT stop (``optimality``; docs/harness.md, "Certified")."""
    max_iterations: int = integer_setting(1, 10_000, default=200)
    """Optimiser iterations at most, 1 to 10 000."""
    optimality: float = real_setting(0.0, 1e-2, low_inclusive=True, default=1e-5)
    """Stop at the first feasible iterate whose KKT residual (:func:`agents.polish.kkt_residual`)
    is at most this [-] (the certificate then says converged), in [0, 1e-2]; 0: the optimiser's
    own test (``tolerance``), which can stall long after. 1e-5 certified one more of eight seeds
    than 0 at the same budget and optima (docs/harness.md, "Local polish")."""
    finish: float = real_setting(0.0, 0.5, low_inclusive=True, default=0.1)
    """Fraction of a polish's allowance kept back, in [0, 0.5], where it climbs by central
    differences and the problem differentiates: where the run's reported stroke is not
    certified, :func:`agents.harness.finish` polishes it on with autograd gradients on
    what the run left (central differences misread the gradient where the model's second
    derivative jumps within a step); 0: no finish (docs/harness.md, "Certified")."""
    margin: float = real_setting(0.0, 1e-4, low_inclusive=True, default=1e-9)
    """Every constraint is held at margin >= ``margin`` [-] (0 to 1e-4), plus one float32 step
    of every coordinate, so the optimum cast to the action type passes the exact test."""
    active: float = real_setting(0.0, 1e-2, low_inclusive=True, default=1e-6)
    """Distance to its limit [-] within which a constraint or bound counts as active in the
    certificate, 0 to 1e-2."""
    starts: int = 1
    """Independent searches (own seeds, equal parts of the budget, each polished) the run reports
    the best of, 1 to :data:`MAX_STARTS` (docs/harness.md, "Starts and initial strokes")."""
    initial: tuple[tuple[float, ...], ...] = ()
    """Normalised strokes polished directly, each on an equal part of the budget: warm starts
    (feasible or not), e.g. a neighbouring model reading's optimum."""
    initial_share: float | None = None
    """The initial strokes' fraction of the budget together (split evenly), in [0.05, 0.95],
    the searches sharing the rest; None: every part an equal share."""

    def __post_init__(self) -> None:
        if self.method not in POLISH_METHODS:
            raise refusal("polish", self.method, ", ".join(map(repr, POLISH_METHODS)))
        check_settings(self, "polish ")
        object.__setattr__(self, "starts", count(self.starts, "starts", high=MAX_STARTS))
        object.__setattr__(self, "initial", _strokes(self.initial))
        if self.initial_share is not None:
            share = finite_real(self.initial_share, "initial_share", *INITIAL_SHARE_RANGE)
            if not self.initial:
                raise ValueError("initial_share without initial strokes; allowed: with initial")
            object.__setattr__(self, "initial_share", share)
        if self.initial and not self.enabled:
            raise ValueError(
                "initial strokes are polished, but polish = 'none'; allowed: "
                "initial with polish 'slsqp' or 'trust-constr'"
            )

    @property
    def enabled(self) -> bool:
        return self.method != "none"

    def reserve(self, budget: int, gradient_cost: int) -> int:
        """Evaluations of ``budget`` kept for the polish: ``share`` of it, or 0 when it is off
        or that is below two gradients (it could not take one step and check it)."""
        reserve = round(self.share * budget) if self.enabled else 0
        return reserve if reserve >= 2 * gradient_cost else 0

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "initial": [list(stroke) for stroke in self.initial]}


def _strokes(value: Any) -> tuple[tuple[float, ...], ...]:
    """``initial`` as a tuple of strokes of finite values in [-1, 1] (equal lengths)."""
    allowed = "a list of strokes, each a list of numbers in [-1, 1] of the action box's size"
    if isinstance(value, str | bytes) or not isinstance(value, list | tuple):
        raise ValueError(f"initial = {value!r}; allowed: {allowed}")
    strokes = []
    for stroke in value:
        if isinstance(stroke, str | bytes) or not isinstance(stroke, list | tuple | np.ndarray):
            raise ValueError(f"initial stroke {stroke!r}; allowed: {allowed}")
        if bad := [v for v in stroke if not (is_real(v) and math.isfinite(v) and -1 <= v <= 1)]:
            raise ValueError(f"initial stroke value {bad[0]!r}; allowed: {allowed}")
        strokes.append(tuple(float(v) for v in stroke))
    if len(lengths := sorted({len(s) for s in strokes})) > 1:
        raise ValueError(f"initial strokes of lengths {lengths}; allowed: {allowed}")
    return tuple(strokes)


def split_settings(
    method: str, method_config: Mapping[str, Any]
) -> tuple[PolishConfig, dict[str, Any]]:
    """The polish settings among a method's settings (the default polish is the method's,
    :data:`POLISH_DEFAULTS`), and the rest; ValueError naming a bad one."""
    name = method.partition(":")[0]
    own = {k: v for k, v in method_config.items() if k not in POLISH_SETTINGS}
    given = {POLISH_SETTINGS[k]: v for k, v in method_config.items() if k in POLISH_SETTINGS}
    given.setdefault("method", POLISH_DEFAULTS.get(name, "none"))
    return PolishConfig(**given), own


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


@dataclass(frozen=True)
class CentralDifferences:
    """Central differences of a :class:`Problem`: x and x ± h e_j for every free j in ONE call
    (at a bound the step is cut to stay inside [-1, 1], one-sided: ``cost`` is the most, a
    point on k' bounds takes 2k + 1 − k')."""

    problem: Problem
    step: float = 1e-5  # h [-]: PolishConfig.step checks it where it enters
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


GradientFunction = CentralDifferences | AutogradGradient
"""``gradient(x) -> Gradient`` at the full point x (dim,); ``cost``: model evaluations per call
at most (kept back; ``Gradient.evaluations`` are counted); ``name`` for the certificate."""


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
