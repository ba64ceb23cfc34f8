"""Stable-Baselines3 ``VecEnv`` adapter over the native vector env: exactly what
``DummyVecEnv`` over n single envs gives SB3, from one batched model call instead of n.
This module imports Stable-Baselines3; ``import tandem_env`` does not. Example::

    from stable_baselines3 import PPO
    from tandem_env.envs.sb3 import make_sb3_vec_env

    venv = make_sb3_vec_env("TandemWing/LevelFlight-v0", n_envs=64, seed=0, speed_range=(0.25, 2.0))
    model = PPO("MlpPolicy", venv, n_steps=16, batch_size=256).learn(50_000)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecMonitor
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvStepReturn

from .base import FlightVectorEnv
from .registration import check_env_id
from .step_batch import rows


class TandemVecEnv(VecEnv):
    """SB3 ``VecEnv`` over a native :class:`~tandem_env.envs.base.FlightVectorEnv`: each step
    is one model call, and the ended sub-envs reset as in ``DummyVecEnv``. ``get_attr`` /
    ``env_method`` act on the shared native env, its value once per requested index."""

    def __init__(self, vector_env: FlightVectorEnv) -> None:
        if not isinstance(vector_env, FlightVectorEnv):
            raise ValueError(
                f"vector_env = {vector_env!r}; allowed: a tandem_env native vector env, e.g. "
                'gym.make_vec(id, num_envs=n, vectorization_mode="vector_entry_point")'
            )
        self.vector_env = vector_env
        self.config = vector_env.config
        """The env config (``LevelFlightConfig``, ``AccelerateConfig`` or ``SpeedChangeConfig``)."""
        super().__init__(
            vector_env.num_envs, vector_env.single_observation_space, vector_env.single_action_space
        )
        # What DummyVecEnv reports: the single env's metadata.
        self.metadata = {k: v for k, v in vector_env.metadata.items() if k != "autoreset_mode"}
        self._actions: np.ndarray | None = None

    def reset(self) -> np.ndarray:
        everyone = np.arange(self.num_envs)
        options = [opts if opts else None for opts in self._options]
        columns = self.vector_env.reset_envs(everyone, list(self._seeds), options)
        self.reset_infos = rows(columns, self.num_envs)
        # Seeds and options are used once, as in DummyVecEnv.
        self._reset_seeds()
        self._reset_options()
        return self.vector_env.observations  # a copy

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_async(actions) must come before step_wait()")
        n = self.num_envs
        actions, self._actions = self._actions, None
        # The vector env validates the actions where it receives them.
        batch, final = self.vector_env.step_envs(np.arange(n), actions)
        terminated, truncated = batch.terminated, batch.truncated
        dones = terminated | truncated
        infos = rows(batch.info_columns(), n)
        # what DummyVecEnv adds: the truncation flag, the last observation at an episode's end
        for i, info in enumerate(infos):
            info["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        ended = np.flatnonzero(dones)
        for i in ended:
            infos[i]["terminal_observation"] = final[i].copy()
        if ended.size:
            columns = self.vector_env.autoreset(ended)  # frames still show the strokes flown
            for i, info in zip(ended, rows(columns, ended.size), strict=True):
                self.reset_infos[i] = info
        return self.vector_env.observations, batch.reward.astype(np.float32), dones, infos

    def close(self) -> None:
        self.vector_env.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        if self.render_mode != "rgb_array":
            return [None] * self.num_envs
        return list(self.vector_env.render())  # type: ignore[arg-type]  # a frame per sub-env

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        value = getattr(self.vector_env, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        setattr(self.vector_env, attr_name, value)

    def env_method(
        self,
        method_name: str,
        *method_args: Any,
        indices: VecEnvIndices = None,
        **method_kwargs: Any,
    ) -> list[Any]:
        result = getattr(self.vector_env, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._get_indices(indices)]

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None
    ) -> list[bool]:
        # No sub-env is a wrapped gym.Env (wrap the whole VecEnv, e.g. VecMonitor, instead).
        return [False for _ in self._get_indices(indices)]


def make_sb3_vec_env(
    env_id: str, n_envs: int = 1, seed: int | None = None, *, monitor: bool = False, **kwargs: Any
) -> VecEnv:
    """An SB3 ``VecEnv`` of ``n_envs`` envs of ``env_id`` (seeded as SB3's ``make_vec_env``
    seeds them), stepped by one model call; ``monitor=True`` wraps it in ``VecMonitor``."""
    check_env_id(env_id)
    mode = "vector_entry_point"
    vector_env = gym.make_vec(env_id, num_envs=n_envs, vectorization_mode=mode, **kwargs)
    venv = TandemVecEnv(vector_env)
    venv.seed(seed)
    if seed is not None:
        venv.action_space.seed(seed)
    return VecMonitor(venv) if monitor else venv
