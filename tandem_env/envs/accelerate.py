"""``TandemWing/Accelerate-v0``: the stroke with most specific excess force, one wing-beat per episode.

Its declaration (:data:`ACCELERATE`), config, batched core, vector env and single env.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from gymnasium.vector import VectorEnv

from ..physics import AVAILABLE_POWER_LIMITS, DRAGONFLY, SPEED_LIMITS, Result
from .base import FlightCore, FlightEnv, FlightVectorEnv
from .config import FlightConfig
from .declaration import FLIGHT_LIMITS, Constraint, TaskCondition, TaskDeclaration, TaskObjectives

#: The specimen's available power per body mass [W/kg], 90 W/kg: the top of the paper's sweep.
SPECIMEN_POWER: float = DRAGONFLY.max_power_per_mass


# Each violation is max(0, −margin). The margins are array-agnostic (``0.0 + x``: a new array,
# numpy's or torch's): the polish differentiates them on torch tensors (agents.polish).
def _vertical_margin(result: Result, _: Any) -> np.ndarray:
    return 0.0 + result.excess_vertical


def _horizontal_margin(result: Result, _: Any) -> np.ndarray:
    return 0.0 + result.excess_horizontal


ACCELERATE = TaskDeclaration(
    name="Accelerate",
    summary="Accelerating flight: maximise a specific excess force with F_v, F_h >= 0 and "
    "P/m <= P_avail.",
    condition=TaskCondition(
        keyword="available_power",
        option="power",  # --power on the command line
        former_keyword="power",
        label="available power per body mass",
        symbol="P_avail",
        metavar="P",
        unit="W/kg",
        limits=AVAILABLE_POWER_LIMITS,
        default=SPECIMEN_POWER,
        envelope=(50.0, SPECIMEN_POWER),  # the paper's sweep, 50 W/kg to the specimen's maximum
        sweep=(50.0, 60.0, 70.0, 80.0, SPECIMEN_POWER),  # Figs. 7-8, 16
    ),
    objectives=TaskObjectives(
        metrics={
            "vertical": "excess_vertical",
            "horizontal": "excess_horizontal",
            "resultant": "excess_total",
            "horizontal_literal": "excess_horizontal_literal",
        },
        default="vertical",
        keyword="objective",
    ),
    constraints=(
        Constraint("vertical_deficit", "F̄_v ≥ 0", "-", margin=_vertical_margin),
        Constraint("horizontal_deficit", "F̄_h ≥ 0", "-", margin=_horizontal_margin),
        *FLIGHT_LIMITS,
    ),
)


@dataclass(frozen=True, kw_only=True)
class AccelerateConfig(FlightConfig):
    """Accelerating flight: maximise a specific excess force with F_v >= 0, F_h >= 0 and P/m <= P_avail."""

    DECLARATION: ClassVar[TaskDeclaration] = ACCELERATE

    objective: str = ACCELERATE.objectives.default  # type: ignore[union-attr]
    """Which specific excess force is maximised (one of ``ACCELERATE.objectives.choices``):
    ``"vertical"`` F̄_v = (L − W)/W, ``"horizontal"`` F̄_h = (T − D)/W, ``"resultant"``
    F̄_a = sqrt(F̄_v² + F̄_h²) or ``"horizontal_literal"`` (D_f + D_h)/W, Eq. 24 read literally
    (the wings' rearward forces, ``excess_horizontal_literal``) [-] (docs/model.md §7.6: the
    paper's attainable F̄_a combines the first two). The constraints are the same for all."""
    available_power: float | None = None
    """Fixed available power per body mass [W/kg]; default 90 W/kg unless a range is given."""
    available_power_range: tuple[float, float] | None = None
    """(low, high) [W/kg]: the available power is drawn uniformly from it at each reset."""
    available_power_envelope: tuple[float, float] = ACCELERATE.condition.envelope  # type: ignore[union-attr]
    """(low, high) [W/kg] mapped to the observation's [-1, 1], holding every power used;
    default the paper's sweep, 50 to 90 W/kg."""
    speed: float = field(default=0.0, metadata={"real": ("m/s", *SPEED_LIMITS)})
    """Flight speed V [m/s], fixed and not observed (default 0: take-off or escape from hover)."""

    def describe(self) -> str:
        return f"{super().describe()}, V = {self.speed:g} m/s, objective {self.objective}"


class AccelerateCore(FlightCore):
    """The condition is the available power; the speed is the config's."""

    config: AccelerateConfig

    def flight_conditions(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.full(values.shape, self.config.speed), values.copy()


# VectorEnv among the direct bases too: skrl tells a vector env by its class's direct bases.
class AccelerateVectorEnv(FlightVectorEnv, VectorEnv):
    """n :class:`AccelerateEnv` in one batched model call (:class:`~tandem_env.envs.base.FlightVectorEnv`)."""

    config_class = AccelerateConfig
    core_class = AccelerateCore
    config: AccelerateConfig


class AccelerateEnv(FlightEnv):
    """Accelerating flight of the tandem-wing dragonfly: find the stroke with most excess force.

    The episodes, action space, penalty and ``info`` of :class:`LevelFlightEnv` at a fixed
    flight speed (default 0: take-off or escape from hover): maximise a specific excess force
    (``objective``) subject to F_v >= 0, F_h >= 0 and P/m <= the available power, which is
    observed (Box(-1, 1, (1,), float32), mapped from ``available_power_envelope``, default
    50-90 W/kg), so one policy can cover the paper's sweep. Feasible rewards are F̄ in [0, ~6]
    (the paper: F̄_v ≈ 2.7-4.4); uniform random strokes score about −100 to 0.
    ``reset(options={"available_power": p})`` sets one episode's power (the old names ``power``,
    ``power_range`` and ``power_envelope`` are refused naming the new ones). Keywords:
    :class:`AccelerateConfig` and every model, penalty and action option of
    :class:`LevelFlightEnv` (docs/envs.md); invalid values raise ``ValueError``. v0: initial.
    """

    vector_class = AccelerateVectorEnv
    config: AccelerateConfig
