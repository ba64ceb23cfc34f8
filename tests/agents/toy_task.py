"""A toy task in ONE file, as a plug-in would add one: cruise at speed V_c with most thrust surplus.

Its declaration (condition ``cruise_speed``, one objective, two constraints, a sweep), its
config, its batched core, its vector env and its single env; registered with one line: in a
process, ``add_entry(TOY_ID, TOY_ENTRY)`` (tests/agents/test_task_declaration.py); installed,
the ``tandem_env.tasks`` entry point ``TandemToy/Cruise-v0 = toy_task:TOY_ENTRY``, with which
``python -m train`` trains it (tests/train/test_cli.py). Nothing in ``tandem_env``,
``agents``, ``train`` or ``eval`` names it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from tandem_env.envs import Constraint, TaskCondition, TaskDeclaration, TaskObjectives
from tandem_env.envs.base import FlightCore, FlightEnv, FlightVectorEnv
from tandem_env.envs.config import FlightConfig
from tandem_env.envs.declaration import POWER_CAP
from tandem_env.envs.registration import EnvEntry


def _lift_deficit(result: Any, _: Any) -> np.ndarray:
    return np.maximum(0.0, -result.excess_vertical)


CRUISE = TaskDeclaration(
    name="Cruise",
    summary="Toy cruise: maximise the thrust surplus (T − D)/W at V_c with L >= W.",
    condition=TaskCondition(
        keyword="cruise_speed",
        label="cruise speed",
        symbol="V_c",
        unit="m/s",
        limits=(0.0, 20.0),
        default=1.0,
        envelope=(0.5, 1.5),
        sweep=(0.5, 1.0, 1.5),
    ),
    objectives=TaskObjectives(metrics={"surplus": "excess_horizontal"}, default="surplus"),
    constraints=(Constraint("lift_deficit", "L ≥ W", "-", _lift_deficit), POWER_CAP),
)


@dataclass(frozen=True, kw_only=True)
class CruiseConfig(FlightConfig):
    """Toy cruise: maximise the thrust surplus (T − D)/W at V_c with L >= W."""

    DECLARATION: ClassVar[TaskDeclaration] = CRUISE

    cruise_speed: float | None = None
    cruise_speed_range: tuple[float, float] | None = None
    cruise_speed_envelope: tuple[float, float] = (0.5, 1.5)

    def describe(self) -> str:
        return CRUISE.condition.describe(self.cruise_speed, self.cruise_speed_range)  # type: ignore[union-attr]


class CruiseCore(FlightCore):
    def flight_conditions(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return values.copy(), np.full(values.shape, self.config.insect.max_power_per_mass)


class CruiseVectorEnv(FlightVectorEnv):
    config_class = CruiseConfig
    core_class = CruiseCore


class CruiseEnv(FlightEnv):
    """Toy cruise (the vector env at B = 1)."""

    vector_class = CruiseVectorEnv


TOY_ID = "TandemToy/Cruise-v0"
TOY_ENTRY = EnvEntry("toy_task", "Cruise", task="cruise-toy")
