"""One training run (:func:`train`, what ``python -m train`` calls): the envs and the model of a
:class:`~train.config.TrainConfig`, learning with evaluations, checkpoints, Monitor and
TensorBoard logs, and the resume of a killed run; :func:`learn_in_memory` is the lean variant of
the harness's ``ppo`` / ``sac`` (no files, a budget of env steps). Callbacks: physical metrics
to TensorBoard (:class:`PhysicsLogger`: SB3's logger only knows rewards), an EvalCallback that
resumes, checkpoints and Ctrl-C (:class:`RunCheckpoint`).
"""

from __future__ import annotations

import contextlib
import math
import signal
import threading
import time
import warnings
import zipfile
from collections.abc import Callable, Iterator, Mapping
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
from stable_baselines3.common.vec_env import sync_envs_normalization

from agents.selection import best_index
from tandem_env.io.files import write_json_atomic
from train.config import Hyperparams, TrainConfig, resolve_hyperparams, step_granularity
from train.run_folder import Checkpoint, Interrupted, RunFolder, RunLayout
from train.saved import build_model, read_normalizer, save_checkpoint
from train.vec import (
    STROKE_METRICS,
    StrokeRecorder,
    evaluate_deterministic,
    make_evaluation_env,
    make_training_env,
)

#: Checkpoints kept in a run folder (older ones are deleted: a SAC replay buffer is ~40 MB).
KEEP_CHECKPOINTS = 2
#: Env steps between SAC's log dumps when no log_interval is given.
SAC_LOG_EVERY = 2_048


@dataclass(frozen=True)
class TrainResult:
    """What a run ended with."""

    algo: str
    env_id: str
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
    hp: Hyperparams | None = None
    """The hyperparameters it trained with (``config.yml``)."""


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


class ResumableEvalCallback(EvalCallback):
    """``EvalCallback`` that, on a resumed run, starts from ``evaluations.npz``'s rows up to the
    checkpoint and their best mean reward (SB3's rewrites the file from memory)."""

    def __init__(self, *args: Any, resume_from_step: int | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._resume_from_step = resume_from_step

    def _init_callback(self) -> None:
        super()._init_callback()
        if self._resume_from_step is None or self.log_path is None:
            return
        path = Path(self.log_path if self.log_path.endswith(".npz") else f"{self.log_path}.npz")
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
            self.best_mean_reward = float(np.max(np.mean(results, axis=1)))
        keep = steps <= self._resume_from_step
        self.evaluations_timesteps = [int(s) for s in steps[keep]]
        self.evaluations_results = [list(map(float, r)) for r in results[keep]]
        self.evaluations_length = [list(map(int, n)) for n in lengths[keep]]
        if successes is not None and len(successes) == len(steps):
            self.evaluations_successes = [list(map(bool, s)) for s in successes[keep]]


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
            normalizer = read_normalizer(checkpoint.vecnormalize)
            normalizer.set_venv(venv)
            venv, normalizer.training = normalizer, True
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
            hooks.append(
                ResumableEvalCallback(
                    eval_env,
                    n_eval_episodes=eval_env.num_envs,
                    eval_freq=max(config.eval_freq // hp.n_envs, 1),
                    best_model_save_path=str(layout.run_dir),
                    log_path=str(layout.run_dir),
                    deterministic=True,
                    verbose=config.verbose,
                    callback_on_new_best=None
                    if hp.normalize is None
                    else ConvertCallback(save_best_statistics),
                    resume_from_step=None if checkpoint is None else start_step,
                )
            )
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
            resume = f"python -m train --algo {config.algo} --env {config.env_id} --run-dir"
            raise Interrupted(saved, f"{resume} {layout.run_dir}")
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
            algo=config.algo,
            env_id=config.env_id,
            run_dir=layout.run_dir,
            num_timesteps=steps,
            wall_time=wall_time,
            resumed_from=resumed_from,
            **seen,
            final_evaluation=evaluate_deterministic(model, eval_env),
            history=tuple(recorder.history),
            hp=hp,
        )
        segment = {"resumed_from": resumed_from, "end_step": steps, "wall_time_s": wall_time}
        segments = [*run.segments, {**segment, **seen}]
        # the segment whose best stroke wins by the selection rule (agents.selection); a segment
        # without one (reward None) ranks last
        feasible = [bool((s.get("best_info") or {}).get("feasible", False)) for s in segments]
        rewards = [-math.inf if s["best_reward"] is None else s["best_reward"] for s in segments]
        best = segments[best_index(feasible, rewards)]
        data = {
            "algo": result.algo,
            "env_id": result.env_id,
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
