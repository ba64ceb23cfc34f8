"""The harness's tasks: which env id a task name means and how its flight condition is passed.

A :class:`TaskSpec` is data only: the Gymnasium id (whose ``vector_entry_point`` the harness
evaluates batches through), the constructor keyword and reset option that set the condition,
the condition's name and unit for records, and the objectives the env offers. ``"level"`` and
``"accelerate"`` are registered here; tests register analytic tasks the same way
(:func:`register_task`), so every method runs through one code path.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from tandem_env.envs.registration import ACCELERATE_ID, LEVEL_FLIGHT_ID
from tandem_env.physics.checks import is_real
from tandem_env.physics.stroke import DISCRETE, LOWER, UPPER

__all__ = [
    "ACCELERATE",
    "LEVEL",
    "Condition",
    "TaskSpec",
    "available_tasks",
    "get_task",
    "register_task",
]

_NAME = re.compile(r"^[a-z][a-z0-9_-]*$")


@dataclass(frozen=True)
class Condition:
    """A task's flight condition as recorded: e.g. ``speed = 1.5 m/s``."""

    name: str
    """What the value is, e.g. ``"speed"`` or ``"available_power"``."""
    value: float
    """The value [unit]."""
    unit: str
    """Its unit, e.g. ``"m/s"`` or ``"W/kg"``."""

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "value": self.value, "unit": self.unit}

    def describe(self) -> str:
        return f"{self.name} = {self.value:g} {self.unit}"


@dataclass(frozen=True)
class TaskSpec:
    """How the harness runs one task.

    Parameters
    ----------
    name : str
        Short name used on the command line and in record file names (lower case).
    env_id : str
        Registered Gymnasium id; it must have a ``vector_entry_point`` whose vector env accepts
        ``autoreset_mode="Disabled"`` and the keyword arguments of the single env.
    condition_name, condition_unit : str
        Name and unit of the condition in records, e.g. ``"speed"``, ``"m/s"``. The env's step
        ``info`` reports the condition under ``condition_name`` (checked when present).
    condition_kwarg : str
        Constructor keyword that fixes the condition, e.g. ``"speed"``.
    reset_option : str
        ``reset(options={reset_option: value})`` key that sets the condition of an episode.
    objectives : mapping of str to str
        Objective choice -> the ``info`` metric it maximises, e.g. ``{"vertical":
        "excess_vertical"}``. One entry and ``objective_kwarg=None`` for a fixed objective.
    objective_kwarg : str or None
        Constructor keyword selecting the objective, or None if the task has only one.
    default_objective : str
        The choice used when none is given (the env's own default).
    objective_unit : str
        Unit of the objective values, for records and tables.
    description : str
        One line for ``--help`` and docs.
    """

    name: str
    env_id: str
    condition_name: str
    condition_unit: str
    condition_kwarg: str
    reset_option: str
    objectives: Mapping[str, str]
    default_objective: str
    objective_kwarg: str | None = None
    objective_unit: str = "-"
    description: str = ""
    forbidden_kwargs: tuple[str, ...] = field(default=())
    """Env kwargs the harness refuses (they would fight the condition it sets)."""
    discrete_actions: tuple[tuple[int, int], ...] = field(default=())
    """(index, levels) of each discrete action coordinate: it takes ``levels`` values, value i
    on the i-th of ``levels`` equal bins of [-1, 1]. Methods that know discrete variables
    (CMA-ES) search those coordinates on the bin centres; the others search them as continuous
    and the env's map decides."""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise ValueError(
                f"TaskSpec.name = {self.name!r}; allowed: lower-case letters, digits, '_' and "
                "'-', starting with a letter"
            )
        if not self.objectives:
            raise ValueError(f"TaskSpec {self.name!r}: objectives is empty; allowed: >= 1 entry")
        if self.default_objective not in self.objectives:
            raise ValueError(
                f"TaskSpec {self.name!r}: default_objective = {self.default_objective!r}; "
                f"allowed: one of {sorted(self.objectives)}"
            )
        if self.objective_kwarg is None and len(self.objectives) > 1:
            raise ValueError(
                f"TaskSpec {self.name!r}: {len(self.objectives)} objectives but no "
                "objective_kwarg to choose between them"
            )
        object.__setattr__(self, "objectives", MappingProxyType(dict(self.objectives)))
        forbidden = (self.condition_kwarg, *self.forbidden_kwargs)
        object.__setattr__(self, "forbidden_kwargs", tuple(dict.fromkeys(forbidden)))

    def condition(self, value: float) -> Condition:
        """The recorded condition for ``value`` [condition_unit] (range checks are the env's)."""
        # NumPy numbers are real numbers too; strings (also "1.5") and booleans are not.
        if not is_real(value):
            raise ValueError(
                f"{self.name}: condition {self.condition_name} = {value!r}; allowed: a "
                f"number [{self.condition_unit}]"
            )
        return Condition(self.condition_name, float(value), self.condition_unit)

    def objective_choice(self, env_kwargs: Mapping[str, Any]) -> str:
        """The objective the env will use with ``env_kwargs``."""
        if self.objective_kwarg is None:
            return self.default_objective
        choice = env_kwargs.get(self.objective_kwarg, self.default_objective)
        if choice not in self.objectives:
            raise ValueError(
                f"{self.name}: {self.objective_kwarg} = {choice!r}; allowed: "
                f"{', '.join(map(repr, self.objectives))}"
            )
        return str(choice)

    def objective_metric(self, env_kwargs: Mapping[str, Any]) -> str:
        """The ``info`` metric the env maximises with ``env_kwargs``, e.g. ``"efficiency"``."""
        return self.objectives[self.objective_choice(env_kwargs)]

    def slug(self, env_kwargs: Mapping[str, Any]) -> str:
        """Task label for file names: the name, plus the objective when there is a choice."""
        if self.objective_kwarg is None:
            return self.name
        return f"{self.name}-{self.objective_choice(env_kwargs)}"


