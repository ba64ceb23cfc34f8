"""One training run: build the envs and the model from a :class:`~train.config.TrainConfig`,
learn with evaluation, checkpoints, Monitor and TensorBoard logs, and resume a killed run.

:func:`train` is what ``python -m train`` calls; :func:`learn_in_memory` is the lean variant
the harness's ``ppo`` / ``sac`` methods use (no files, a budget of env steps).
"""

from __future__ import annotations

import contextlib
import math
import os
import time
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.vec_env import VecEnv, VecNormalize, sync_envs_normalization

from agents.selection import best_index
from tandem_env.envs.registration import check_env_id
from tandem_env.io.files import write_json_atomic
from train.callbacks import PhysicsLogger, ResumableEvalCallback, SaveVecNormalize
from train.checkpoint import (
    RunCheckpoint,
    StopOnInterrupt,
    build_model,
    load_checkpoint,
    load_on_copy,
    prune_checkpoints,
    save_checkpoint,
)
from train.config import (
    Hyperparams,
    TrainConfig,
    load_entry,
    plain,
    resolve_hyperparams,
    write_yaml,
)
from train.layout import (
    Checkpoint,
    Interrupted,
    RunComplete,
    RunLayout,
    read_normalizer,
    read_result_segments,
    read_run_yaml,
    run_lock,
)
from train.vec import (
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
    run_dir: Path | None
    num_timesteps: int
    wall_time: float
    """Wall-clock time of this training segment [s]."""
    resumed_from: int | None
    """Checkpoint step this segment resumed from, or None for a fresh run."""
    best_reward: float
    """Best raw reward of any stroke the training env evaluated in this segment."""
    best_action: np.ndarray | None
    best_info: dict[str, Any] | None
    final_evaluation: list[dict[str, Any]] = field(default_factory=list)
    """The final policy's deterministic stroke at each evaluation condition (metrics)."""
    history: tuple[tuple[int, float], ...] = ()
    """(env steps of this segment, best reward so far) after every vector step."""


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


def step_granularity(algo: str, hp: Hyperparams) -> int:
    """Env steps one learn iteration takes (``learn`` never stops inside one)."""
    if algo == "ppo":
        return int(hp.model_kwargs.get("n_steps", 2048)) * hp.n_envs
    train_freq = hp.model_kwargs.get("train_freq", 1)
    # Every episode is one step, so "episode" frequencies count the same vector steps.
    steps = train_freq[0] if isinstance(train_freq, tuple) else train_freq
    return int(steps) * hp.n_envs


def default_log_interval(algo: str, n_envs: int) -> int:
    """PPO: every rollout. SAC counts episodes, and every vector step ends n_envs of them, so
    its default (4) would dump n_envs/4 times per step; dump every ~SAC_LOG_EVERY steps instead."""
    if algo == "ppo":
        return 1
    return n_envs * max(1, round(SAC_LOG_EVERY / n_envs))


# --- the run ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class TrainPlan:
    config: TrainConfig
    hp: Hyperparams
    env_kwargs: dict[str, Any]
    layout: RunLayout
    checkpoint: Checkpoint | None
    target: int
    """Env steps the run ends at: n_timesteps rounded up to whole learn iterations."""
    unit: int
    """Env steps of one learn iteration (see :func:`step_granularity`)."""
    segments: tuple[Mapping[str, Any], ...] = ()
    """The earlier runs' segments of the folder's ``result.json``, which a resume extends."""


def whole_iterations(n_timesteps: int, unit: int) -> int:
    """``n_timesteps`` rounded up to a multiple of ``unit``: where SB3's ``learn`` stops (it
    never stops inside an iteration), so progress bars and targets say what will happen."""
    return -(-n_timesteps // unit) * unit


def plan_run(config: TrainConfig, held: contextlib.ExitStack) -> TrainPlan:
    """Where the run goes and what it resumes from; validates everything before any work.

    The run folder is locked (:func:`~train.layout.run_lock`) before its files are read, so a
    second command on the same run is refused instead of training beside the first; ``held``
    holds the lock, to the end of the run (:func:`train`), or releases it if the plan fails."""
    if config.resume:
        layout = RunLayout.latest(config.log_folder, config.algo, config.env_id)
    elif config.run_dir is not None:
        layout = RunLayout(config.run_dir, config.env_id)
        reason = layout.foreign()
        if reason is not None:
            raise ValueError(
                f"--run-dir: {reason}; it is left untouched. Allowed: a run folder of "
                "python -m train (to continue it), or an absent or empty folder (a new run)"
            )
    else:
        layout = None
    # A folder that is not ours was refused above, before the lock file is made in it.
    locked = False
    if layout is not None and layout.run_dir.is_dir():
        held.enter_context(run_lock(layout.run_dir))
        locked = True
    resume = config.resume  # the merge below turns a resume into a run of a given folder
    checkpoint = None
    entry = None  # config.yml: the hyperparameters the run started with
    if layout is not None:
        if layout.args_file.is_file():
            config = _merge_saved(config, read_run_yaml(layout.args_file), layout)
        if layout.config_file.is_file():
            entry = read_run_yaml(layout.config_file)
        normalize = entry is not None and bool(entry.get("normalize"))
        checkpoint = _latest_usable_checkpoint(config, layout, normalize)
        damaged = [c.model.name for c in layout.checkpoints()]
        if checkpoint is None and damaged:
            raise ValueError(
                f"{layout.run_dir}: no checkpoint is intact ({', '.join(damaged)}: see the "
                "warnings above); it is left untouched. Allowed: move the damaged checkpoints "
                "away to start this run again from step 0, or a new run"
            )
        if checkpoint is None and resume:
            raise ValueError(
                f"{layout.run_dir} has no complete checkpoint to resume from (save_freq <= 0, "
                "or killed before the first); allowed: start a new run"
            )

    if checkpoint is not None and layout is not None:
        if entry is None:
            # Resuming from the current yml instead would mix two runs' hyperparameters unsaid.
            raise ValueError(
                f"{layout.config_file} is missing: the hyperparameters the run started with "
                "cannot be restored; allowed: a run folder with its config.yml (or a new run)"
            )
        # A resumed run keeps the hyperparameters it started with, whatever the yml says now.
        try:
            hp = resolve_hyperparams(entry, n_timesteps=config.n_timesteps)
        except ValueError as error:
            raise ValueError(f"{layout.config_file}: {error}") from None
    else:
        hp = config.hyperparameters()
    unit = step_granularity(config.algo, hp)
    target = whole_iterations(hp.n_timesteps, unit)
    if checkpoint is not None and checkpoint.step >= target:
        raise RunComplete(layout.run_dir, checkpoint.step, target)  # type: ignore[union-attr]
    if checkpoint is None and layout is not None:
        finished = [p.name for p in (layout.final_model, layout.result_file) if p.is_file()]
        if finished:
            raise ValueError(
                f"{layout.run_dir} holds a finished run ({', '.join(finished)}) and no "
                "checkpoint to continue from (it ran with save_freq <= 0); a new run there "
                "would overwrite it, so it is left untouched. Allowed: a new run (no --run-dir) "
                "or another folder"
            )
    env_kwargs = {**hp.env_kwargs, **config.env_kwargs}
    _check_env(config.env_id, env_kwargs)
    segments: tuple[Mapping[str, Any], ...] = ()
    if checkpoint is not None:  # the files a resume loads, read as it will read them
        checked = load_on_copy(config.algo, checkpoint, hp, config.env_id, env_kwargs)
        checked.get_env().close()  # type: ignore[union-attr]
        if hp.normalize is not None:
            read_normalizer(checkpoint.vecnormalize)
        segments = read_result_segments(layout.result_file)  # type: ignore[union-attr]
    if layout is None:
        layout = RunLayout.new(config.log_folder, config.algo, config.env_id)
    layout.run_dir.mkdir(parents=True, exist_ok=True)
    if not locked:  # a new folder (this process made it, or --run-dir of an absent one)
        held.enter_context(run_lock(layout.run_dir))
    _check_writable(layout)
    return TrainPlan(config, hp, env_kwargs, layout, checkpoint, target, unit, segments)


def _check_writable(layout: RunLayout) -> None:
    """A run folder (and its params folder) must be writable before any training is spent."""
    for folder in (layout.run_dir, layout.params_dir):
        if folder.is_dir() and not os.access(folder, os.W_OK | os.X_OK):
            raise ValueError(
                f"{folder} is not writable; a run writes its checkpoints, models and settings "
                "there. Allowed: a folder you can write (chmod u+w), or a new run"
            )


def _merge_saved(config: TrainConfig, saved: Mapping[str, Any], layout: RunLayout) -> TrainConfig:
    """The config of a run being continued: its saved settings, this command's target steps."""
    for key, mine in (("algo", config.algo), ("env", config.env_id)):
        if saved.get(key) != mine:
            raise ValueError(
                f"{layout.run_dir} is a run of {key} = {saved.get(key)!r}, not {mine!r}; "
                "allowed: the same algo and env, or a new run"
            )
    for key, mine in (("env_kwargs", config.env_kwargs), ("hyperparams", config.hyperparams)):
        if mine and plain(dict(mine)) != saved.get(key):
            raise ValueError(
                f"{layout.run_dir} was started with {key} = {saved.get(key)!r}; this command "
                f"gives {plain(dict(mine))!r}. A resumed run keeps its settings; allowed: the "
                "same values or none, or a new run"
            )
    return replace(
        config,
        seed=int(saved.get("seed", config.seed)),
        n_envs=saved.get("n_envs"),
        n_timesteps=config.n_timesteps or saved.get("n_timesteps"),
        env_kwargs=saved.get("env_kwargs") or {},
        hyperparams=saved.get("hyperparams") or {},
        hyperparams_file=saved.get("conf_file"),
        eval_freq=int(saved.get("eval_freq", config.eval_freq)),
        save_freq=int(saved.get("save_freq", config.save_freq)),
        resume=False,
        run_dir=layout.run_dir,
    )


def _latest_usable_checkpoint(
    config: TrainConfig, layout: RunLayout, normalize: bool
) -> Checkpoint | None:
    """The newest intact checkpoint (``normalize``: the run saves VecNormalize statistics)."""
    for checkpoint in reversed(layout.checkpoints()):
        problem = checkpoint.damage(replay_buffer=config.algo == "sac", vecnormalize=normalize)
        if problem is None:
            return checkpoint
        warnings.warn(
            f"skipping checkpoint {checkpoint.model.name} of {layout.run_dir}: {problem} "
            "(killed while saving?); an earlier intact checkpoint is used if there is one",
            RuntimeWarning,
            stacklevel=3,
        )
    return None


def _check_env(env_id: str, env_kwargs: Mapping[str, Any]) -> None:
    import gymnasium as gym

    import tandem_env  # noqa: F401 - registers the ids

    check_env_id(env_id, "env")
    try:
        gym.make(env_id, disable_env_checker=True, **env_kwargs).close()
    except TypeError as error:
        raise ValueError(f"{env_id}: {error}") from error


def train(config: TrainConfig) -> TrainResult:
    """Run (or resume) one training run with files; see :mod:`train.layout` for the folder."""
    with contextlib.ExitStack() as held:
        return _train_planned(plan_run(config, held))


def _train_planned(plan: TrainPlan) -> TrainResult:
    config, hp, layout = plan.config, plan.hp, plan.layout
    if config.verbose:
        _say_plan(plan)
    if plan.checkpoint is None:
        write_yaml(layout.config_file, hp.saved)
        write_yaml(layout.args_file, config.to_dict())
        if layout.evaluations.exists():
            layout.evaluations.unlink()  # a fresh start in an old folder: no stale curve

    with torch_threads(config.torch_threads):
        venv, recorder, eval_env = _run_envs(plan)
        model = _run_model(plan, venv)
        start_step = model.num_timesteps
        stop = StopOnInterrupt()
        callbacks = CallbackList([*_run_callbacks(plan, recorder, eval_env, start_step), stop])
        started = time.perf_counter()
        with stop.catching():
            model.learn(
                plan.target - start_step,
                callback=callbacks,
                log_interval=config.log_interval or default_log_interval(config.algo, hp.n_envs),
                tb_log_name=config.algo.upper(),
                reset_num_timesteps=plan.checkpoint is None,
                progress_bar=config.progress_bar,
            )
        wall_time = time.perf_counter() - started
        if stop.requested:
            checkpoint = stop.save(layout, KEEP_CHECKPOINTS)
            venv.close()
            eval_env.close()
            resume = f"python -m train --algo {config.algo} --env {config.env_id} --run-dir"
            raise Interrupted(checkpoint, f"{resume} {layout.run_dir}")
        final = _save_and_evaluate(plan, model, venv, eval_env)

    result = TrainResult(
        algo=config.algo,
        env_id=config.env_id,
        run_dir=layout.run_dir,
        num_timesteps=int(model.num_timesteps),
        wall_time=wall_time,
        resumed_from=None if plan.checkpoint is None else plan.checkpoint.step,
        best_reward=recorder.best_reward,
        best_action=recorder.best_action,
        best_info=recorder.best_info,
        final_evaluation=final,
        history=tuple(recorder.history),
    )
    _write_result(layout, result, hp, plan.segments)
    return result


def _run_envs(plan: TrainPlan) -> tuple[VecEnv, StrokeRecorder, VecEnv]:
    """The training env (Monitor file, normalisation resumed from the checkpoint or new) with
    its stroke recorder, and the evaluation env."""
    config, hp = plan.config, plan.hp
    venv, recorder = make_training_env(
        config.env_id,
        hp.n_envs,
        config.seed,
        plan.env_kwargs,
        monitor_file=plan.layout.next_monitor_file(),
        normalize=None,
    )
    if hp.normalize is not None:
        if plan.checkpoint is not None:
            normalizer = read_normalizer(plan.checkpoint.vecnormalize)
            normalizer.set_venv(venv)
            venv = normalizer
            venv.training = True
        else:
            venv = VecNormalize(venv, **dict(hp.normalize))
    eval_env = make_evaluation_env(
        config.env_id, plan.env_kwargs, config.seed + 10_000, normalize=hp.normalize
    )
    return venv, recorder, eval_env


def _run_model(plan: TrainPlan, venv: VecEnv) -> BaseAlgorithm:
    """A new model, or the checkpoint's (with SAC's replay buffer) for a resumed run."""
    config = plan.config
    settings: dict[str, Any] = {
        "seed": config.seed,
        "tensorboard_log": plan.layout.tensorboard if config.tensorboard else None,
        "verbose": config.model_verbose,
        "device": config.device,
    }
    if plan.checkpoint is None:
        return build_model(config.algo, plan.hp, venv, **settings)
    model = load_checkpoint(config.algo, plan.checkpoint, plan.hp, venv, **settings)
    # A resumed segment is reproducible given its checkpoint (RNG states are not saved).
    model.set_random_seed(config.seed + model.num_timesteps)
    return model


def _run_callbacks(
    plan: TrainPlan, recorder: StrokeRecorder, eval_env: VecEnv, start_step: int
) -> list[BaseCallback]:
    """Physics logging, checkpoints every ``save_freq`` and evaluations every ``eval_freq``."""
    config, hp, layout = plan.config, plan.hp, plan.layout
    callbacks: list[BaseCallback] = [PhysicsLogger(recorder)]
    if config.save_freq > 0:
        callbacks.append(
            RunCheckpoint(layout, config.save_freq, KEEP_CHECKPOINTS, verbose=config.verbose)
        )
    if config.eval_freq > 0:
        callbacks.append(
            ResumableEvalCallback(
                eval_env,
                n_eval_episodes=eval_env.num_envs,
                eval_freq=max(config.eval_freq // hp.n_envs, 1),
                best_model_save_path=str(layout.run_dir),
                log_path=str(layout.run_dir),
                deterministic=True,
                verbose=config.verbose,
                callback_on_new_best=(
                    None if hp.normalize is None else SaveVecNormalize(layout.best_vecnormalize)
                ),
                resume_from_step=None if plan.checkpoint is None else start_step,
            )
        )
    return callbacks


def _save_and_evaluate(
    plan: TrainPlan, model: BaseAlgorithm, venv: VecEnv, eval_env: VecEnv
) -> list[dict[str, Any]]:
    """Save the final model (normalisation statistics, a last checkpoint), then evaluate its
    deterministic policy at every evaluation condition; closes both envs."""
    config, layout = plan.config, plan.layout
    model.save(layout.final_model)
    if plan.hp.normalize is not None:
        normalizer = model.get_vec_normalize_env()
        assert normalizer is not None
        normalizer.save(str(layout.vecnormalize))
        sync_envs_normalization(venv, eval_env)
    if config.save_freq > 0:
        save_checkpoint(model, layout)
        prune_checkpoints(layout, KEEP_CHECKPOINTS)
    final = evaluate_deterministic(model, eval_env)
    venv.close()
    eval_env.close()
    return final


def _say_plan(plan: TrainPlan) -> None:
    """What this command is about to do, before any work (stdout, ``verbose >= 1``)."""
    hp, layout = plan.hp, plan.layout
    if plan.target != hp.n_timesteps:
        what = (
            f"n_steps {plan.unit // hp.n_envs} x n_envs {hp.n_envs}"  # step_granularity's
            if plan.config.algo == "ppo"
            else f"train_freq x n_envs {hp.n_envs}"
        )
        print(
            f"n_timesteps {hp.n_timesteps} is not a whole number of {plan.config.algo.upper()} "
            f"iterations ({plan.unit} env steps = {what}); training runs to {plan.target}"
        )
    if plan.checkpoint is not None:
        print(
            f"resuming {layout.run_dir} from checkpoint {plan.checkpoint.model.name} "
            f"(step {plan.checkpoint.step} of {plan.target})"
        )
    elif layout.args_file.is_file():
        print(f"{layout.run_dir} has no complete checkpoint: starting it again from step 0")


def _best_segment(segments: Sequence[Mapping[str, Any]]) -> Mapping[str, Any]:
    """The segment whose best stroke wins by the selection rule (:mod:`agents.selection`);
    a segment without one (reward None) ranks last."""
    feasible = [bool((s.get("best_info") or {}).get("feasible", False)) for s in segments]
    rewards = [-math.inf if s["best_reward"] is None else s["best_reward"] for s in segments]
    return segments[best_index(feasible, rewards)]


def _write_result(
    layout: RunLayout,
    result: TrainResult,
    hp: Hyperparams,
    previous: Sequence[Mapping[str, Any]],
) -> None:
    """Write ``result.json``: the earlier segments (``previous``, read by the plan) and this
    run's."""
    segments = list(previous)
    segments.append(
        {
            "resumed_from": result.resumed_from,
            "end_step": result.num_timesteps,
            "wall_time_s": result.wall_time,
            "best_reward": result.best_reward,
            "best_action": result.best_action,
            "best_info": result.best_info,
        }
    )
    best = _best_segment(segments)
    data = {
        "algo": result.algo,
        "env_id": result.env_id,
        "num_timesteps": result.num_timesteps,
        "n_envs": hp.n_envs,
        "wall_time_s": sum(float(s["wall_time_s"]) for s in segments),
        "best_seen": {k: best[k] for k in ("best_reward", "best_action", "best_info")},
        "final_evaluation": result.final_evaluation,
        "segments": segments,
    }
    write_json_atomic(layout.result_file, data, indent=1)


# --- the harness's lean variant ----------------------------------------------------------------
def budget_hyperparams(
    algo: str,
    entry: Mapping[str, Any],
    overrides: Mapping[str, Any] | None,
    n_envs: int | None,
    budget: int,
) -> Hyperparams:
    """The hyperparameters of a run within ``budget`` env steps: ``n_timesteps`` is the budget
    rounded down to whole learn iterations (PPO: n_steps·n_envs, SAC: train_freq·n_envs),
    because SB3 never stops inside one and the budget is a hard limit."""
    hp = resolve_hyperparams(entry, overrides, n_envs=n_envs, n_timesteps=1)
    unit = step_granularity(algo, hp)
    steps = (budget // unit) * unit
    if steps < 1:
        raise ValueError(
            f"budget {budget} is below one {algo.upper()} iteration ({unit} env steps with "
            f"n_envs = {hp.n_envs}); allowed: a budget >= {unit}, or a smaller n_envs"
        )
    return resolve_hyperparams(entry, overrides, n_envs=n_envs, n_timesteps=steps)


def learn_in_memory(
    algo: str,
    env_id: str,
    env_kwargs: Mapping[str, Any],
    budget: int,
    seed: int,
    *,
    overrides: Mapping[str, Any] | None = None,
    n_envs: int | None = None,
    hyperparams_file: str | Path | None = None,
    on_step: Callable[[StrokeRecorder], None] | None = None,
    threads: int = 1,
) -> tuple[BaseAlgorithm, StrokeRecorder, Hyperparams]:
    """Train ``algo`` for at most ``budget`` env steps (see :func:`budget_hyperparams`), no files;
    returns (model, recorder, hp)."""
    hp = budget_hyperparams(
        algo, load_entry(algo, env_id, hyperparams_file), overrides, n_envs, budget
    )
    env_kwargs = {**hp.env_kwargs, **env_kwargs}
    with torch_threads(threads):
        venv, recorder = make_training_env(
            env_id,
            hp.n_envs,
            seed,
            env_kwargs,
            monitor_file=None,
            normalize=hp.normalize,
            on_step=on_step,
        )
        model = build_model(algo, hp, venv, seed=seed)
        model.learn(
            hp.n_timesteps,
            log_interval=default_log_interval(algo, hp.n_envs),
            progress_bar=False,
        )
    if recorder.evaluations > budget:  # cannot happen with the rounding above; never record it
        raise RuntimeError(f"{algo} used {recorder.evaluations} env steps > budget {budget}")
    return model, recorder, hp
