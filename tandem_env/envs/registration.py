"""The Gymnasium ids of the flight environments, registered when ``tandem_env`` is imported.

Entry points are strings, so registering imports neither the env classes' dependencies
(matplotlib) nor Stable-Baselines3.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

LEVEL_FLIGHT_ID = "TandemWing/LevelFlight-v0"
"""Level flight: maximise η with L = W, T = D and P/m <= 90 W/kg."""
ACCELERATE_ID = "TandemWing/Accelerate-v0"
"""Accelerating flight: maximise a specific excess force with F_v, F_h >= 0 and P/m <= P_avail."""
SPEED_CHANGE_ID = "TandemWing/SpeedChange-v0"
"""Multi-cycle flight: reach a target speed and hold altitude, one stroke per wing-beat."""


@dataclass(frozen=True)
class EnvEntry:
    """One registered env: its task module and, if any, the harness task that runs it."""

    module: str
    """The task module; it defines ``{env}Env`` and ``{env}VectorEnv`` (the single env's
    ``config_class`` declares the task)."""
    env: str
    """The env's class name without ``Env``, e.g. ``"LevelFlight"``."""
    task: str | None = None
    """Name of the harness task (``agents.tasks``, ``--task`` on the command line) that
    optimises one stroke on this env, read from its config's ``DECLARATION``; None for an env
    the harness does not run (multi-cycle episodes)."""

    @property
    def entry_point(self) -> str:
        """``module:Class`` of the single env."""
        return f"{self.module}:{self.env}Env"

    @property
    def vector_entry_point(self) -> str:
        """``module:Class`` of the batched vector env."""
        return f"{self.module}:{self.env}VectorEnv"


#: Every env id this package registers. Adding a task is its module (declaration, config, core,
#: vector env, single env) and one line here.
ENTRIES: dict[str, EnvEntry] = {
    LEVEL_FLIGHT_ID: EnvEntry("tandem_env.envs.level_flight", "LevelFlight", task="level"),
    ACCELERATE_ID: EnvEntry("tandem_env.envs.accelerate", "Accelerate", task="accelerate"),
    SPEED_CHANGE_ID: EnvEntry("tandem_env.envs.speed_change", "SpeedChange"),
}
#: This package's own ids (``check_env_id``: the ids the SB3 adapter and training accept).
ENV_IDS: tuple[str, ...] = tuple(ENTRIES)
#: Harness task name -> the env id it runs, for the ids with a task (:func:`add_entry` adds).
TASK_ENV_IDS: dict[str, str] = {e.task: i for i, e in ENTRIES.items() if e.task is not None}


def check_env_id(env_id: object, name: str = "env_id") -> str:
    """``env_id`` if it is one of :data:`ENV_IDS`; else a ValueError listing them."""
    if not isinstance(env_id, str) or env_id not in ENV_IDS:
        raise ValueError(
            f"{name} = {env_id!r} is not a tandem-wing env; allowed: {', '.join(ENV_IDS)}"
        )
    return env_id


def register_envs() -> None:
    """Register every id (idempotent: a reload does not re-register or warn)."""
    for env_id, entry in ENTRIES.items():
        add_entry(env_id, entry)


def add_entry(env_id: str, entry: EnvEntry) -> None:
    """Register one task module's env under ``env_id`` with Gymnasium and, with
    ``entry.task``, as a harness task: the one line that adds a task (a plug-in or a test
    calls it as this package's :data:`ENTRIES` does). Idempotent for the same entry."""
    from gymnasium.envs.registration import register, registry

    if not isinstance(entry, EnvEntry):
        raise ValueError(f"entry = {entry!r}; allowed: an EnvEntry(module, env, task=None)")
    known = ENTRIES.get(env_id)
    if known is not None and known != entry:
        raise ValueError(f"env id {env_id!r} is already registered as {known!r}")
    ENTRIES[env_id] = entry
    if entry.task is not None:
        TASK_ENV_IDS[entry.task] = env_id
    if env_id not in registry:
        # No max_episode_steps: the one-cycle episodes terminate after their step and
        # SpeedChange truncates itself after max_cycles, so a TimeLimit would only duplicate it.
        register(
            id=env_id, entry_point=entry.entry_point, vector_entry_point=entry.vector_entry_point
        )


def config_class(env_id: str) -> type[Any]:
    """The config class of a registered env id: the ``config_class`` of its entry point (or,
    if that has none, of its vector entry point).

    Works for any id in Gymnasium's registry whose entry point is a class (or a
    ``module:Class`` string) with a ``config_class`` attribute, so that tasks registered
    outside this package (tests, plug-ins) are looked up the same way.
    """
    from gymnasium.envs.registration import load_env_creator, registry

    if env_id not in registry:
        raise ValueError(f"env id {env_id!r} is not registered with Gymnasium")
    spec = registry[env_id]
    for entry_point in (spec.entry_point, spec.vector_entry_point):
        creator = load_env_creator(entry_point) if isinstance(entry_point, str) else entry_point
        found = getattr(creator, "config_class", None)
        if isinstance(found, type):
            return found
    raise ValueError(
        f"{env_id}: neither its entry point {spec.entry_point!r} nor its vector entry point "
        f"{spec.vector_entry_point!r} has a config_class; allowed: an env class whose "
        "config_class has a DECLARATION (tandem_env.envs.declaration)"
    )


def core_class(env_id: str) -> type[Any]:
    """The batched core class of a registered env id (its vector env's ``core_class``)."""
    from gymnasium.envs.registration import load_env_creator, registry

    spec = registry[env_id]
    entry = spec.vector_entry_point
    creator = load_env_creator(entry) if isinstance(entry, str) else entry
    found = getattr(creator, "core_class", None)
    if not isinstance(found, type):
        raise ValueError(f"{env_id}: its vector entry point {entry!r} has no core_class")
    return found


def condition_keywords() -> tuple[str, ...]:
    """Every keyword that sets a declared condition (fixed value or range) of this package's
    envs, e.g. ``("speed", "speed_range", "available_power", "available_power_range")``."""
    keywords: list[str] = []
    for env_id in ENTRIES:
        declared = getattr(config_class(env_id), "CONDITION", None)
        if declared is not None:
            keywords += [declared.keyword, declared.range_keyword]
    return tuple(dict.fromkeys(keywords))
