"""The vector envs a run trains and evaluates on. Training (bottom up): the batched SB3 adapter
(one model call per step) -> :class:`StrokeRecorder` (raw rewards: the best stroke seen, the
evaluation count) -> ``VecMonitor`` (episode CSV with the physical metrics) -> ``VecNormalize``
if the hyperparameters ask for it. Evaluation: the adapter, one sub-env per evaluation condition
-> :class:`ConditionGrid` (``best_model.zip`` is chosen on a fixed, not a resampled, set) ->
``VecMonitor`` -> ``VecNormalize(training=False, norm_reward=False)``, on which
:func:`evaluate_deterministic` plays a model's deterministic policy.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper, VecMonitor, VecNormalize
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

from agents.selection import BestStroke
from tandem_env.envs.registration import config_class
from tandem_env.envs.sb3 import TandemVecEnv, make_sb3_vec_env

#: The ``info`` entries of an evaluated stroke that both the Monitor CSV and the logs keep.
STROKE_METRICS = ("objective", "efficiency", "lift_to_weight", "power_per_mass", "feasible")
#: ``info`` entries written to the Monitor CSV next to each episode's reward and length.
MONITOR_KEYWORDS: tuple[str, ...] = (*STROKE_METRICS, "speed", "available_power")


class StrokeRecorder(VecEnvWrapper):
    """Keeps the best stroke any sub-env was given by the harness's selection rule
    (:mod:`agents.selection`: feasible first, then the higher raw reward, the earlier on ties)
    and counts evaluations. On the adapter itself, it sees the exact actions evaluated (after
    SB3's clipping or rescaling) and the env's own rewards (before any normalisation)."""

    def __init__(self, venv: VecEnv, on_step: Callable[[StrokeRecorder], None] | None = None):
        super().__init__(venv)
        # VecMonitor writes the env id into the Monitor header when the stack has a spec.
        self.spec = getattr(getattr(venv, "vector_env", None), "spec", None)
        self.evaluations = 0
        self.steps = 0
        self.best_reward = -np.inf
        self.best_action: np.ndarray | None = None
        self.best_info: dict[str, Any] | None = None
        self.max_reward = -np.inf
        self.history: list[tuple[int, float]] = []
        """(evaluations, best reward so far, feasible or not) per vector step: never decreasing."""
        self._best = BestStroke()
        self._actions: np.ndarray | None = None
        self._on_step = on_step

    def reset(self) -> np.ndarray:
        return self.venv.reset()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.array(actions, copy=True)
        self.venv.step_async(actions)

    def step_wait(self) -> VecEnvStepReturn:
        observations, rewards, dones, infos = self.venv.step_wait()
        # float64 rewards: a record compares the stroke's reward with its re-evaluation, which
        # is objective - penalty exactly as the task computes it (SB3 gets float32)
        exact = np.asarray(rewards, dtype=np.float64)
        if infos and all("objective" in info and "penalty" in info for info in infos):
            exact = np.array([i["objective"] - i["penalty"] for i in infos], dtype=np.float64)
        feasible = np.array([bool(info.get("feasible", True)) for info in infos], dtype=bool)
        i = None if self._actions is None else self._best.offer(feasible, exact)
        if i is not None:
            self.best_reward = self._best.reward
            self.best_action = self._actions[i].copy()
            self.best_info = {k: v for k, v in infos[i].items() if k != "terminal_observation"}
        clean = np.where(np.isnan(exact), -np.inf, exact)
        self.max_reward = max(self.max_reward, float(clean.max()))
        self.evaluations += len(rewards)
        self.steps += 1
        self.history.append((self.evaluations, self.max_reward))
        if self._on_step is not None:
            self._on_step(self)
        return observations, rewards, dones, infos


class ConditionGrid(VecEnvWrapper):
    """Resets sub-env i of the batched adapter ``venv`` at ``conditions[i]`` at every reset
    (through the env's reset option, e.g. ``speed``)."""

    def __init__(self, venv: TandemVecEnv, conditions: Sequence[float]) -> None:
        super().__init__(venv)
        self.option_key = venv.vector_env.core.option_key
        self.conditions = tuple(float(c) for c in conditions)

    def reset(self) -> np.ndarray:
        self.venv.set_options([{self.option_key: c} for c in self.conditions])
        return self.venv.reset()

    def step_wait(self) -> VecEnvStepReturn:
        return self.venv.step_wait()


def make_training_env(
    env_id: str,
    n_envs: int,
    seed: int,
    env_kwargs: Mapping[str, Any],
    *,
    monitor_file: Path | None = None,
    normalize: Mapping[str, Any] | None = None,
    on_step: Callable[[StrokeRecorder], None] | None = None,
) -> tuple[VecEnv, StrokeRecorder]:
    """The training stack (module docstring; None: no Monitor file or VecNormalize), its recorder."""
    recorder = StrokeRecorder(
        make_sb3_vec_env(env_id, n_envs=n_envs, seed=seed, **env_kwargs), on_step
    )
    filename = None if monitor_file is None else str(monitor_file)
    venv: VecEnv = VecMonitor(recorder, filename=filename, info_keywords=MONITOR_KEYWORDS)
    if normalize is not None:
        venv = VecNormalize(venv, **normalize)
    return venv, recorder


def make_evaluation_env(
    env_id: str,
    env_kwargs: Mapping[str, Any],
    seed: int,
    *,
    normalize: Mapping[str, Any] | None,
) -> VecEnv:
    """The evaluation stack at the fixed condition, or the declared sweep's points in the
    sampled range (its ends and midpoint where it holds fewer than two)."""
    config = config_class(env_id).from_kwargs(**env_kwargs)
    if config.condition_range is None:
        conditions: tuple[float, ...] = (float(config.fixed_condition),)
    else:
        low, high = config.condition_range
        declared = type(config).CONDITION
        sweep = () if declared is None else declared.sweep
        inside = tuple(c for c in sweep if low - 1e-9 <= c <= high + 1e-9)
        conditions = inside if len(inside) >= 2 else (low, 0.5 * (low + high), high)
    base = make_sb3_vec_env(env_id, n_envs=len(conditions), seed=seed, **env_kwargs)
    venv: VecEnv = VecMonitor(ConditionGrid(base, conditions))
    if normalize is not None:
        venv = VecNormalize(venv, **{**normalize, "training": False, "norm_reward": False})
    return venv


def evaluate_deterministic(
    model: BaseAlgorithm, eval_env: VecEnv, max_steps: int = 100_000
) -> list[dict[str, Any]]:
    """The deterministic policy from one reset of each evaluation env to the end of its episode:
    one row per env, the info of its last step with ``reward`` (the return),
    ``episode_length`` and ``action`` (its first)."""
    observations = eval_env.reset()
    returns = np.zeros(eval_env.num_envs)
    lengths = np.zeros(eval_env.num_envs, dtype=np.int64)
    first_actions: Any = None
    rows: list[dict[str, Any] | None] = [None] * eval_env.num_envs
    dropped = ("terminal_observation", "episode", "stroke", "TimeLimit.truncated")
    for _ in range(max_steps):
        actions, _ = model.predict(observations, deterministic=True)
        first_actions = actions if first_actions is None else first_actions
        observations, rewards, dones, infos = eval_env.step(actions)
        # an env whose episode is over keeps its row: later steps belong to the next one
        playing = np.array([row is None for row in rows])
        returns[playing] += np.asarray(rewards, dtype=np.float64)[playing]
        lengths[playing] += 1
        for k in np.flatnonzero(playing & np.asarray(dones, dtype=bool)):
            rows[k] = {key: v for key, v in infos[k].items() if key not in dropped}
            rows[k].update(  # type: ignore[union-attr]
                reward=float(returns[k]),
                episode_length=int(lengths[k]),
                action=[float(a) for a in first_actions[k]],
            )
        if all(row is not None for row in rows):
            return rows  # type: ignore[return-value]
    raise RuntimeError(f"the evaluation episodes did not end within {max_steps} steps")
