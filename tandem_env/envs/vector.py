"""The native vector env: n flight envs stepped by ONE batched model call.

``gym.make_vec(id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)`` builds it.
It reproduces :class:`gymnasium.vector.SyncVectorEnv` over n single envs exactly (same
observations, rewards, terminations, truncations and infos for the same seeds, env i seeded
with ``seed + i``) in each :class:`~gymnasium.vector.AutoresetMode`, while evaluating all
stepped envs in one :func:`tandem_env.evaluate` call instead of n.

Autoreset (default ``NEXT_STEP``, Gymnasium's default): every episode is one step, so after a
step that terminates, the *next* ``step`` resets those envs instead of evaluating them: it
ignores their actions and returns their new observation, reward 0, ``terminated=False`` and
the reset info. With all envs in step, evaluating steps and resetting steps alternate. Use
``autoreset_mode="SameStep"`` to reset in the same step (every step evaluates; the final
observation and info are in ``info["final_obs"]`` / ``info["final_info"]``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..physics.checks import real_array
from .config import AccelerateConfig, FlightConfig, LevelFlightConfig
from .flight import (
    RENDER_FPS,
    RENDER_MODES,
    LastStep,
    RenderWindow,
    action_space,
    build_config,
    check_render_mode,
    frame_for,
    observation_space,
)
from .task import Columns, StepBatch, add_columns, make_task, take_columns

EnvGenerators = Callable[[int], np.random.Generator]
"""``rng(k)``: the generator of the k-th sub-env being reset."""
EnvOptions = list[Mapping[str, Any] | None]
"""The reset options of each sub-env being reset."""


class FlightVectorEnv(RenderWindow, VectorEnv):
    """Shared base of the native vector envs; see the module docstring for the semantics.

    Args:
        num_envs: Number of sub-envs n (>= 1).
        render_mode: None, "rgb_array" (``render()`` returns one frame per sub-env) or "human"
            (a window showing sub-env 0, redrawn at each step).
        autoreset_mode: ``AutoresetMode`` or its value ("NextStep", "SameStep", "Disabled").
        config: A ready config; otherwise the keyword options, as for the single env.
    """

    metadata: ClassVar[dict[str, Any]] = {
        "render_modes": list(RENDER_MODES),
        "render_fps": RENDER_FPS,
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }
    config_class: ClassVar[type[FlightConfig]] = FlightConfig
    picture: ClassVar[Callable[[Any, int], Any]] = LastStep
    """What a sub-env's picture keeps of its last step: ``picture(batch, k)``."""

    def __init__(
        self,
        num_envs: int = 1,
        render_mode: str | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        *,
        config: FlightConfig | None = None,
        **kwargs: Any,
    ) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer) or num_envs < 1:
            raise ValueError(f"num_envs = {num_envs!r}; allowed: an integer >= 1")
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError as error:
            allowed = ", ".join(repr(m.value) for m in AutoresetMode)
            raise ValueError(f"autoreset_mode = {autoreset_mode!r}; allowed: {allowed}") from error
        self.num_envs = int(num_envs)
        self.render_mode = check_render_mode(render_mode)
        self.autoreset_mode = mode
        self.metadata = {**type(self).metadata, "autoreset_mode": mode}
        self.config = build_config(self.config_class, config, kwargs)
        self.task = self._make_task()
        self.single_action_space = action_space()
        self.single_observation_space = self._observation_space()
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)

        n = self.num_envs
        self._rngs: list[np.random.Generator | None] = [None] * n
        self._rng_seeds: list[int | None] = [None] * n
        self._observations = np.zeros((n, *self.single_observation_space.shape), dtype=np.float32)
        self._autoreset = np.zeros(n, dtype=np.bool_)
        self._started = np.zeros(n, dtype=np.bool_)
        self._last: list[LastStep | None] = [None] * n
        self._window: Any = None
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
            self._rng(i)
        return tuple(self._rng_seeds)

    @property
    def conditions(self) -> np.ndarray:
        """(n,) current condition of each sub-env (speed [m/s] or available power [W/kg])."""
        return self._values.copy()

    @property
    def observations(self) -> np.ndarray:
        """(n, 1) current observation of each sub-env (a copy)."""
        return self._observations.copy()

    # --- primitives shared with the SB3 adapter (no autoreset bookkeeping, no rendering) ------
    def reset_envs(
        self,
        index: np.ndarray,
        seeds: Sequence[int | None],
        options: Mapping[str, Any] | Sequence[Mapping[str, Any] | None] | None,
    ) -> Columns:
        """Start new episodes in sub-envs ``index`` (each seeded with its entry of ``seeds``
        unless None; ``options`` one mapping for all or one per env); returns their reset info
        columns. ``reset`` and the SB3 adapter both start episodes through it."""
        index = np.asarray(index, dtype=np.intp)
        for i, seed in zip(index, seeds, strict=True):
            if seed is not None:
                self._rngs[i], self._rng_seeds[i] = seeding.np_random(seed)
        if options is None or isinstance(options, Mapping):
            per_env = [options] * index.size
        else:
            per_env = list(options)
        columns = self._start(index, lambda k: self._rng(int(index[k])), per_env)
        self._started[index] = True
        for i in index:
            self._last[i] = None
        return columns

    def step_envs(self, index: np.ndarray, actions: Any) -> tuple[Any, np.ndarray]:
        """Evaluate the strokes (actions) of sub-envs ``index`` in one model call; returns the
        batch and the observations after it (those an ended episode ended on). ``step`` and the
        SB3 adapter both step through it."""
        index = np.asarray(index, dtype=np.intp)
        if not self._started[index].all():
            raise ResetNeeded("call reset() before step()")
        batch, observations = self._fly(index, actions)
        for k, i in enumerate(index):
            self._last[i] = self.picture(batch, k)
        return batch, observations

    # --- what differs between the one-cycle and the multi-cycle env ----------------------------
    def _make_task(self) -> Any:
        """The batched core behind the sub-envs."""
        return make_task(self.config)

    def _observation_space(self) -> spaces.Box:
        """One sub-env's observation space."""
        return observation_space()

    def _init_episodes(self, n: int) -> None:
        """The episode state of n sub-envs before their first reset."""
        self._values = np.full(n, np.nan)

    def _start(self, index: np.ndarray, rng: EnvGenerators, options: EnvOptions) -> Columns:
        """Draw new episodes for sub-envs ``index`` (``rng(k)`` the generator of the k-th),
        set their state and observations; their reset info columns."""
        values = self.task.draw_conditions(index.size, rng, options)
        self._values[index] = values
        self._observations[index] = self.task.observe(values)
        return self.task.reset_columns(values)

    def _fly(self, index: np.ndarray, actions: Any) -> tuple[StepBatch, np.ndarray]:
        """Evaluate the strokes of started sub-envs ``index``; (batch, observations after)."""
        values = self._values[index]
        return self.task.step(actions, values), self.task.observe(values)

    def _frame(self, i: int, title: str) -> Any:
        """The render frame of sub-env ``i``."""
        value = None if not self._started[i] else float(self._values[i])
        return frame_for(self.task, title, value, self._last[i])

    # --- Gymnasium VectorEnv API ------------------------------------------------------------------
    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        n = self.num_envs
        if seed is None:
            seeds: list[int | None] = [None] * n
        elif isinstance(seed, int | np.integer) and not isinstance(seed, bool):
            seeds = [int(seed) + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ValueError(
                    f"If seeds are passed as a list the length must match num_envs={n} but got "
                    f"length={len(seeds)}."
                )
        options = dict(options) if options is not None else None
        if options is not None and "reset_mask" in options:
            mask = options.pop("reset_mask")
            if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (n,):
                raise ValueError(
                    f"options['reset_mask'] must be a numpy bool array of shape ({n},); got {mask!r}"
                )
            if not mask.any():
                raise ValueError("options['reset_mask'] must contain at least one True value")
            index = np.flatnonzero(mask)
        else:
            index = np.arange(n)
        columns = self.reset_envs(index, [seeds[i] for i in index], options)
        self._autoreset[index] = False
        if self.render_mode == "human":
            self.render()
        return self._observations.copy(), add_columns({}, columns, index, n)

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        n = self.num_envs
        actions = real_array(
            actions, "actions", f"real numbers of shape {self.action_space.shape} (num_envs, 28)"
        )
        if actions.shape != self.action_space.shape:
            raise ValueError(
                f"actions must have shape {self.action_space.shape} (num_envs, 28); got "
                f"shape {actions.shape}"
            )
        rewards = np.zeros(n, dtype=np.float64)
        terminations = np.zeros(n, dtype=np.bool_)
        truncations = np.zeros(n, dtype=np.bool_)
        infos: dict[str, Any] = {}

        def fly(index: np.ndarray) -> tuple[Any, np.ndarray]:
            batch, final = self.step_envs(index, actions[index])
            rewards[index] = batch.reward
            terminations[index] = batch.terminated
            truncations[index] = batch.truncated
            return batch, final

        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            resetting = np.flatnonzero(self._autoreset)
            stepping = np.flatnonzero(~self._autoreset)
            if stepping.size:
                batch, _ = fly(stepping)
                add_columns(infos, batch.info_columns(), stepping, n)
            if resetting.size:
                columns = self.reset_envs(resetting, [None] * resetting.size, None)
                add_columns(infos, columns, resetting, n)
        elif self.autoreset_mode == AutoresetMode.SAME_STEP:
            batch, final = fly(np.arange(n))
            ended = terminations | truncations
            columns = batch.info_columns()
            running, done = np.flatnonzero(~ended), np.flatnonzero(ended)
            if running.size:
                add_columns(infos, take_columns(columns, running), running, n)
            if done.size:
                final_obs = np.full(n, None, dtype=object)
                for i in done:
                    final_obs[i] = final[i]
                infos["final_obs"], infos["_final_obs"] = final_obs, ended.copy()
                infos["final_info"] = add_columns({}, take_columns(columns, done), done, n)
                infos["_final_info"] = ended.copy()
                add_columns(infos, self.reset_envs(done, [None] * done.size, None), done, n)
                # The stroke just evaluated stays the picture until the next step.
                for i in done:
                    self._last[i] = self.picture(batch, int(i))
        else:
            if self._autoreset.any():
                raise RuntimeError(
                    f"sub-envs {np.flatnonzero(self._autoreset).tolist()} have ended their "
                    "episodes; with autoreset_mode=Disabled reset them first, e.g. "
                    "reset(options={'reset_mask': mask})"
                )
            everyone = np.arange(n)
            batch, _ = fly(everyone)
            add_columns(infos, batch.info_columns(), everyone, n)

        self._autoreset = terminations | truncations
        if self.render_mode == "human":
            self.render()
        return self._observations.copy(), rewards, terminations, truncations, infos

    def render(self) -> tuple[np.ndarray, ...] | None:
        """rgb_array: one frame per sub-env (costly for large n); human: sub-env 0 in a window."""
        if self.render_mode is None:
            return None
        title = self.spec.id if self.spec is not None else type(self).__name__
        if self.render_mode == "rgb_array":
            return tuple(
                self._show(self._frame(i, f"{title} [env {i}]")) for i in range(self.num_envs)
            )  # type: ignore[return-value]
        self._show(self._frame(0, f"{title} [env 0]"))
        return None

    def close_extras(self, **kwargs: Any) -> None:
        self._close_window()

    def __repr__(self) -> str:
        name = self.spec.id if self.spec is not None else type(self).__name__
        return f"{type(self).__name__}({name}, num_envs={self.num_envs})"


class LevelFlightVectorEnv(FlightVectorEnv):
    """n :class:`~tandem_env.envs.flight.LevelFlightEnv` in one batched model call."""

    config_class = LevelFlightConfig
    config: LevelFlightConfig


class AccelerateVectorEnv(FlightVectorEnv):
    """n :class:`~tandem_env.envs.flight.AccelerateEnv` in one batched model call."""

    config_class = AccelerateConfig
    config: AccelerateConfig
