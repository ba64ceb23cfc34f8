"""Gymnasium environments over the tandem-wing model (see docs/envs.md).

Ids ``TandemWing/LevelFlight-v0``, ``TandemWing/Accelerate-v0`` (one wing-beat per episode)
and ``TandemWing/SpeedChange-v0`` (many wing-beats) are registered by ``import tandem_env``.
The SB3 adapter (``TandemVecEnv``, ``make_sb3_vec_env``) lives in :mod:`tandem_env.envs.sb3`
and is imported only when asked for, so that importing the envs does not import
Stable-Baselines3 (or torch).
"""

from __future__ import annotations

from typing import Any

from .config import AccelerateConfig, FlightConfig, LevelFlightConfig, PenaltyConfig
from .flight import AccelerateEnv, FlightEnv, LevelFlightEnv
from .registration import (
    ACCELERATE_ID,
    ENV_IDS,
    LEVEL_FLIGHT_ID,
    SPEED_CHANGE_ID,
    check_env_id,
    register_envs,
)
from .speed_change import SpeedChangeEnv
from .speed_change_config import SpeedChangeConfig, SpeedChangeReward
from .speed_change_vector import SpeedChangeVectorEnv
from .vector import AccelerateVectorEnv, FlightVectorEnv, LevelFlightVectorEnv

__all__ = [
    "ACCELERATE_ID",
    "ENV_IDS",
    "LEVEL_FLIGHT_ID",
    "SPEED_CHANGE_ID",
    "AccelerateConfig",
    "AccelerateEnv",
    "AccelerateVectorEnv",
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
    "check_env_id",
    "make_sb3_vec_env",
    "register_envs",
]

_LAZY_SB3 = ("TandemVecEnv", "make_sb3_vec_env")


def __getattr__(name: str) -> Any:
    if name in _LAZY_SB3:
        from . import sb3

        return getattr(sb3, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
