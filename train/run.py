"""One training run (:func:`train`, what ``python -m train`` calls): the envs and the model of a
:class:`~train.config.TrainConfig`, learning with evaluations, checkpoints, Monitor and
TensorBoard logs, and the resume of a killed run; :func:`learn_in_memory` is the lean variant of
the harness's ``ppo`` / ``sac`` (no files, a budget of env steps). Callbacks: physical metrics
to TensorBoard (:class:`PhysicsLogger`: SB3's logger only knows rewards), SB3's
EvalCallback resumed (:func:`resume_evaluations`), checkpoints and Ctrl-C (:class:`RunCheckpoint`).

The env stacks. Training (bottom up): the batched SB3 adapter (one model call per step) ->
:class:`StrokeRecorder` (raw rewards: the best stroke seen, the evaluation count) ->
``VecMonitor`` (episode CSV with the physical metrics) -> ``VecNormalize`` if the
hyperparameters ask for it. Evaluation: the adapter, one sub-env per evaluation condition ->
:class:`ConditionGrid` (``best_model.zip`` is chosen on a fixed, not a resampled, set) ->
``VecMonitor`` -> ``VecNormalize(training=False, norm_reward=False)``, on which
:func:`evaluate_deterministic` plays a model's deterministic policy.
"""

from __future__ import annotations

import contextlib
import math
import signal
import threading
import time
import warnings
import zipfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import (
    BaseCallback,
    CallbackList,
    ConvertCallback,
    EvalCallback,
)
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize, sync_envs_normalization
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvStepReturn, VecEnvWrapper

from agents.selection import BestStroke, best_index
from tandem_env.envs.registration import config_class
from tandem_env.envs.sb3 import TandemVecEnv, make_sb3_vec_env
from tandem_env.io.files import write_json_atomic
from train.config import Hyperparams, TrainConfig, resolve_hyperparams, step_granularity
from train.run_folder import Checkpoint, Interrupted, RunFolder, RunLayout
from train.saved import build_model, read_normalizer, save_checkpoint

#: Checkpoints kept in a run folder (older ones are deleted: a SAC replay buffer is ~40 MB).
KEEP_CHECKPOINTS = 2
#: Env steps between SAC's log dumps when no log_interval is given.
SAC_LOG_EVERY = 2_048


@dataclass(frozen=True)
class TrainResult:
    """What a run ended with."""

    num_timesteps: int
    best_reward: float
    """Best raw reward of any stroke the training env evaluated in this segment."""
    best_action: np.ndarray | None
    best_info: dict[str, Any] | None
    run_dir: Path | None = None
    wall_time: float = 0.0
    """Wall-clock time of this training segment [s]."""
    resumed_from: int | None = None
    """Checkpoint step this segment resumed from, or None for a fresh run."""
    final_evaluation: list[dict[str, Any]] = field(default_factory=list)
    """The final policy's deterministic stroke at each evaluation condition (metrics)."""
    history: tuple[tuple[int, float], ...] = ()
    """(env steps of this segment, best reward so far) after every vector step."""


# --- the env stacks ------------------------------------------------------------------------------
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
        self.best_feasible = False
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
            self.best_feasible = self._best.feasible
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
    env_id: str, env_kwargs: Mapping[str, Any], seed: int, *, normalize: Mapping[str, Any] | None
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
            rows[k] = {
                **{key: v for key, v in infos[k].items() if key not in dropped},
                "reward": float(returns[k]),
                "episode_length": int(lengths[k]),
                "action": [float(a) for a in first_actions[k]],
            }
        if all(row is not None for row in rows):
            return rows  # type: ignore[return-value]
    raise RuntimeError(f"the evaluation episodes did not end within {max_steps} steps")


# --- building blocks -----------------------------------------------------------------------
@contextlib.contextmanager
def torch_threads(count: int) -> Iterator[None]:
    """Run with ``count`` torch threads, restoring the previous number afterwards."""
    previous = torch.get_num_threads()
    torch.set_num_threads(count)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


