"""The native vector env of ``TandemWing/SpeedChange-v0``: n episodes, ONE batched model call per step.

``gym.make_vec("TandemWing/SpeedChange-v0", num_envs=n)`` builds it. Each sub-env flies at its
own speed and flight-path angle; a step evaluates all stepped sub-envs' strokes in one
:func:`tandem_env.evaluate` call. It reproduces :class:`gymnasium.vector.SyncVectorEnv` over n
:class:`~tandem_env.envs.speed_change.SpeedChangeEnv` exactly (observations, rewards,
terminations, truncations and infos, env i seeded ``seed + i``) in each
:class:`~gymnasium.vector.AutoresetMode`: ``NextStep`` (default: the step after an episode ends
resets that sub-env, ignoring its action, with reward 0), ``SameStep`` (reset at once; the last
observation and info are in ``info["final_obs"]`` / ``info["final_info"]``) and ``Disabled``
(reset ended sub-envs yourself with ``reset(options={"reset_mask": mask})``).

Seeding, ``reset`` (with ``reset_mask``), the per-env generators, pickling and closing are the
one-cycle vector env's (:class:`~tandem_env.envs.vector.FlightVectorEnv`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from gymnasium.error import ResetNeeded
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from .speed_change import LastCycle, frame_for, observation_space
from .speed_change_config import SpeedChangeConfig
from .speed_change_task import CycleBatch, Flight, SpeedChangeTask, take_columns
from .task import Columns, add_columns
from .vector import FlightVectorEnv


class SpeedChangeVectorEnv(FlightVectorEnv):
    """n :class:`~tandem_env.envs.speed_change.SpeedChangeEnv` in one batched model call per step.

    Args: as :class:`~tandem_env.envs.vector.FlightVectorEnv` (``num_envs``, ``render_mode``,
    ``autoreset_mode``, ``config`` or the env's keyword options).
    """

    config_class = SpeedChangeConfig
    config: SpeedChangeConfig
    task: SpeedChangeTask  # type: ignore[assignment]

    def __init__(
        self,
        num_envs: int = 1,
        render_mode: str | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        *,
        config: SpeedChangeConfig | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(num_envs, render_mode, autoreset_mode, config=config, **kwargs)
        n = self.num_envs
        self.single_observation_space = observation_space()
        self.observation_space = batch_space(self.single_observation_space, n)
        self._observations = np.zeros((n, *self.single_observation_space.shape), dtype=np.float32)
        self._flight = Flight.empty(n)
        self._last: list[LastCycle | None] = [None] * n  # type: ignore[assignment]

    def _make_task(self) -> SpeedChangeTask:
        return SpeedChangeTask(self.config)

    @property
    def conditions(self) -> np.ndarray:
        """(n,) target speed of each sub-env's episode [m/s]."""
        return self._flight.target_speed.copy()

    @property
    def flight(self) -> Flight:
        """The state of every sub-env's episode (a copy)."""
        return self._flight.take(np.arange(self.num_envs))

    # --- primitives shared with the SB3 adapter -------------------------------------------------
    def reset_envs(
        self,
        index: np.ndarray,
        seeds: Sequence[int | None],
        options: Mapping[str, Any] | Sequence[Mapping[str, Any] | None] | None,
    ) -> Columns:
        """Start new episodes in sub-envs ``index``; returns their reset info columns."""
        index = np.asarray(index, dtype=np.intp)
        for i, seed in zip(index, seeds, strict=True):
            if seed is not None:
                self._rngs[i], self._rng_seeds[i] = seeding.np_random(seed)
        if options is None or isinstance(options, Mapping):
            per_env = [options] * index.size
        else:
            per_env = list(options)
        flight = self.task.draw(index.size, lambda k: self._rng(int(index[k])), per_env)
        self._flight.put(index, flight)
        self._observations[index] = self.task.observe(flight)
        self._started[index] = True
        for i in index:
            self._last[i] = None
        return self.task.reset_columns(flight)

    def step_envs(self, index: np.ndarray, actions: Any) -> tuple[CycleBatch, np.ndarray]:
        """Fly one cycle of sub-envs ``index`` in one model call; (batch, observations)."""
        index = np.asarray(index, dtype=np.intp)
        if not self._started[index].all():
            raise ResetNeeded("call reset() before step()")
        batch = self.task.step(actions, self._flight.take(index))
        self._flight.put(index, batch.after)
        observations = self.task.observe(batch.after)
        self._observations[index] = observations
        for k, i in enumerate(index):
            self._last[i] = LastCycle(batch, k)
        return batch, observations

    # --- Gymnasium VectorEnv API ------------------------------------------------------------------
    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        n = self.num_envs
        actions = np.asarray(actions)
        if actions.shape != self.action_space.shape:
            raise ValueError(
                f"actions must have shape {self.action_space.shape} (num_envs, 28); got "
                f"shape {actions.shape}"
            )
        rewards = np.zeros(n, dtype=np.float64)
        terminations = np.zeros(n, dtype=np.bool_)
        truncations = np.zeros(n, dtype=np.bool_)
        infos: dict[str, Any] = {}

        def fly(index: np.ndarray) -> tuple[CycleBatch, np.ndarray]:
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
            everyone = np.arange(n)
            batch, final = fly(everyone)
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
                # The cycle just flown stays the picture until the next step.
                for i in done:
                    self._last[i] = LastCycle(batch, int(i))
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
        from .render import HumanWindow, to_rgb_array

        title = self.spec.id if self.spec is not None else type(self).__name__

        def frame(i: int) -> Any:
            flight = self._flight if self._started[i] else None
            return frame_for(self.task, f"{title} [env {i}]", flight, i, self._last[i])

        if self.render_mode == "rgb_array":
            return tuple(to_rgb_array(frame(i)) for i in range(self.num_envs))
        if self._window is None:
            self._window = HumanWindow(self.metadata["render_fps"])
        self._window.show(frame(0))
        return None
