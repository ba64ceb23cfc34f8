"""The machinery every task module shares: the batched core (:class:`FlightCore`: conditions,
observations, one model call, rewards and infos for B strokes, without Gymnasium), the vector
env (:class:`FlightVectorEnv`: n sub-envs in ONE model call, equal to ``SyncVectorEnv`` over n
single envs in every autoreset mode) and the single env (:class:`FlightEnv`: the vector env at
B = 1, so the two cannot drift apart). An action is validated once, where an env receives it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..physics import N_PARAMETERS, Result, evaluate, normalised_to_physical
from ..physics.checks import count
from ..physics.model import MAX_BATCH_STROKES
from .config import (
    RENDER_MODES,
    FlightConfig,
    action_array,
    action_values,
    check_render_mode,
    reset_options,
)
from .declaration import TaskDeclaration, refusal
from .problem import FlightProblem
from .reference import ConfigReference
from .render import Frame, LastStep, RenderWindow, history_of, metrics_line
from .step_batch import Columns, StepBatch, add_columns, row, take_columns

RENDER_FPS = 4
#: The ``metadata`` of every flight env; a vector env's adds its autoreset mode.
_METADATA: dict[str, Any] = {"render_modes": list(RENDER_MODES), "render_fps": RENDER_FPS}

EnvGenerators = Callable[[int], np.random.Generator]
"""``rng(k)``: the generator of the k-th sub-env being reset."""
EnvOptions = Sequence[Mapping[str, Any] | None]
"""The reset options of each sub-env being reset."""

_FIRST = np.zeros(1, dtype=np.intp)


#: The action space's dtype: what an agent's action (an SB3 policy's output) carries.
ACTION_DTYPE = np.float32
#: The action box's bounds, every coordinate: the normalised stroke's range, which
#: ``physics.normalised_to_physical`` maps onto Table 4's bounds.
ACTION_LOW, ACTION_HIGH = -1.0, 1.0


def action_space() -> spaces.Box:
    """Box(-1, 1, (28,), float32): the normalised stroke, fore-wing first (Table 4 order)."""
    return spaces.Box(ACTION_LOW, ACTION_HIGH, (N_PARAMETERS,), dtype=ACTION_DTYPE)


def as_action_type(strokes: Any) -> np.ndarray:
    """Normalised strokes (any shape) rounded to :data:`ACTION_DTYPE`, as float64: the strokes
    the harness searches and reports, so that stepped as float32 actions they are the same."""
    return np.asarray(strokes, dtype=np.float64).astype(ACTION_DTYPE).astype(np.float64)


def fly(
    config: FlightConfig,
    physical: np.ndarray,
    speed: np.ndarray,
    power: np.ndarray,
    flight_path_angle: float | np.ndarray = 0.0,
) -> Result:
    """ONE batched model call for B physical strokes with the config's model: every env's."""
    model = {"insect": config.insect, "options": config.options}
    model |= {"backend": config.backend, "device": config.device}
    return evaluate(physical, speed, power, flight_path_angle=flight_path_angle, **model)


class FlightCore:
    """The batched core of a one-cycle task: draw conditions, observe them, score strokes; a
    task's core defines only how its declared condition enters the model
    (:meth:`flight_conditions`)."""

    config: FlightConfig

    def __init__(self, config: FlightConfig) -> None:
        self.config = config
        self._low, self._high = config.envelope
        self._renamed = config.declared_condition.renamed()
        self.option_key = config.declared_condition.keyword
        """The ``reset(options=...)`` key that sets the condition for one episode."""
        self.reference = ConfigReference(config)
        """The reference optima this config's strokes are scored against (or none)."""

    @property
    def declaration(self) -> TaskDeclaration:
        """The task's declaration (a class attribute of its config, so never pickled)."""
        return type(self.config).DECLARATION  # type: ignore[return-value]

    def draw(self, count: int, rngs: EnvGenerators, options: EnvOptions) -> np.ndarray:
        """Conditions (count,) of new episodes: ``options[k]``'s, the fixed one, or one
        ``uniform`` draw from ``rngs(k)`` (so every front end consumes the streams alike)."""
        cfg, key = self.config, self.option_key
        where = (self._low, self._high, cfg.declared_condition.unit, "the observation envelope")
        values = np.empty(count)
        for k in range(count):
            given = reset_options(cfg.name, options[k], {key: where}, self._renamed)
            value = given.get(key, cfg.fixed_condition)  # None: sampled
            values[k] = rngs(k).uniform(*cfg.condition_range) if value is None else value
        return values

    def observe(self, values: np.ndarray) -> np.ndarray:
        """(B, 1) float32 observations: each condition mapped from the envelope to [-1, 1]."""
        scaled = 2.0 * (np.asarray(values, dtype=np.float64) - self._low) / (self._high - self._low)
        return np.clip(scaled - 1.0, -1.0, 1.0).astype(np.float32)[:, None]

    def flight_conditions(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(speed [m/s], available power [W/kg]) arrays (B,) for conditions ``values``."""
        raise NotImplementedError

    def reset_columns(self, values: np.ndarray) -> Columns:
        """Reset info columns: the flight condition of each new episode."""
        return dict(zip(("speed", "available_power"), self.flight_conditions(values), strict=True))

    def step(self, physical: np.ndarray, values: np.ndarray) -> StepBatch:
        """Evaluate one wing-beat of each (validated, physical) stroke in its condition, in ONE
        batched model call, and score it by the task's declaration."""
        speed, power = self.flight_conditions(values)
        result = fly(self.config, physical, speed, power)
        objective = getattr(result, self.config.objective_metric)
        scores = self.declaration.score(result, self.config)
        score = self.reference.score(values, objective, scores.feasible, scores.total)
        penalty = self.config.penalty.penalty(scores.total, scores.feasible)
        return StepBatch(physical, result, objective, scores, penalty, score)


class FlightVectorEnv(RenderWindow, VectorEnv):
    """n sub-envs (1 to ``MAX_BATCH_STROKES``) of a task in ONE batched model call per step;
    ``render_mode`` "rgb_array" renders a frame per sub-env, "human" sub-env 0; ``config`` a
    ready config, else the single env's keyword options."""

    metadata: ClassVar[dict[str, Any]] = {**_METADATA, "autoreset_mode": AutoresetMode.NEXT_STEP}
    config_class: ClassVar[type[FlightConfig]] = FlightConfig
    core_class: ClassVar[type[Any]] = FlightCore

    def __init__(
        self,
        num_envs: int = 1,
        render_mode: str | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        *,
        config: FlightConfig | None = None,
        **kwargs: Any,
    ) -> None:
        # one batch of strokes per step: the model's batch limit is every vector env's
        count(num_envs, "num_envs", 1, MAX_BATCH_STROKES, "sub-envs: one model batch per step")
        try:
            self.autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError as error:
            allowed = ", ".join(repr(m.value) for m in AutoresetMode)
            raise refusal("autoreset_mode", autoreset_mode, allowed) from error
        self.num_envs = int(num_envs)
        self.render_mode = check_render_mode(render_mode)
        self.metadata = {**type(self).metadata, "autoreset_mode": self.autoreset_mode}
        if config is not None and kwargs:
            raise ValueError(
                f"give either config= or keyword options, not both; got config and {sorted(kwargs)}"
            )
        if not isinstance(config, self.config_class | None):
            raise refusal("config", config, f"a {self.config_class.__name__} (or keyword options)")
        self.config = self.config_class.from_kwargs(**kwargs) if config is None else config
        self.core = self.core_class(self.config)
        self.single_action_space = action_space()
        self.single_observation_space = self._observation_space()
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)

        n = self.num_envs
        self._rngs: list[np.random.Generator | None] = [None] * n
        self._rng_seeds: list[int | None] = [None] * n
        self._observations = np.zeros((n, *self.single_observation_space.shape), dtype=np.float32)
        self._started = np.zeros(n, dtype=np.bool_)
        self._ended = np.zeros(n, dtype=np.bool_)
        self._last: list[LastStep | None] = [None] * n
        self._init_episodes(n)

    # --- per-env random generators (one per sub-env, as SyncVectorEnv's envs have) -------------
    def _rng(self, i: int) -> np.random.Generator:
        if self._rngs[i] is None:
            self._rngs[i], self._rng_seeds[i] = seeding.np_random()
        return self._rngs[i]  # type: ignore[return-value]

    @property
    def np_random(self) -> tuple[np.random.Generator, ...]:  # type: ignore[override]
        """Each sub-env's generator (created with a random seed if never seeded)."""
        return tuple(self._rng(i) for i in range(self.num_envs))

    @property
    def np_random_seed(self) -> tuple[int | None, ...]:  # type: ignore[override]
        """Each sub-env's seed."""
        for i in range(self.num_envs):
            self._rng(i)  # a sub-env never seeded gets its generator and seed now
        return tuple(self._rng_seeds)

    @property
    def conditions(self) -> np.ndarray:
        """(n,) current condition of each sub-env (its declared condition's unit)."""
        return self._state.copy()

    @property
    def observations(self) -> np.ndarray:
        """(n, ...) current observation of each sub-env (a copy)."""
        return self._observations.copy()

    def problem(self) -> FlightProblem:
        """The task as an optimisation problem over the action box (:mod:`~.problem`): bounds,
        constraints, batched evaluation through the core's ``step`` at explicit conditions. A
        one-cycle task's only: a sequential task's core has no one-stroke problem (TypeError)."""
        if not isinstance(self.core, FlightCore):
            raise TypeError(
                f"{self!r}: {type(self.core).__name__} poses no one-stroke problem; allowed: a "
                "one-cycle task (a FlightCore)"
            )
        return FlightProblem(self.core, ACTION_LOW, ACTION_HIGH)

    @property
    def started(self) -> np.ndarray:
        """(n,) bool, whether each sub-env has been reset at least once (a copy)."""
        return self._started.copy()

    # --- primitives shared with the single env and the SB3 adapter --------------------------------
    def start(self, index: np.ndarray, rng: EnvGenerators, options: EnvOptions) -> Columns:
        """Start new episodes in sub-envs ``index`` drawing from ``rng(k)`` (the generator of
        the k-th); their reset info columns. The single env passes its own ``np_random``."""
        state = self.core.draw(index.size, rng, options)
        self._state[index] = state
        self._observations[index] = self.core.observe(state)
        self._started[index] = True
        self._ended[index] = False
        for i in index:
            self._last[i] = None
        return self.core.reset_columns(state)

    def reset_envs(
        self,
        index: np.ndarray,
        seeds: Sequence[int | None],
        options: Mapping[str, Any] | Sequence[Mapping[str, Any] | None] | None,
    ) -> Columns:
        """Start new episodes in sub-envs ``index`` (each seeded with its entry of ``seeds``
        unless None; ``options`` one mapping for all or one per env); their reset info columns."""
        index = np.asarray(index, dtype=np.intp)
        for i, seed in zip(index, seeds, strict=True):
            if seed is not None:
                self._rngs[i], self._rng_seeds[i] = seeding.np_random(seed)
        if options is None or isinstance(options, Mapping):
            per_env: EnvOptions = [options] * index.size
        else:
            per_env = list(options)
        return self.start(index, lambda k: self._rng(int(index[k])), per_env)

    def autoreset(self, index: np.ndarray) -> Columns:
        """Start new episodes (unseeded, no options) in the ended sub-envs ``index`` within the
        step that ended them (same-step mode, SB3); their frames still show the stroke flown."""
        pictures = [self._last[i] for i in index]
        columns = self.reset_envs(index, [None] * index.size, None)
        for i, picture in zip(index, pictures, strict=True):
            self._last[i] = picture
        return columns

    def step_envs(self, index: np.ndarray, actions: Any) -> tuple[Any, np.ndarray]:
        """Validate and evaluate the actions (len(index), 28) of sub-envs ``index`` in one model
        call; (batch, observations after it). The SB3 adapter steps through it."""
        index = np.asarray(index, dtype=np.intp)
        shape = (index.size, N_PARAMETERS)
        arr = action_values(action_array(actions, shape), self.config.clip_actions)
        return self.step_checked(index, arr)

    def step_checked(self, index: np.ndarray, actions: np.ndarray) -> tuple[Any, np.ndarray]:
        """Step sub-envs ``index`` with normalised actions (len(index), 28) their caller has
        validated; (batch, observations after it)."""
        if not self._started[index].all():
            raise ResetNeeded("call reset() before step()")
        if self._ended[index].any():
            raise ResetNeeded("the episode has ended; call reset() before step()")
        bounds = self.config.insect.stroke_bounds  # the flyer's own (Table 4 by default)
        batch, observations = self._fly(index, normalised_to_physical(actions, bounds))
        self._ended[index] = batch.terminated | batch.truncated
        for k, i in enumerate(index):
            self._last[i] = LastStep(batch, k)
        return batch, observations

    # --- what a task with another episode state overrides ----------------------------------------
    def _observation_space(self) -> spaces.Box:
        """One sub-env's observation space: the condition normalised over its envelope."""
        return spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)

    def _init_episodes(self, n: int) -> None:
        """The episode state of n sub-envs before their first reset, ``_state``: the core's
        ``draw`` and ``step`` take it, read (``_state[index]``) and set by sub-env."""
        self._state = np.full(n, np.nan)

    def _fly(self, index: np.ndarray, physical: np.ndarray) -> tuple[Any, np.ndarray]:
        """Evaluate the strokes of started sub-envs ``index``; (batch, observations after)."""
        return self.core.step(physical, self._state[index]), self._observations[index]

    def frame(self, i: int, title: str) -> Frame:
        """The render frame of sub-env ``i`` under ``title`` (drawn by ``render``)."""
        cfg, last = self.config, self._last[i]
        if last is not None:
            # The condition the stroke was evaluated in (a same-step autoreset may have moved on).
            speed = float(last.batch.result.speed[last.index])
            power = float(last.batch.result.available_power[last.index])
        elif self._started[i]:
            conditions = self.core.flight_conditions(self._state[i : i + 1])
            speed, power = (float(v[0]) for v in conditions)
        else:
            return Frame(title=f"{title}  {cfg.describe()}", subtitle="not reset yet", history=None)
        heading = f"{title}  V = {speed:.3g} m/s, P_avail = {power:.3g} W/kg"
        if last is None:
            return Frame(title=heading, subtitle="no stroke evaluated since reset", history=None)
        columns = {k: v for k, v in last.batch.info_columns().items() if not isinstance(v, dict)}
        keyword = cfg.OBJECTIVES.keyword if cfg.OBJECTIVES is not None else None
        label = "η" if keyword is None else f"F̄ ({getattr(cfg, keyword)})"
        line = metrics_line(float(last.batch.reward[last.index]), row(columns, last.index), label)
        return Frame(heading, line, history_of(last.batch, last.index, cfg.insect, cfg.options))

    # --- Gymnasium VectorEnv API ------------------------------------------------------------------
    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        n = self.num_envs
        if seed is None or (isinstance(seed, int | np.integer) and not isinstance(seed, bool)):
            seeds: list[int | None] = [None if seed is None else int(seed) + i for i in range(n)]
        elif len(seeds := list(seed)) != n:
            raise ValueError(
                f"If seeds are passed as a list the length must match num_envs={n} but got "
                f"length={len(seeds)}."
            )
        options = dict(options) if options is not None else None
        index = np.arange(n)  # every sub-env, unless a reset_mask says which
        if options is not None and "reset_mask" in options:
            mask = options.pop("reset_mask")
            if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (n,):
                raise ValueError(
                    f"options['reset_mask'] must be a numpy bool array of shape ({n},); got {mask!r}"
                )
            if not mask.any():
                raise ValueError("options['reset_mask'] must contain at least one True value")
            index = np.flatnonzero(mask)
        columns = self.reset_envs(index, [seeds[i] for i in index], options)
        if self.render_mode == "human":
            self.render()
        return self._observations.copy(), add_columns({}, columns, index, n)

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        n = self.num_envs
        actions = action_array(actions, (n, N_PARAMETERS))
        # next-step autoreset resets the ended sub-envs instead; Disabled refuses them (same-step
        # autoreset has none: it resets them within the step that ended them, below)
        resetting, stepping = np.flatnonzero(self._ended), np.flatnonzero(~self._ended)
        if resetting.size and self.autoreset_mode == AutoresetMode.DISABLED:
            raise RuntimeError(
                f"sub-envs {resetting.tolist()} have ended their episodes; with "
                "autoreset_mode=Disabled reset them first, e.g. "
                "reset(options={'reset_mask': mask})"
            )
        rewards = np.zeros(n, dtype=np.float64)
        terminations = np.zeros(n, dtype=np.bool_)
        truncations = np.zeros(n, dtype=np.bool_)
        infos: dict[str, Any] = {}
        if stepping.size:
            arr = action_values(actions[stepping], self.config.clip_actions)
            batch, final = self.step_checked(stepping, arr)
            rewards[stepping] = batch.reward
            terminations[stepping] = batch.terminated
            truncations[stepping] = batch.truncated
            columns, ended = batch.info_columns(), batch.terminated | batch.truncated
            ended &= self.autoreset_mode == AutoresetMode.SAME_STEP
            if not ended.any():  # the usual step: every column as it is, without a copy
                add_columns(infos, columns, stepping, n)
            elif not ended.all():
                add_columns(infos, take_columns(columns, ~ended), stepping[~ended], n)
            if ended.any():  # same-step: the final observations and infos, then the resets
                done, mask = stepping[ended], np.isin(np.arange(n), stepping[ended])
                final_obs = np.full(n, None, dtype=object)
                for i, observation in zip(done, final[ended], strict=True):
                    final_obs[i] = observation
                infos["final_obs"], infos["_final_obs"] = final_obs, mask
                infos["final_info"] = add_columns({}, take_columns(columns, ended), done, n)
                infos["_final_info"] = mask.copy()
                add_columns(infos, self.autoreset(done), done, n)
        if resetting.size:
            columns = self.reset_envs(resetting, [None] * resetting.size, None)
            add_columns(infos, columns, resetting, n)

        if self.render_mode == "human":
            self.render()
        return self._observations.copy(), rewards, terminations, truncations, infos

    def render(self) -> tuple[np.ndarray, ...] | None:
        """rgb_array: one frame per sub-env (costly for large n); human: sub-env 0 in a window."""
        if self.render_mode is None:
            return None
        title, count = self._title(), self.num_envs if self.render_mode == "rgb_array" else 1
        frames = tuple(self._show(self.frame(i, f"{title} [env {i}]")) for i in range(count))
        return frames if self.render_mode == "rgb_array" else None  # type: ignore[return-value]

    def close_extras(self, **kwargs: Any) -> None:
        self._close_window()

    def _title(self) -> str:
        return self.spec.id if self.spec is not None else type(self).__name__

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._title()}, num_envs={self.num_envs})"


