"""The Gymnasium ids of the flight environments, registered (as strings, importing nothing)
when ``tandem_env`` is imported."""

from __future__ import annotations

import warnings
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
    """The task module; it defines ``{env}Env`` and ``{env}VectorEnv``."""
    env: str
    """The env's class name without ``Env``, e.g. ``"LevelFlight"``."""
    task: str | None = None
    """Name of the harness task (``--task``) that runs this env; None for none."""


#: Every env id registered through :func:`add_entry`: this package's own (adding a task is its
#: module and one line here), then those of plug-ins and tests.
ENTRIES: dict[str, EnvEntry] = {
    LEVEL_FLIGHT_ID: EnvEntry("tandem_env.envs.level_flight", "LevelFlight", task="level"),
    ACCELERATE_ID: EnvEntry("tandem_env.envs.accelerate", "Accelerate", task="accelerate"),
    SPEED_CHANGE_ID: EnvEntry("tandem_env.envs.speed_change", "SpeedChange"),
}
#: This package's own ids, which :func:`remove_entry` keeps.
_OWN_IDS: frozenset[str] = frozenset(ENTRIES)
#: The entry-point group of out-of-tree tasks: env id -> an :class:`EnvEntry`, e.g. in a
#: plug-in's pyproject.toml ``[project.entry-points."tandem_env.tasks"]``
#: ``"Mine/Cruise-v0" = "my_tasks:CRUISE_ENTRY"``.
TASK_ENTRY_POINTS = "tandem_env.tasks"


def env_ids() -> tuple[str, ...]:
    """The tandem-wing env ids now: every :data:`ENTRIES` id still in Gymnasium's registry."""
    from gymnasium.envs.registration import registry

    return tuple(env_id for env_id in ENTRIES if env_id in registry)


def task_env_ids() -> dict[str, str]:
    """Harness task name -> the env id it runs, for the ids of :func:`env_ids` with a task."""
    return {e.task: i for i in env_ids() if (e := ENTRIES[i]).task is not None}


def check_env_id(env_id: object, name: str = "env_id") -> str:
    """``env_id`` if it is one of :func:`env_ids` (read now); else a ValueError listing them."""
    allowed = env_ids()
    if not isinstance(env_id, str) or env_id not in allowed:
        raise ValueError(
            f"{name} = {env_id!r} is not a tandem-wing env; allowed: {', '.join(allowed)}"
        )
    return env_id


def register_envs() -> None:
    """Register every id of :data:`ENTRIES` and of the ``tandem_env.tasks`` entry points
    (idempotent); a broken entry point is skipped with a warning naming it."""
    from importlib.metadata import entry_points

    for env_id, entry in list(ENTRIES.items()):
        add_entry(env_id, entry)
    for point in entry_points(group=TASK_ENTRY_POINTS):
        try:
            add_entry(point.name, point.load())
        except Exception as error:  # a plug-in's own failure: report it, keep the others
            skipped = f"{TASK_ENTRY_POINTS} entry point {point.name} = {point.value} skipped"
            warnings.warn(f"{skipped}: {error}", stacklevel=2)


def add_entry(env_id: str, entry: EnvEntry) -> None:
    """Register one task module's env under ``env_id`` (and its harness task); idempotent."""
    from gymnasium.envs.registration import register, registry

    if not isinstance(entry, EnvEntry):
        raise ValueError(f"entry = {entry!r}; allowed: an EnvEntry(module, env, task=None)")
    known = ENTRIES.get(env_id)
    if known is not None and known != entry:
        raise ValueError(f"env id {env_id!r} is already registered as {known!r}")
    if entry.task is not None:
        runs = task_env_ids().get(entry.task, env_id)
        if runs != env_id:
            raise ValueError(f"task {entry.task!r} already runs {runs}; allowed: a new name")
    ENTRIES[env_id] = entry
    if env_id not in registry:
        # no max_episode_steps: the one-cycle episodes terminate after their step and
        # SpeedChange truncates itself after max_cycles (a TimeLimit would only duplicate it)
        where = f"{entry.module}:{entry.env}"  # the task module's {env}Env and {env}VectorEnv
        register(id=env_id, entry_point=f"{where}Env", vector_entry_point=f"{where}VectorEnv")


def remove_entry(env_id: str) -> None:
    """Undo :func:`add_entry` for an id added after import (this package's own ids stay)."""
    from gymnasium.envs.registration import registry

    if env_id in _OWN_IDS or env_id not in ENTRIES:
        added = [i for i in ENTRIES if i not in _OWN_IDS]
        raise ValueError(f"env id {env_id!r}; allowed: an id added by add_entry: {added}")
    del ENTRIES[env_id]
    registry.pop(env_id, None)


def config_class(env_id: str) -> type[Any]:
    """The config class of a registered env id (its entry points' ``config_class``)."""
    return _entry_class(env_id, "config_class")


def core_class(env_id: str) -> type[Any]:
    """The batched core class of a registered env id (its vector env's ``core_class``)."""
    return _entry_class(env_id, "core_class")


def _entry_class(env_id: str, attribute: str) -> type[Any]:
    """The class ``attribute`` of the first of ``env_id``'s entry points that has one."""
    from gymnasium.envs.registration import load_env_creator, registry

    if env_id not in registry:
        raise ValueError(f"env id {env_id!r} is not registered with Gymnasium")
    spec = registry[env_id]
    for entry_point in (spec.entry_point, spec.vector_entry_point):
        creator = load_env_creator(entry_point) if isinstance(entry_point, str) else entry_point
        found = getattr(creator, attribute, None)
        if isinstance(found, type):
            return found
    raise ValueError(
        f"{env_id}: neither its entry point {spec.entry_point!r} nor its vector entry point "
        f"{spec.vector_entry_point!r} has a {attribute}; allowed: an env class whose "
        "config_class has a DECLARATION (tandem_env.envs.declaration)"
    )


def condition_keywords() -> tuple[str, ...]:
    """Every keyword that sets a declared condition (fixed or range) of the registered envs."""
    declared = [getattr(config_class(env_id), "CONDITION", None) for env_id in env_ids()]
    keywords = [k for d in declared if d is not None for k in (d.keyword, d.range_keyword)]
    return tuple(dict.fromkeys(keywords))
