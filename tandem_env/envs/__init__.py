"""Gymnasium environments over the tandem-wing model (docs/envs.md), registered by ``import
tandem_env``: each a task module over ``base``. The SB3 adapter is imported only when asked for.
"""

from __future__ import annotations

from typing import Any

from .accelerate import ACCELERATE, AccelerateConfig, AccelerateEnv, AccelerateVectorEnv
from .base import FlightEnv, FlightVectorEnv
from .config import FlightConfig, PenaltyConfig
from .declaration import Constraint, TaskCondition, TaskDeclaration, TaskObjectives
from .level_flight import LEVEL_FLIGHT, LevelFlightConfig, LevelFlightEnv, LevelFlightVectorEnv
from .registration import (
    ACCELERATE_ID,
    LEVEL_FLIGHT_ID,
    SPEED_CHANGE_ID,
    add_entry,
    check_env_id,
    env_ids,
    register_envs,
)
from .speed_change import SpeedChangeEnv, SpeedChangeVectorEnv
from .speed_change_config import SPEED_CHANGE, SpeedChangeConfig, SpeedChangeReward

__all__ = [
    "ACCELERATE",
    "ACCELERATE_ID",
    "LEVEL_FLIGHT",
    "LEVEL_FLIGHT_ID",
    "SPEED_CHANGE",
    "SPEED_CHANGE_ID",
    "AccelerateConfig",
    "AccelerateEnv",
    "AccelerateVectorEnv",
    "Constraint",
    "FlightConfig",
    "FlightEnv",
    "FlightVectorEnv",
    "LevelFlightConfig",
    "LevelFlightEnv",
    "LevelFlightVectorEnv",
    "PenaltyConfig",
    "SpeedChangeConfig",
    "SpeedChangeEnv",
    "SpeedChangeReward",
    "SpeedChangeVectorEnv",
    "TandemVecEnv",
    "TaskCondition",
    "TaskDeclaration",
    "TaskObjectives",
    "add_entry",
    "check_env_id",
    "env_ids",
    "make_sb3_vec_env",
    "register_envs",
]


def __getattr__(name: str) -> Any:
    if name in ("TandemVecEnv", "make_sb3_vec_env"):  # the SB3 adapter, imported when asked for
        from . import sb3

        return getattr(sb3, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