class FlightEnv(RenderWindow, gym.Env[np.ndarray, np.ndarray]):
    """One env of a task: its vector env at B = 1 (``vector_class``), seeded through
    Gymnasium's ``Env.np_random``."""

    metadata: ClassVar[dict[str, Any]] = dict(_METADATA)
    vector_class: ClassVar[type[FlightVectorEnv]] = FlightVectorEnv
    vector_env: FlightVectorEnv
    """The vector env this env steps: ``vector_class`` with ``num_envs=1``, autoreset disabled
    (the registry finds the task's ``config_class`` on it)."""

    def __init__(
        self, render_mode: str | None = None, *, config: FlightConfig | None = None, **kwargs: Any
    ) -> None:
        self.render_mode = check_render_mode(render_mode)
        self.vector_env = self.vector_class(1, None, "Disabled", config=config, **kwargs)
        self.config = self.vector_env.config
        self.core = self.vector_env.core
        self.action_space = action_space()
        self.observation_space = self.vector_env.single_observation_space

    @property
    def condition(self) -> float | None:
        """The current episode's condition (its declared unit), or None before the first reset."""
        return float(self.vector_env.conditions[0]) if self.vector_env.started[0] else None

    def problem(self) -> FlightProblem:
        """The task as an optimisation problem, its vector env's (:meth:`FlightVectorEnv.problem`)."""
        return self.vector_env.problem()

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        columns = self.vector_env.start(_FIRST, lambda _: self.np_random, [options])
        if self.render_mode == "human":
            self.render()
        return self.vector_env.observations[0], row(columns, 0)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        arr = action_values(action_array(action, (N_PARAMETERS,)), self.config.clip_actions)
        batch, observations = self.vector_env.step_checked(_FIRST, arr[None, :])
        if self.render_mode == "human":
            self.render()
        ended = bool(batch.terminated[0]), bool(batch.truncated[0])
        return observations[0].copy(), float(batch.reward[0]), *ended, row(batch.info_columns(), 0)

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without a render mode; make the env with "
                f"render_mode in {list(RENDER_MODES)}"
            )
            return None
        title = self.spec.id if self.spec is not None else self.config.name  # the task's name
        return self._show(self.vector_env.frame(0, title))

    def close(self) -> None:
        self._close_window()