def default_log_interval(hp: Hyperparams) -> int:
    """PPO: every rollout. SAC counts episodes, and every vector step ends n_envs of them, so
    its default (4) would dump n_envs/4 times per step; dump every ~SAC_LOG_EVERY steps instead."""
    return 1 if hp.algo == "ppo" else hp.n_envs * max(1, round(SAC_LOG_EVERY / hp.n_envs))


# --- callbacks -----------------------------------------------------------------------------
#: ``info`` entries averaged over each vector step into ``physics/<name>``.
LOGGED_METRICS: tuple[str, ...] = (*STROKE_METRICS, "constraint_violation", "score")


class PhysicsLogger(BaseCallback):
    """Logs as ``physics/*`` scalars the means over each vector step's ``info`` dicts of the
    model's metrics of each evaluated stroke and its normalised score against the reference
    optimum (docs/reference.md), and the best stroke seen so far."""

    def __init__(self, recorder: StrokeRecorder, verbose: int = 0) -> None:
        super().__init__(verbose)
        self.recorder = recorder

    def _on_step(self) -> bool:
        infos = self.locals.get("infos") or ()
        for name in LOGGED_METRICS:
            # NaN: a metric the step does not define (the score where no reference applies)
            values = [info[name] for info in infos if name in info and info[name] == info[name]]
            if values:
                self.logger.record_mean(f"physics/{name}", float(np.mean(values)))
        best = self.recorder.best_info
        if best is not None:
            self.logger.record("physics/best_reward", self.recorder.max_reward)
            for name in ("feasible", "objective", "score"):
                value = float(best.get(name, np.nan))
                if name != "score" or not np.isnan(value):  # NaN: no reference score
                    self.logger.record(f"physics/best_{name}", value)
        self.logger.record("physics/evaluations", self.recorder.evaluations)
        return True


def resume_evaluations(callback: EvalCallback, path: Path, step: int) -> None:
    """Start a resumed run's ``callback`` (SB3's rewrites ``evaluations.npz``, ``path``, from
    memory) from the file's rows up to the checkpoint's ``step`` and their best mean reward."""
    if not path.is_file():
        return
    try:
        with np.load(path, allow_pickle=False) as data:
            steps, results, lengths = (data[k] for k in ("timesteps", "results", "ep_lengths"))
            successes = data["successes"] if "successes" in data.files else None
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as error:
        warnings.warn(
            f"{path} cannot be read ({type(error).__name__}: {error}); the evaluation "
            "history starts again from this segment",
            RuntimeWarning,
            stacklevel=2,
        )
        return
    if len(steps):
        callback.best_mean_reward = float(np.max(np.mean(results, axis=1)))
    keep = steps <= step
    callback.evaluations_timesteps = [int(s) for s in steps[keep]]
    callback.evaluations_results = [list(map(float, r)) for r in results[keep]]
    callback.evaluations_length = [list(map(int, n)) for n in lengths[keep]]
    if successes is not None and len(successes) == len(steps):
        callback.evaluations_successes = [list(map(bool, s)) for s in successes[keep]]


class RunCheckpoint(BaseCallback):
    """Checkpoints every ``save_freq`` env steps (<= 0: none), keeping the newest ``keep``, at a
    rollout's end (named as SB3's CheckpointCallback names them; that one saves inside
    ``on_step``, before SAC stores the step's transitions, which a resume would miss). Ctrl-C
    (SIGINT) while :meth:`catching` stops ``learn`` at the next env step, for :meth:`save` to
    checkpoint the last rollout's end (:attr:`boundary`: the unfinished rollout is collected
    again on resume); a second Ctrl-C raises KeyboardInterrupt at once."""

    def __init__(self, layout: RunLayout, save_freq: int, keep: int, verbose: int = 0) -> None:
        super().__init__(verbose)
        self.layout, self.save_freq, self.keep = layout, save_freq, keep
        self.requested = False
        self.boundary = 0

    def _init_callback(self) -> None:
        self.boundary = self.model.num_timesteps

    def _on_step(self) -> bool:
        return not self.requested

    def _on_rollout_end(self) -> None:
        previous, self.boundary = self.boundary, self.model.num_timesteps
        # a multiple of save_freq passed in this rollout
        if self.save_freq > 0 and self.boundary // self.save_freq > previous // self.save_freq:
            checkpoint = self.save()
            if self.verbose >= 2:
                print(f"Saved checkpoint {checkpoint.model}")

    def _request(self, *_: object) -> None:  # a signal handler's (signum, frame)
        self.requested = True
        signal.signal(signal.SIGINT, signal.default_int_handler)

    @contextlib.contextmanager
    def catching(self) -> Iterator[None]:
        """Catch SIGINT within the block (in the main thread, unless SIGINT is ignored: a
        background job's), restoring the previous handler afterwards."""
        previous = signal.getsignal(signal.SIGINT)
        if threading.current_thread() is not threading.main_thread() or previous == signal.SIG_IGN:
            yield
            return
        signal.signal(signal.SIGINT, self._request)
        try:
            yield
        finally:
            signal.signal(signal.SIGINT, previous)

    def save(self) -> Checkpoint:
        """The checkpoint of the last whole iteration, the ``keep`` newest kept."""
        self.model.num_timesteps = self.boundary
        return save_checkpoint(self.model, self.layout, self.keep)


