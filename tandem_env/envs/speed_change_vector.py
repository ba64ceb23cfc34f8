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

Seeding, ``reset`` (with ``reset_mask``), ``step`` and its autoreset modes, the per-env
generators, rendering, pickling and closing are the one-cycle vector env's
(:class:`~tandem_env.envs.vector.FlightVectorEnv`); this module adds the episode state.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from .speed_change import LastCycle, frame_for, observation_space
from .speed_change_config import SpeedChangeConfig
from .speed_change_task import CycleBatch, Flight, SpeedChangeTask
from .task import Columns
from .vector import EnvGenerators, EnvOptions, FlightVectorEnv


class SpeedChangeVectorEnv(FlightVectorEnv):
    """n :class:`~tandem_env.envs.speed_change.SpeedChangeEnv` in one batched model call per step.

    Args: as :class:`~tandem_env.envs.vector.FlightVectorEnv` (``num_envs``, ``render_mode``,
    ``autoreset_mode``, ``config`` or the env's keyword options).
    """

    config_class = SpeedChangeConfig
    config: SpeedChangeConfig
    task: SpeedChangeTask  # type: ignore[assignment]
    picture = LastCycle
    _last: list[LastCycle | None]  # type: ignore[assignment]

    @property
    def conditions(self) -> np.ndarray:
        """(n,) target speed of each sub-env's episode [m/s]."""
        return self._flight.target_speed.copy()

    @property
    def flight(self) -> Flight:
        """The state of every sub-env's episode (a copy)."""
        return self._flight.take(np.arange(self.num_envs))

    # --- what differs from the one-cycle env ----------------------------------------------------
    def _make_task(self) -> SpeedChangeTask:
        return SpeedChangeTask(self.config)

    def _observation_space(self) -> spaces.Box:
        return observation_space()

    def _init_episodes(self, n: int) -> None:
        self._flight = Flight.empty(n)

    def _start(self, index: np.ndarray, rng: EnvGenerators, options: EnvOptions) -> Columns:
        flight = self.task.draw(index.size, rng, options)
        self._flight.put(index, flight)
        self._observations[index] = self.task.observe(flight)
        return self.task.reset_columns(flight)

    def _fly(self, index: np.ndarray, actions: Any) -> tuple[CycleBatch, np.ndarray]:
        """Fly one cycle of sub-envs ``index`` in one model call; (batch, observations)."""
        batch = self.task.step(actions, self._flight.take(index))
        self._flight.put(index, batch.after)
        observations = self.task.observe(batch.after)
        self._observations[index] = observations
        return batch, observations

    def _frame(self, i: int, title: str) -> Any:
        flight = self._flight if self._started[i] else None
        return frame_for(self.task, title, flight, i, self._last[i])