#: The harmonic N of each wing, 1 or 2 (``normalised_to_physical``: N = 1 where a < 0, else 2,
#: i.e. two equal bins of [-1, 1]); the stroke's only discrete parameters.
STROKE_DISCRETE: tuple[tuple[int, int], ...] = tuple(
    (int(i), int(UPPER[i] - LOWER[i]) + 1) for i in np.flatnonzero(DISCRETE)
)

LEVEL = TaskSpec(
    name="level",
    env_id=LEVEL_FLIGHT_ID,
    condition_name="speed",
    condition_unit="m/s",
    condition_kwarg="speed",
    reset_option="speed",
    objectives={"efficiency": "efficiency"},
    default_objective="efficiency",
    objective_unit="-",
    description="level flight at speed V [m/s]: maximise η = T·V/P with L = W, T = D, P/m <= 90 W/kg",
    forbidden_kwargs=("speed_range",),
    discrete_actions=STROKE_DISCRETE,
)

ACCELERATE = TaskSpec(
    name="accelerate",
    env_id=ACCELERATE_ID,
    condition_name="available_power",
    condition_unit="W/kg",
    condition_kwarg="power",
    reset_option="power",
    objectives={
        "vertical": "excess_vertical",
        "horizontal": "excess_horizontal",
        "resultant": "excess_total",
        "horizontal_literal": "excess_horizontal_literal",
    },
    default_objective="vertical",
    objective_kwarg="objective",
    objective_unit="-",
    description=(
        "accelerating flight at available power P [W/kg]: maximise F̄_v, F̄_h or F̄_a with "
        "F̄_v, F̄_h >= 0 and P/m <= P"
    ),
    forbidden_kwargs=("power_range",),
    discrete_actions=STROKE_DISCRETE,
)

_TASKS: dict[str, TaskSpec] = {LEVEL.name: LEVEL, ACCELERATE.name: ACCELERATE}


def register_task(spec: TaskSpec, *, replace: bool = False) -> None:
    """Make ``spec`` available to :func:`get_task` under ``spec.name``."""
    if not isinstance(spec, TaskSpec):
        raise ValueError(f"spec = {spec!r}; allowed: a TaskSpec")
    if spec.name in _TASKS and not replace and _TASKS[spec.name] != spec:
        raise ValueError(
            f"task {spec.name!r} is already registered; pass replace=True to replace it"
        )
    _TASKS[spec.name] = spec


def available_tasks() -> tuple[str, ...]:
    """Names of the registered tasks."""
    return tuple(_TASKS)


def get_task(task: str | TaskSpec) -> TaskSpec:
    """The spec of a task name (or ``task`` itself if it already is a spec)."""
    if isinstance(task, TaskSpec):
        return task
    try:
        return _TASKS[task]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown task {task!r}; allowed: {', '.join(map(repr, _TASKS))}"
        ) from None