# --- the run ---------------------------------------------------------------------------------
def train(config: TrainConfig) -> TrainResult:
    """Run (or resume) one training run with files (:class:`~train.run_folder.RunFolder`): the
    envs, the model, learning, then the final model, its evaluation and ``result.json`` (the
    previous segments and this run's)."""
    with contextlib.ExitStack() as held:
        # the plan: which folder, from which checkpoint, with which settings
        run = RunFolder.open(config, held)
        config, hp, layout, checkpoint = run.config, run.hp, run.layout, run.checkpoint
        assert hp is not None
        run.start(hp.saved)
        held.enter_context(torch_threads(config.torch_threads))
        # the envs: training (its Monitor file, normalisation resumed or new), evaluation
        venv, recorder = make_training_env(
            config.env_id,
            hp.n_envs,
            config.seed,
            run.env_kwargs,
            monitor_file=layout.next_monitor_file(),
            normalize=hp.normalize if checkpoint is None else None,
        )
        if hp.normalize is not None and checkpoint is not None:
            venv = read_normalizer(checkpoint.vecnormalize, venv, training=True)
        eval_env = make_evaluation_env(
            config.env_id, run.env_kwargs, config.seed + 10_000, normalize=hp.normalize
        )
        held.callback(eval_env.close)
        held.callback(venv.close)
        # the model: new, or the checkpoint's (with SAC's replay buffer)
        model = run.model(venv)
        start_step = model.num_timesteps
        # learning, with physics logs, checkpoints and evaluations; Ctrl-C saves a checkpoint
        checkpoints = RunCheckpoint(layout, config.save_freq, KEEP_CHECKPOINTS, config.verbose)

        def save_best_statistics(*_: Any) -> bool:
            """On a new best model, the training VecNormalize statistics: ``best_model.zip``
            is loaded with those it was evaluated with."""
            model.get_vec_normalize_env().save(str(layout.best_vecnormalize))
            return True

        hooks: list[BaseCallback] = [PhysicsLogger(recorder), checkpoints]
        if config.eval_freq > 0:
            evaluation = EvalCallback(
                eval_env,
                n_eval_episodes=eval_env.num_envs,
                eval_freq=max(config.eval_freq // hp.n_envs, 1),
                best_model_save_path=str(layout.run_dir),
                log_path=str(layout.run_dir),  # its evaluations.npz: layout.evaluations
                deterministic=True,
                verbose=config.verbose,
                callback_on_new_best=None
                if hp.normalize is None
                else ConvertCallback(save_best_statistics),
            )
            if checkpoint is not None:
                resume_evaluations(evaluation, layout.evaluations, start_step)
            hooks.append(evaluation)
        started = time.perf_counter()
        with checkpoints.catching():
            model.learn(
                run.target - start_step,
                callback=CallbackList(hooks),
                log_interval=config.log_interval or default_log_interval(hp),
                tb_log_name=config.algo.upper(),
                reset_num_timesteps=checkpoint is None,
                progress_bar=config.progress_bar,
            )
        wall_time = time.perf_counter() - started
        if checkpoints.requested:
            saved = checkpoints.save()
            raise Interrupted(
                f"interrupted: checkpoint at step {saved.step} saved as {saved.model}; continue "
                f"with: python -m train --algo {config.algo} --env {config.env_id} --run-dir "
                f"{layout.run_dir}"
            )
        # the final model (normalisation statistics, a last checkpoint) and its evaluation
        model.save(layout.final_model)
        if hp.normalize is not None:
            model.get_vec_normalize_env().save(str(layout.vecnormalize))  # type: ignore[union-attr]
            sync_envs_normalization(venv, eval_env)
        if config.save_freq > 0:
            save_checkpoint(model, layout, KEEP_CHECKPOINTS)
        resumed_from = None if checkpoint is None else checkpoint.step
        seen = {k: getattr(recorder, k) for k in ("best_reward", "best_action", "best_info")}
        steps = int(model.num_timesteps)
        result = TrainResult(
            run_dir=layout.run_dir,
            num_timesteps=steps,
            wall_time=wall_time,
            resumed_from=resumed_from,
            **seen,
            final_evaluation=evaluate_deterministic(model, eval_env),
            history=tuple(recorder.history),
        )
        segment = {"resumed_from": resumed_from, "end_step": steps, "wall_time_s": wall_time}
        segments = [*run.segments, {**segment, **seen}]
        # the segment whose best stroke wins by the selection rule (agents.selection); a segment
        # without one (reward None) ranks last
        feasible = [bool((s.get("best_info") or {}).get("feasible", False)) for s in segments]
        rewards = [-math.inf if s["best_reward"] is None else s["best_reward"] for s in segments]
        best = segments[best_index(feasible, rewards)]
        data = {
            "algo": config.algo,
            "env_id": config.env_id,
            "num_timesteps": steps,
            "n_envs": hp.n_envs,
            "wall_time_s": sum(float(s["wall_time_s"]) for s in segments),
            "best_seen": {k: best[k] for k in ("best_reward", "best_action", "best_info")},
            "final_evaluation": result.final_evaluation,
            "segments": segments,
        }
        write_json_atomic(layout.result_file, data, indent=1)
        return result


# --- the harness's lean variant ----------------------------------------------------------------
def budget_hyperparams(
    algo: str,
    entry: Mapping[str, Any],
    overrides: Mapping[str, Any] | None,
    n_envs: int | None,
    budget: int,
) -> Hyperparams:
    """The hyperparameters of a run within ``budget`` env steps: ``n_timesteps`` rounded down
    to whole learn iterations (SB3 never stops inside one; the budget is a hard limit)."""
    hp = resolve_hyperparams(entry, overrides, algo=algo, n_envs=n_envs, n_timesteps=1)
    unit = step_granularity(hp)
    steps = (budget // unit) * unit
    if steps < 1:
        raise ValueError(
            f"budget {budget} is below one {algo.upper()} iteration ({unit} env steps with "
            f"n_envs = {hp.n_envs}); allowed: a budget >= {unit}, or a smaller n_envs"
        )
    return resolve_hyperparams(entry, overrides, algo=algo, n_envs=n_envs, n_timesteps=steps)


def learn_in_memory(
    hp: Hyperparams,
    env_id: str,
    env_kwargs: Mapping[str, Any],
    seed: int,
    *,
    on_step: Callable[[StrokeRecorder], None] | None = None,
    threads: int = 1,
) -> tuple[BaseAlgorithm, StrokeRecorder]:
    """Train ``hp.algo`` for its ``n_timesteps`` env steps (a budget's, :func:`budget_hyperparams`),
    no files; returns (model, recorder)."""
    env_kwargs = {**hp.env_kwargs, **env_kwargs}
    with torch_threads(threads):
        venv, recorder = make_training_env(
            env_id, hp.n_envs, seed, env_kwargs, normalize=hp.normalize, on_step=on_step
        )
        model = build_model(hp.algo, hp, venv, seed=seed)
        model.learn(hp.n_timesteps, log_interval=default_log_interval(hp), progress_bar=False)
    if recorder.evaluations > hp.n_timesteps:  # whole iterations: cannot happen; never record it
        raise RuntimeError(f"{hp.algo} used {recorder.evaluations} env steps > {hp.n_timesteps}")
    return model, recorder
