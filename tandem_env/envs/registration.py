"""The Gymnasium ids of the flight environments, registered when ``tandem_env`` is imported.

Entry points are strings, so registering imports neither the env classes' dependencies
(matplotlib) nor Stable-Baselines3.
"""

from __future__ import annotations

LEVEL_FLIGHT_ID = "TandemWing/LevelFlight-v0"
"""Level flight: maximise η with L = W, T = D and P/m <= 90 W/kg."""
ACCELERATE_ID = "TandemWing/Accelerate-v0"
"""Accelerating flight: maximise a specific excess force with F_v, F_h >= 0 and P/m <= P_avail."""
SPEED_CHANGE_ID = "TandemWing/SpeedChange-v0"
"""Multi-cycle flight: reach a target speed and hold altitude, one stroke per wing-beat."""
ENV_IDS: tuple[str, ...] = (LEVEL_FLIGHT_ID, ACCELERATE_ID, SPEED_CHANGE_ID)

_ENTRY_POINTS: dict[str, tuple[str, str]] = {
    LEVEL_FLIGHT_ID: (
        "tandem_env.envs.flight:LevelFlightEnv",
        "tandem_env.envs.vector:LevelFlightVectorEnv",
    ),
    ACCELERATE_ID: (
        "tandem_env.envs.flight:AccelerateEnv",
        "tandem_env.envs.vector:AccelerateVectorEnv",
    ),
    SPEED_CHANGE_ID: (
        "tandem_env.envs.speed_change:SpeedChangeEnv",
        "tandem_env.envs.speed_change_vector:SpeedChangeVectorEnv",
    ),
}


def check_env_id(env_id: object, name: str = "env_id") -> str:
    """``env_id`` if it is one of :data:`ENV_IDS`; else a ValueError listing them."""
    if not isinstance(env_id, str) or env_id not in ENV_IDS:
        raise ValueError(
            f"{name} = {env_id!r} is not a tandem-wing env; allowed: {', '.join(ENV_IDS)}"
        )
    return env_id


def register_envs() -> None:
    """Register every id (idempotent: a reload does not re-register or warn)."""
    from gymnasium.envs.registration import register, registry

    for env_id, (entry_point, vector_entry_point) in _ENTRY_POINTS.items():
        if env_id in registry:
            continue
        # No max_episode_steps: the one-cycle episodes terminate after their step and
        # SpeedChange truncates itself after max_cycles, so a TimeLimit would only duplicate it.
        register(id=env_id, entry_point=entry_point, vector_entry_point=vector_entry_point)
