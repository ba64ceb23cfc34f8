"""The harness's tasks: which env id a task name means, read from the env's task declaration.

A :class:`TaskSpec` is a name, a Gymnasium id and the env config's
:class:`~tandem_env.envs.TaskDeclaration`, read, never copied: every env entry with a task
gives one (:meth:`TaskSpec.from_env`); tests register analytic tasks (:func:`register_task`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from tandem_env.envs import registration
from tandem_env.envs.config import FlightConfig
from tandem_env.envs.declaration import TaskCondition, TaskDeclaration, TaskObjectives, refusal
from tandem_env.envs.registration import config_class
from tandem_env.physics.checks import is_real
from tandem_env.physics.stroke import DISCRETE, LOWER, UPPER

_NAME = re.compile(r"^[a-z][a-z0-9_-]*$")


#: The harmonic N of each wing, 1 or 2 (``normalised_to_physical``: N = 1 where a < 0, else 2,
#: two equal bins of [-1, 1]): the stroke's only discrete parameters.
STROKE_DISCRETE: tuple[tuple[int, int], ...] = tuple(
    (int(i), int(UPPER[i] - LOWER[i]) + 1) for i in np.flatnonzero(DISCRETE)
)


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
    """How the harness runs one task: a name, an env id and the env's task declaration."""

    name: str
    """Short name used on the command line and in record file names (lower case)."""
    env_id: str
    """Registered Gymnasium id with a ``vector_entry_point`` (autoreset ``"Disabled"``, the
    single env's keywords)."""
    declaration: TaskDeclaration
    """The env's declaration (its config's ``DECLARATION``), with a condition and objectives."""
    discrete_actions: tuple[tuple[int, int], ...] = field(default=())
    """(index, levels) of each discrete action coordinate: value i on the i-th of ``levels``
    equal bins of [-1, 1] (CMA-ES searches the bin centres)."""

    @classmethod
    def from_env(cls, name: str, env_id: str) -> TaskSpec:
        """The task of a registered env id: its config's ``DECLARATION``, read, not copied."""
        config = config_class(env_id)
        declaration = getattr(config, "DECLARATION", None)
        if not isinstance(declaration, TaskDeclaration) or declaration.condition is None:
            raise ValueError(
                f"task {name!r}: {env_id}'s config {config.__name__} declares DECLARATION = "
                f"{declaration!r}; allowed: a TaskDeclaration with a condition and objectives "
                "(tandem_env.envs.declaration)"
            )
        # Every flight env's action is a normalised stroke (tandem_env.envs.base).
        discrete = STROKE_DISCRETE if issubclass(config, FlightConfig) else ()
        return cls(name=name, env_id=env_id, declaration=declaration, discrete_actions=discrete)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            allowed = "lower-case letters, digits, '_' and '-', starting with a letter"
            raise refusal("TaskSpec.name", self.name, allowed)
        declared = self.declaration
        if not isinstance(declared, TaskDeclaration) or declared.condition is None:
            allowed = "a TaskDeclaration with a condition and objectives"
            raise refusal(f"TaskSpec {self.name!r}: declaration", declared, allowed)

    @property
    def declared_condition(self) -> TaskCondition:
        """The declared condition (keyword, unit, label, envelope, sweep)."""
        return self.declaration.condition  # type: ignore[return-value]

    @property
    def declared_objectives(self) -> TaskObjectives:
        """The declared objectives (each choice's ``info`` metric)."""
        return self.declaration.objectives  # type: ignore[return-value]

    @property
    def condition_flag(self) -> str:
        """The condition's command-line option, e.g. ``"--speed"`` or ``"--power"``."""
        return "--" + self.declared_condition.option.replace("_", "-")

    @property
    def forbidden_kwargs(self) -> tuple[str, ...]:
        """Env kwargs the harness refuses (they would fight the condition it sets)."""
        return self.declared_condition.keyword, self.declared_condition.range_keyword

    def condition(self, value: float) -> Condition:
        """The recorded condition for ``value`` [the declared unit] (range checks are the env's)."""
        declared = self.declared_condition
        if not is_real(value):  # numpy numbers are; strings (also "1.5") and booleans are not
            what = f"{self.name}: condition {declared.keyword}"
            raise refusal(what, value, f"a number [{declared.unit}]")
        return Condition(declared.keyword, float(value), declared.unit)

    def objective_metric(self, env_kwargs: Mapping[str, Any]) -> str:
        """The ``info`` metric the env maximises with ``env_kwargs``, e.g. ``"efficiency"``."""
        declared = self.declared_objectives
        keyword = declared.keyword
        choice = env_kwargs.get(keyword, declared.default) if keyword else declared.default
        if choice not in declared.metrics:
            allowed = ", ".join(map(repr, declared.metrics))
            raise refusal(f"{self.name}: {declared.keyword}", choice, allowed)
        return declared.metrics[choice]


#: Tasks registered by hand (:func:`register_task`); those of env entries are read on each call.
REGISTERED_TASKS: dict[str, TaskSpec] = {}


def _tasks() -> dict[str, TaskSpec]:
    """Every task now: one per env entry with a task, then those registered by hand."""
    derived = {name: TaskSpec.from_env(name, i) for name, i in registration.task_env_ids().items()}
    return {**derived, **REGISTERED_TASKS}


#: The paper's two tasks (the studies name them).
LEVEL_TASK: TaskSpec = TaskSpec.from_env("level", registration.LEVEL_FLIGHT_ID)
ACCELERATE_TASK: TaskSpec = TaskSpec.from_env("accelerate", registration.ACCELERATE_ID)


def register_task(spec: TaskSpec, *, replace: bool = False) -> None:
    """Make ``spec`` available to :func:`get_task` under ``spec.name`` (a task of an env entry
    is registered with ``registration.add_entry`` instead)."""
    if not isinstance(spec, TaskSpec):
        raise ValueError(f"spec = {spec!r}; allowed: a TaskSpec")
    if (known := _tasks().get(spec.name)) is not None and not replace and known != spec:
        raise ValueError(
            f"task {spec.name!r} is already registered; pass replace=True to replace it"
        )
    REGISTERED_TASKS[spec.name] = spec


def available_tasks() -> tuple[str, ...]:
    """Names of the registered tasks."""
    return tuple(_tasks())


def get_task(task: str | TaskSpec) -> TaskSpec:
    """The spec of a task name (or ``task`` itself if it already is a spec)."""
    if isinstance(task, TaskSpec):
        return task
    tasks = _tasks()
    try:
        return tasks[task]
    except (KeyError, TypeError):
        raise ValueError(f"unknown task {task!r}; allowed: {', '.join(map(repr, tasks))}") from None


def task_of(env_id: str) -> str:
    """The name of the registered task whose env is ``env_id``; ValueError naming the env ids the
    tasks run if none does."""
    tasks = _tasks()
    for name, spec in tasks.items():
        if spec.env_id == env_id:
            return name
    allowed = ", ".join(spec.env_id for spec in tasks.values())
    raise ValueError(f"no harness task runs {env_id}; allowed: {allowed}")
