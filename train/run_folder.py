"""A training run's folder (``logs/<algo>/<env>_<n>/``, the files of
:class:`~train.layout.RunLayout`): :meth:`RunFolder.open` finds or makes it, locks it and
decides, before any work, whether this command may train there and from which checkpoint; the
folder then writes the run's settings and reads its normaliser. PPO, SAC
(:func:`train.run.train`) and the amortised policy (:func:`train.amortised.train_run`) share it.

When a run continues: ``--resume`` (the latest run of the algo and env) or ``--run-dir`` of a
folder ``python -m train`` wrote, with an intact checkpoint short of the target; it keeps the
settings it started with (``args.yml``, ``config.yml``). An amortised run is never continued
(it trains in minutes): its folder is new, or empty.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from tandem_env.envs.registration import check_env_id
from train.config import AMORTISED, Hyperparams, TrainConfig, plain, resolve_hyperparams, write_yaml
from train.layout import (
    LOCK_FILE,
    Checkpoint,
    RunComplete,
    RunLayout,
    read_normalizer,
    read_result_segments,
    read_run_yaml,
    run_lock,
)


def step_granularity(algo: str, hp: Hyperparams) -> int:
    """Env steps one learn iteration takes (``learn`` never stops inside one)."""
    if algo == "ppo":
        return int(hp.model_kwargs.get("n_steps", 2048)) * hp.n_envs
    train_freq = hp.model_kwargs.get("train_freq", 1)
    # Every episode is one step, so "episode" frequencies count the same vector steps.
    steps = train_freq[0] if isinstance(train_freq, tuple) else train_freq
    return int(steps) * hp.n_envs


@dataclass(frozen=True)
class RunFolder:
    """One run's folder, held (locked) by this command, and what it trains from."""

    layout: RunLayout
    config: TrainConfig
    """The run's settings: this command's, or those a continued run started with."""
    hp: Hyperparams | None = None
    """The resolved hyperparameters (PPO, SAC; None for an amortised run)."""
    checkpoint: Checkpoint | None = None
    """The checkpoint a continued run resumes from (None: from step 0)."""
    target: int = 0
    """Env steps the run ends at: n_timesteps rounded up to whole learn iterations."""
    unit: int = 0
    """Env steps of one learn iteration (see :func:`step_granularity`)."""
    segments: tuple[Mapping[str, Any], ...] = ()
    """The earlier runs' segments of the folder's ``result.json``, which a resume extends."""

    @classmethod
    def open(cls, config: TrainConfig, held: contextlib.ExitStack) -> RunFolder:
        """The folder of ``config``'s run, locked until ``held`` closes; every refusal (a folder
        not of ``python -m train``, in use, damaged, finished, unwritable; settings that differ
        from those the run started with) is raised here, before any work, and leaves the folder
        untouched. The lock (:func:`~train.layout.run_lock`) is taken before the folder's files
        are read, so a second command on the same run is refused instead of training beside it.
        """
        amortised = config.algo == AMORTISED
        layout = None
        if config.resume:
            layout = RunLayout.latest(config.log_folder, config.algo, config.env_id)
        elif config.run_dir is not None:
            layout = RunLayout(config.run_dir, config.env_id)
            _check_claimable(layout, amortised)
        # A folder that is not ours was refused above, before the lock file is made in it.
        locked = layout is not None and layout.run_dir.is_dir()
        if locked:
            held.enter_context(run_lock(layout.run_dir))  # type: ignore[union-attr]
            _check_claimable(layout, amortised)  # type: ignore[arg-type]
        if amortised:
            run = cls(layout or RunLayout.new(config.log_folder, AMORTISED, config.env_id), config)
        else:
            run = cls._resumable(config, layout)
        run.layout.run_dir.mkdir(parents=True, exist_ok=True)
        if not locked:  # a new folder (this process made it, or --run-dir of an absent one)
            held.enter_context(run_lock(run.layout.run_dir))
        for folder in (run.layout.run_dir, run.layout.params_dir):
            if folder.is_dir() and not os.access(folder, os.W_OK | os.X_OK):
                raise ValueError(
                    f"{folder} is not writable; a run writes its checkpoints, models and "
                    "settings there. Allowed: a folder you can write (chmod u+w), or a new run"
                )
        return run

    @classmethod
    def _resumable(cls, config: TrainConfig, layout: RunLayout | None) -> RunFolder | None:
        """A PPO / SAC run in ``layout`` (None: a new folder, made later): its settings,
        hyperparameters and the checkpoint it continues from, every file a resume loads read
        as it will read it."""
        checkpoint = None
        entry = None  # config.yml: the hyperparameters the run started with
        if layout is not None:
            resume = config.resume  # the merge below turns a resume into a run of a folder
            if layout.args_file.is_file():
                config = _merge_saved(config, read_run_yaml(layout.args_file), layout)
            if layout.config_file.is_file():
                entry = read_run_yaml(layout.config_file)
            normalize = entry is not None and bool(entry.get("normalize"))
            checkpoint = _latest_usable_checkpoint(layout, config.algo == "sac", normalize)
            damaged = [c.model.name for c in layout.checkpoints()]
            if checkpoint is None and damaged:
                raise ValueError(
                    f"{layout.run_dir}: no checkpoint is intact ({', '.join(damaged)}: see the "
                    "warnings above); it is left untouched. Allowed: move the damaged "
                    "checkpoints away to start this run again from step 0, or a new run"
                )
            if checkpoint is None and resume:
                raise ValueError(
                    f"{layout.run_dir} has no complete checkpoint to resume from (save_freq "
                    "<= 0, or killed before the first); allowed: start a new run"
                )
        if checkpoint is not None:
            if entry is None:
                # Resuming from the current yml instead would mix two runs' settings unsaid.
                raise ValueError(
                    f"{layout.config_file} is missing: the hyperparameters the run started "  # type: ignore[union-attr]
                    "with cannot be restored; allowed: a run folder with its config.yml (or "
                    "a new run)"
                )
            # A resumed run keeps the hyperparameters it started with, whatever the yml says.
            try:
                hp = resolve_hyperparams(entry, n_timesteps=config.n_timesteps)
            except ValueError as error:
                raise ValueError(f"{layout.config_file}: {error}") from None  # type: ignore[union-attr]
        else:
            hp = config.hyperparameters()
        unit = step_granularity(config.algo, hp)
        target = -(-hp.n_timesteps // unit) * unit  # where SB3's learn stops: whole iterations
        if checkpoint is not None and checkpoint.step >= target:
            raise RunComplete(layout.run_dir, checkpoint.step, target)  # type: ignore[union-attr]
        if checkpoint is None and layout is not None:
            finished = [p.name for p in (layout.final_model, layout.result_file) if p.is_file()]
            if finished:
                raise ValueError(
                    f"{layout.run_dir} holds a finished run ({', '.join(finished)}) and no "
                    "checkpoint to continue from (it ran with save_freq <= 0); a new run there "
                    "would overwrite it, so it is left untouched. Allowed: a new run (no "
                    "--run-dir) or another folder"
                )
        env_kwargs = {**hp.env_kwargs, **config.env_kwargs}
        _check_env(config.env_id, env_kwargs)
        segments: tuple[Mapping[str, Any], ...] = ()
        if checkpoint is not None:  # the files a resume loads, read as it will read them
            from train.checkpoint import load_on_copy

            checked = load_on_copy(config.algo, checkpoint, hp, config.env_id, env_kwargs)
            checked.get_env().close()  # type: ignore[union-attr]
            if hp.normalize is not None:
                read_normalizer(checkpoint.vecnormalize)
            segments = read_result_segments(layout.result_file)  # type: ignore[union-attr]
        if layout is None:
            layout = RunLayout.new(config.log_folder, config.algo, config.env_id)
        return cls(layout, config, hp, checkpoint, target, unit, segments)

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The env options: the yml entry's, overridden by the command's."""
        return {**(self.hp.env_kwargs if self.hp else {}), **self.config.env_kwargs}

    def start(self, settings: Mapping[str, Any]) -> None:
        """A run from step 0 writes its ``settings`` (``config.yml``) and its arguments
        (``args.yml``), and drops the evaluation curve an earlier start left; a continued run
        keeps its own."""
        if self.checkpoint is None:
            write_yaml(self.layout.config_file, settings)
            write_yaml(self.layout.args_file, self.config.to_dict())
            self.layout.evaluations.unlink(missing_ok=True)

    def normaliser(self) -> Any:
        """The checkpoint's ``VecNormalize`` statistics (read with only the classes such a file
        holds: :func:`~train.layout.read_normalizer`)."""
        assert self.checkpoint is not None
        return read_normalizer(self.checkpoint.vecnormalize)

    def say_plan(self) -> None:
        """What this command is about to do, before any work (stdout)."""
        hp, layout, algo = self.hp, self.layout, self.config.algo
        assert hp is not None
        if self.target != hp.n_timesteps:
            what = (
                f"n_steps {self.unit // hp.n_envs} x n_envs {hp.n_envs}"  # step_granularity's
                if algo == "ppo"
                else f"train_freq x n_envs {hp.n_envs}"
            )
            print(
                f"n_timesteps {hp.n_timesteps} is not a whole number of {algo.upper()} "
                f"iterations ({self.unit} env steps = {what}); training runs to {self.target}"
            )
        if self.checkpoint is not None:
            print(
                f"resuming {layout.run_dir} from checkpoint {self.checkpoint.model.name} "
                f"(step {self.checkpoint.step} of {self.target})"
            )
        elif layout.args_file.is_file():
            print(f"{layout.run_dir} has no complete checkpoint: starting it again from step 0")


def _check_claimable(layout: RunLayout, amortised: bool) -> None:
    """ValueError unless a run may start or go on in ``layout``'s folder: absent or empty, or
    (PPO, SAC) a run of ``python -m train`` on this env (:meth:`RunLayout.foreign`)."""
    run_dir = layout.run_dir
    if amortised:
        if run_dir.exists() and (
            not run_dir.is_dir() or any(p.name != LOCK_FILE for p in run_dir.iterdir())
        ):
            raise ValueError(
                f"run_dir = {run_dir}: not an empty folder; an amortised run is not resumed "
                "(it trains in minutes). Allowed: a new or empty folder"
            )
        return
    reason = layout.foreign()
    if reason is not None:
        raise ValueError(
            f"--run-dir: {reason}; it is left untouched. Allowed: a run folder of "
            "python -m train (to continue it), or an absent or empty folder (a new run)"
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
    layout: RunLayout, replay_buffer: bool, normalize: bool
) -> Checkpoint | None:
    """The newest intact checkpoint (with its replay buffer, its VecNormalize statistics)."""
    for checkpoint in reversed(layout.checkpoints()):
        problem = checkpoint.damage(replay_buffer=replay_buffer, vecnormalize=normalize)
        if problem is None:
            return checkpoint
        warnings.warn(
            f"skipping checkpoint {checkpoint.model.name} of {layout.run_dir}: {problem} "
            "(killed while saving?); an earlier intact checkpoint is used if there is one",
            RuntimeWarning,
            stacklevel=4,
        )
    return None


def _check_env(env_id: str, env_kwargs: Mapping[str, Any]) -> None:
    """ValueError unless ``env_id`` with ``env_kwargs`` makes an env."""
    import gymnasium as gym

    import tandem_env  # noqa: F401 - registers the ids

    check_env_id(env_id, "env")
    try:
        gym.make(env_id, disable_env_checker=True, **env_kwargs).close()
    except TypeError as error:
        raise ValueError(f"{env_id}: {error}") from error
