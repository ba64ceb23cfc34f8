"""``TandemWing/LevelFlight-v0``: the most efficient stroke in steady level flight, one wing-beat per episode.

Its declaration (:data:`LEVEL_FLIGHT`), config, batched core, vector env and single env.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, get_args, get_type_hints

import numpy as np
from gymnasium.vector import VectorEnv

from ..physics import SPEED_LIMITS, ModelOptions, Result
from .base import FlightCore, FlightEnv, FlightVectorEnv
from .config import MODEL_OPTION_KWARGS, FlightConfig
from .declaration import FLIGHT_LIMITS, Constraint, TaskCondition, TaskDeclaration, TaskObjectives


# Each violation is max(0, −margin). The margins are array-agnostic (builtin abs, arithmetic):
# the polish differentiates them on the torch backend's tensors by autograd (agents.polish).
def _lift_margin(result: Result, config: Any) -> np.ndarray:
    return config.constraint_tolerance - abs(result.lift_to_weight - 1.0)


def _thrust_margin(result: Result, config: Any) -> np.ndarray:
    return config.constraint_tolerance - abs(result.excess_horizontal)


LEVEL_FLIGHT = TaskDeclaration(
    name="LevelFlight",
    summary="Level flight at speed V: maximise η = T·V/P with L = W, T = D and P/m <= the "
    "insect's maximum.",
    condition=TaskCondition(
        keyword="speed",
        label="flight speed",
        symbol="V",
        unit="m/s",
        limits=SPEED_LIMITS,
        default=1.5,  # the paper's best-efficiency speed
        envelope=(0.25, 2.0),  # the paper's range
        sweep=(0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0),  # Figs. 4-6, 15
    ),
    objectives=TaskObjectives(metrics={"efficiency": "efficiency"}, default="efficiency"),
    # Forces are fractions of W and the power excess a fraction of the cap, so the three terms
    # share one scale (a 10 % miss costs the same whichever constraint).
    constraints=(
        Constraint("lift_violation", "|L/W − 1| ≤ tol", "-", margin=_lift_margin),
        Constraint("thrust_violation", "|T − D|/W ≤ tol", "-", margin=_thrust_margin),
        *FLIGHT_LIMITS,
    ),
)


@dataclass(frozen=True, kw_only=True)
class LevelFlightConfig(FlightConfig):
    """Level flight at speed V: maximise η = T·V/P with L = W, T = D and P/m <= the insect's maximum."""

    DECLARATION: ClassVar[TaskDeclaration] = LEVEL_FLIGHT

    speed: float | None = None
    """Fixed flight speed V [m/s]; default 1.5 m/s (the paper's best-efficiency speed) unless
    ``speed_range`` is given."""
    speed_range: tuple[float, float] | None = None
    """(low, high) [m/s]: V is drawn uniformly from it at each reset (not with ``speed``)."""
    speed_envelope: tuple[float, float] = LEVEL_FLIGHT.condition.envelope  # type: ignore[union-attr]
    """(low, high) [m/s] mapped to the observation's [-1, 1], holding every speed used;
    default the paper's range, 0.25 to 2.0 m/s."""
    constraint_tolerance: float = field(default=0.02, metadata={"real": ("", 0.0, 0.999)})
    """Band of the equalities L = W and T = D, as a fraction of W [-] (docs/model.md §7.5)."""


class LevelFlightCore(FlightCore):
    """The condition is the speed; the power cap the insect's maximum."""

    config: LevelFlightConfig

    def flight_conditions(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return values.copy(), np.full(values.shape, self.config.available_power)


# VectorEnv among the direct bases too: skrl tells a vector env by its class's direct bases.
class LevelFlightVectorEnv(FlightVectorEnv, VectorEnv):
    """n :class:`LevelFlightEnv` in one batched model call (:class:`~tandem_env.envs.base.FlightVectorEnv`)."""

    config_class = LevelFlightConfig
    core_class = LevelFlightCore
    config: LevelFlightConfig


class LevelFlightEnv(FlightEnv):
    """Steady level flight of the tandem-wing dragonfly: find the most efficient stroke.

    The quasi-steady tandem flapping-wing model of Faisal & Filippone (2016, AIAA J.) evaluates
    one wing-beat cycle of a stroke at flight speed V; the task (docs/model.md §7) is to maximise
    η = T·V/P subject to L = W, T = D and P/m <= 90 W/kg. Each episode is one cycle (a
    contextual bandit): observe V, choose a stroke; ``step`` terminates it (docs/envs.md).

    * Action: ``Box(-1, 1, (28,), float32)``, the 14 parameters of each wing, fore-wing first,
      each mapped onto its Table 4 range (:func:`tandem_env.normalised_to_physical`). Non-finite
      actions raise ``ValueError``, and so do values outside [-1, 1] unless the env was made
      with ``clip_actions=True`` (for clients that do not clip, such as skrl).
    * Observation: ``Box(-1, 1, (1,), float32)``, V mapped from ``speed_envelope``.
    * Reward: ``η − penalty``, ``penalty = weight·violation + offset·[infeasible]`` over
      :data:`LEVEL_FLIGHT`'s constraints (:class:`~tandem_env.envs.config.PenaltyConfig`): a
      feasible stroke earns exactly its η, in [0, ~0.5]; random strokes score about −120 to 0.
    * Start: V is ``speed`` (default 1.5 m/s) or drawn from ``speed_range`` at each reset;
      ``reset(options={"speed": v})`` sets it for one episode.
    * Info: the named stroke (``info["stroke"]``), every field of :class:`tandem_env.Result`,
      each constraint's violation and ``objective``, ``constraint_violation``, ``penalty``,
      ``feasible``.
    * Keywords (:class:`LevelFlightConfig`, :meth:`FlightConfig.from_kwargs`): ``speed``,
      ``speed_range``, ``speed_envelope``, ``constraint_tolerance``, ``insect``, ``planform``
      ("tear-drop" | "real"), ``options`` or its fields ({model_options}), ``penalty`` or
      ``penalty_weight`` / ``penalty_offset``, ``clip_actions``, ``render_mode`` ("rgb_array" |
      "human"); invalid values raise ``ValueError`` at construction. v0: initial version.
    """

    vector_class = LevelFlightVectorEnv
    config: LevelFlightConfig


def model_option_keywords() -> str:
    """The ``gym.make`` keywords of the model options, each with its choices, for docstrings."""
    hints = get_type_hints(ModelOptions)
    shown = []
    for keyword, name in MODEL_OPTION_KWARGS.items():
        choices = " | ".join(f'"{c}"' for c in get_args(hints[name]))
        shown.append(f"``{keyword}``" + (f" ({choices})" if choices else ""))
    return ", ".join(shown)


# Generated, so that the list cannot leave out an option (python -OO drops docstrings).
if LevelFlightEnv.__doc__:
    LevelFlightEnv.__doc__ = LevelFlightEnv.__doc__.replace(
        "{model_options}", model_option_keywords()
    )
