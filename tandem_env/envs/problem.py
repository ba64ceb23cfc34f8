"""The optimisation problem a one-cycle task poses (``env.unwrapped.problem()``), for an
optimiser that is not an episode-stepping agent: the stroke box, the constraints, and a batched
evaluation through the core's own ``step`` at conditions given with each call::

    problem = gym.make("TandemWing/LevelFlight-v0").unwrapped.problem()
    evaluation = problem.evaluate(actions, 1.5)  # (B, 28) in [-1, 1], at V = 1.5 m/s
    evaluation.objective, evaluation.margins, evaluation.feasible

Nothing here imports Gymnasium; torch only in :meth:`FlightProblem.differentiate`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..physics import N_PARAMETERS, PARAMETER_NAMES, Result, normalised_to_physical
from ..physics.stroke import DISCRETE
from .config import FlightConfig
from .declaration import Constraint, TaskCondition, TaskDeclaration


@dataclass(frozen=True)
class ProblemEvaluation:
    """B strokes evaluated at their conditions in ONE model call."""

    objective: np.ndarray
    """(B,) the task's objective, maximised [the objective's unit]."""
    margins: np.ndarray | None
    """(B, m) each constraint's signed margin [-], >= 0 where it holds
    (:attr:`FlightProblem.constraints` order); None for a task with a constraint that declares
    no margin (:attr:`FlightProblem.has_margins`)."""
    feasible: np.ndarray
    """(B,) bool: the task's exact feasibility test, every constraint's violation exactly 0
    (what the env's ``info["feasible"]`` reports)."""
    result: Result
    """The model's full result, (B,) arrays."""


@dataclass(frozen=True)
class ProblemGradient:
    """B strokes evaluated with first derivatives w.r.t. the normalised coordinates."""

    evaluation: ProblemEvaluation
    objective_gradient: np.ndarray
    """(B, 28) d objective / d action (0 in the discrete coordinates, N being a step)."""
    margin_jacobian: np.ndarray
    """(B, m, 28) d margins / d action."""


class FlightProblem:
    """Maximise a one-cycle task's objective over the normalised stroke box subject to its
    :attr:`constraints` (feasible: every violation exactly 0; a gradient-based optimiser holds
    the signed margins >= 0), at a condition given with each evaluation.

    Its attributes, set once: ``config`` (the env's: insect, model options, backend, device,
    objective choice), ``declaration`` (the task's: condition, objectives, constraints),
    ``condition`` (the declared condition every evaluation takes: keyword, unit, the model's
    limits, the paper's envelope and sweep), ``objective_metric`` (the
    :class:`~tandem_env.physics.Result` field maximised, e.g. ``"efficiency"``),
    ``normalised_low`` / ``normalised_high`` (28,) (the action box's bounds), ``physical_low`` /
    ``physical_high`` (28,) (their images, the insect's stroke bounds [Hz, deg, -], Table 4's
    unless it sets its own), ``discrete`` (28,) bool (each wing's harmonic N), ``constraints``
    (the declaration's the config asks for, in the margins' column order), ``constraint_names``
    (their violations' ``info`` keys) and ``has_margins`` (every constraint declares a signed
    margin, what :meth:`differentiate` and a gradient-based optimiser need). Arrays read-only.
    """

    #: Number of action coordinates (28).
    dim: int = N_PARAMETERS
    #: Names of the coordinates, fore-wing first (Table 4 order).
    parameter_names: tuple[str, ...] = PARAMETER_NAMES

    def __init__(self, core: Any, normalised_low: float, normalised_high: float) -> None:
        self._core = core
        self.config: FlightConfig = core.config
        self.declaration: TaskDeclaration = core.declaration
        self.condition: TaskCondition = self.config.declared_condition
        self.objective_metric: str = self.config.objective_metric
        bounds = self.config.insect.stroke_bounds
        arrays = {"normalised_low": np.full(N_PARAMETERS, float(normalised_low))}
        arrays["normalised_high"] = np.full(N_PARAMETERS, float(normalised_high))
        arrays |= {"physical_low": np.array(bounds.lower), "physical_high": np.array(bounds.upper)}
        for name, array in {**arrays, "discrete": DISCRETE.copy()}.items():
            array.setflags(write=False)
            setattr(self, name, array)
        self.constraints: tuple[Constraint, ...] = self.declaration.constraints_of(self.config)
        self.constraint_names = tuple(c.name for c in self.constraints)
        self.has_margins = all(c.margin is not None for c in self.constraints)

    # --- evaluation ---------------------------------------------------------------------------
    def evaluate(self, actions: np.ndarray, conditions: Any) -> ProblemEvaluation:
        """B normalised strokes (B, 28) at ``conditions`` (one or (B,) values, the condition's
        unit) in ONE model call, scored as the env scores a step; ValueError for a bad shape,
        a stroke outside the box or a condition the model refuses."""
        strokes, values = self._inputs(actions, conditions)
        bounds = self.config.insect.stroke_bounds
        batch = self._core.step(normalised_to_physical(strokes, bounds), values)
        margins = None  # (B, m); None where a constraint declares none
        if self.has_margins:
            margins = np.array([c.margin(batch.result, self.config) for c in self.constraints])
            margins = margins.reshape(-1, len(strokes)).T
        objective = np.asarray(batch.objective, dtype=np.float64)
        feasible = np.asarray(batch.feasible, dtype=bool)
        return ProblemEvaluation(objective, margins, feasible, batch.result)

    def differentiate(self, actions: np.ndarray, conditions: Any) -> ProblemGradient:
        """:meth:`evaluate` with the objective's gradient and the margins' Jacobian w.r.t. the
        normalised coordinates, by autograd from ONE torch evaluation; ValueError where a
        constraint declares no margin."""
        from ..physics import torch_model  # torch only when something differentiates

        if not self.has_margins:
            missing = [c.name for c in self.constraints if c.margin is None]
            raise ValueError(
                f"{self.declaration.name}: constraints {missing} declare no margin; allowed: "
                "differentiate a task whose every constraint has one (Constraint.margin)"
            )
        strokes, values = self._inputs(actions, conditions)
        config = self.config
        speed, power = self._core.flight_conditions(values)
        functions = [lambda result: getattr(result, self.objective_metric)]
        functions += [lambda result, c=c: c.margin(result, config) for c in self.constraints]
        model = {"insect": config.insect, "options": config.options, "device": config.device}
        result, values, jacobian = torch_model.normalised_jacobian(
            strokes, functions, speed, power, **model
        )
        feasible = np.asarray(self.declaration.score(result, config).feasible, dtype=bool)
        evaluation = ProblemEvaluation(values[:, 0], values[:, 1:], feasible, result)
        return ProblemGradient(evaluation, jacobian[:, 0], jacobian[:, 1:])

    def _inputs(self, actions: Any, conditions: Any) -> tuple[np.ndarray, np.ndarray]:
        """(strokes (B, 28), conditions (B,)), checked."""
        strokes = np.asarray(actions, dtype=np.float64)
        if strokes.ndim != 2 or strokes.shape[1] != N_PARAMETERS:
            raise ValueError(
                f"actions of shape {strokes.shape}; allowed: (B, {N_PARAMETERS}) normalised strokes"
            )
        count, values = len(strokes), np.asarray(conditions, dtype=np.float64)
        if values.ndim == 0:
            return strokes, np.full(count, float(values))
        if values.shape != (count,):
            raise ValueError(
                f"conditions of shape {values.shape} for {count} strokes; allowed: one "
                f"{self.condition.keyword} [{self.condition.unit}] or one per stroke ({count},)"
            )
        return strokes, values

    def __repr__(self) -> str:
        return (
            f"FlightProblem({self.declaration.name}: maximise {self.objective_metric} at "
            f"{self.condition.keyword} [{self.condition.unit}] s.t. "
            f"{', '.join(self.constraint_names) or 'nothing'})"
        )
