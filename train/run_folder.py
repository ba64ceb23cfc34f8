"""A training run's folder (docs/training.md, "The run folder") of PPO, SAC and the amortised
policy: its files (:class:`RunLayout`, rl-baselines3-zoo's ``logs/<algo>/<env>_<n>/``; a run of
this project is told from rl_zoo3's by ``made_by`` in ``args.yml``) and when a run goes on
there (:meth:`RunFolder.open`, every refusal before any work).
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

import gymnasium as gym

from tandem_env.io.files import FolderLock
from train import saved
from train.config import (
    AMORTISED,
    FOLDER_NAME,
    MADE_BY,
    Hyperparams,
    TrainConfig,
    load_entry,
    plain,
    resolve_hyperparams,
    step_granularity,
    write_yaml,
)

CHECKPOINT_PREFIX = "rl_model"
#: An ``args.yml`` key only this project writes (runs from before ``made_by`` have it; the
#: zoo calls its thread count ``num_threads``).
_LEGACY_KEY = "torch_threads"
_CHECKPOINT = re.compile(rf"^{CHECKPOINT_PREFIX}_(\d+)_steps\.zip$")
#: The lock file of a run folder: held (``flock``) by the ``python -m train`` writing there.
LOCK_FILE = ".train.lock"
#: What an amortised run's network is besides its weights (``train.amortised_policy``).
POLICY_FILE = "policy.json"


def latest_run_id(algo_folder: Path, name: str) -> int:
    """Greatest ``n`` of the ``<name>_<n>`` folders in ``algo_folder`` (0 if none), as the zoo."""
    paths = algo_folder.iterdir() if algo_folder.is_dir() else ()
    parts = [(p, *p.name.rpartition("_")) for p in paths]
    return max(
        [int(n) for p, stem, _, n in parts if p.is_dir() and stem == name and n.isdigit()] or [0]
    )


def resolve_run_dir(path: str | os.PathLike[str]) -> Path:
    """A run folder, or the latest run a path names: ``logs/ppo/<env>`` (no ``_<n>``) is
    ``logs/ppo/<env>_<n>`` with the greatest ``n``; any other path as given."""
    path = Path(path)
    if path.is_dir() or not path.parent.is_dir():
        return path
    n = latest_run_id(path.parent, path.name)
    return path.parent / f"{path.name}_{n}" if n else path


def read_run_folder(
    run_dir: str | os.PathLike[str], allowed: str
) -> tuple[RunLayout, dict[str, Any]]:
    """The layout of a run folder (or of the latest run it names, :func:`resolve_run_dir`) and
    the settings of its one ``<env>/args.yml`` (its ``args_file``); ValueError naming the folder
    and ``allowed`` otherwise."""
    folder = resolve_run_dir(run_dir)
    found = sorted(folder.glob("*/args.yml")) if folder.is_dir() else []
    if len(found) != 1:
        raise ValueError(
            f"{folder} is not a training run folder (expected one <env>/args.yml, found "
            f"{len(found)}); allowed: {allowed}"
        )
    args = saved.read_run_yaml(found[0])
    env_id = args.get("env")
    if not isinstance(env_id, str) or env_id.translate(FOLDER_NAME) != found[0].parent.name:
        raise ValueError(
            f"{found[0]}: env = {env_id!r}, but the file sits in the settings folder of "
            f"{found[0].parent.name}; allowed: the env the run was trained on"
        )
    return RunLayout(folder, env_id), args


def run_lock(run_dir: Path) -> FolderLock:
    """The exclusive lock of a run folder (``<run>/.train.lock``, a ``FolderLock``)."""
    return FolderLock(
        run_dir,
        LOCK_FILE,
        lambda pid: (
            f"{run_dir} is in use: another python -m train (pid {pid}) is training there "
            f"and holds {LOCK_FILE}; nothing was changed. Allowed: wait for it to finish, or resume "
            "another run"
        ),
    )


class RunPolicy:
    """What every trained policy (``TrainedPolicy``, ``AmortisedPolicy``) answers about its run."""

    run_dir: Path | None
    env_id: str
    training_conditions: tuple[float, float] | float | None
    """The condition range it was trained on, or its fixed condition (None if unknown) [the
    condition's unit]."""

    def check_env(self, env_id: str) -> None:
        """ValueError unless the run was trained on ``env_id``."""
        if self.env_id != env_id:
            raise ValueError(
                f"{self.run_dir} was trained on {self.env_id}; this task's env is {env_id}; "
                "allowed: a run of the same env"
            )

    def trained_at(self, value: float) -> bool:
        """Whether ``value`` is a condition the policy saw in training (inside its range, or
        its fixed condition); True when the training condition is unknown."""
        seen = self.training_conditions
        if isinstance(seen, tuple):
            return seen[0] - 1e-9 <= value <= seen[1] + 1e-9
        return seen is None or math.isclose(seen, value)


class RunComplete(Exception):
    """A resumed run has nothing left to train (``python -m train`` exits with status 0)."""


class Interrupted(Exception):
    """Training stopped by Ctrl-C with a checkpoint saved (``python -m train`` exits 130)."""


@dataclass(frozen=True)
class Checkpoint:
    """One checkpoint: the model after ``step`` env steps and its companions."""

    step: int
    model: Path
    replay_buffer: Path
    """SAC's replay buffer, arrays in an ``.npz`` (:func:`train.saved.save_replay_buffer`)."""
    vecnormalize: Path
    legacy_replay_buffer: Path
    """The pickled buffer of earlier versions: never loaded (a pickle can run code)."""

    def loads(self, algo: str) -> dict[str, Any]:
        """``saved.load_model``'s ``step`` and ``replay_buffer`` (SAC's)."""
        return {"step": self.step, "replay_buffer": self.replay_buffer if algo == "sac" else None}

    def paths(self) -> tuple[Path, ...]:
        return (self.model, self.replay_buffer, self.vecnormalize, self.legacy_replay_buffer)


class RunLayout:
    """The files of one run folder (``run_dir``) of a run on ``env_id``."""

    def __init__(self, run_dir: str | os.PathLike[str], env_id: str) -> None:
        self.run_dir, self.env_id, self.name = Path(run_dir), env_id, env_id.translate(FOLDER_NAME)
        self.params_dir = self.run_dir / self.name
        self.final_model = self.run_dir / f"{self.name}.zip"
        self.best_model = self.run_dir / "best_model.zip"
        self.best_vecnormalize = self.run_dir / "best_model_vecnormalize.pkl"
        """The VecNormalize statistics ``best_model.zip`` was evaluated with."""
        self.evaluations = self.run_dir / "evaluations.npz"
        self.tensorboard = self.run_dir / "tb"
        self.result_file = self.run_dir / "result.json"
        self.config_file = self.params_dir / "config.yml"
        self.args_file = self.params_dir / "args.yml"
        self.vecnormalize = self.params_dir / "vecnormalize.pkl"
        self.weights = self.run_dir / f"{self.name}.pt"
        """An amortised run's weights (``torch.load(weights_only=True)``), beside its
        ``policy.json`` (:attr:`policy_file`)."""
        self.policy_file = self.run_dir / POLICY_FILE

    def monitor_files(self) -> list[Path]:
        """The Monitor CSVs of the run's training segments, in order."""
        return sorted(self.run_dir.glob("*.monitor.csv"), key=lambda p: int(p.name.split(".")[0]))

    def next_monitor_file(self) -> Path:
        """A fresh Monitor file per training segment (VecMonitor truncates an existing one)."""
        return self.run_dir / f"{len(self.monitor_files())}.monitor.csv"

    def foreign(self) -> str | None:
        """None if a run may go on here (absent, empty, or ours on this env); else why not."""
        if not self.run_dir.exists():
            return None
        if not self.run_dir.is_dir():
            return f"{self.run_dir} is a file, not a run folder"
        if not self.args_file.is_file():
            if not any(p.name != LOCK_FILE for p in self.run_dir.iterdir()):
                return None
            others = sorted(p.parent.name for p in self.run_dir.glob("*/args.yml"))
            if others:
                return (
                    f"{self.run_dir} holds a run of {', '.join(others)} (its */args.yml), not of "
                    f"{self.env_id}"
                )
            return f"{self.run_dir} holds files but no {self.name}/args.yml: not a training run"
        try:
            text = self.args_file.read_text(encoding="utf-8")
            args = saved.parse_run_yaml(text, self.args_file)
        except UnicodeDecodeError:
            return f"{self.args_file} is not UTF-8 text"
        except (OSError, ValueError) as error:
            return str(error)
        if args.get("made_by") == MADE_BY or (_LEGACY_KEY in args and "!!python" not in text):
            return None
        zoo = "!!python/object/apply:collections.OrderedDict" in text or "trained_agent" in args
        looks = " (it looks like an rl-baselines3-zoo run: rl_zoo3.train writes the same layout)"
        return f"{self.run_dir} was not written by python -m train{looks if zoo else ''}"

    def checkpoint(self, step: int) -> Checkpoint:
        base = f"{self.run_dir / CHECKPOINT_PREFIX}"
        return Checkpoint(
            step=step,
            model=Path(f"{base}_{step}_steps.zip"),
            replay_buffer=Path(f"{base}_replay_buffer_{step}_steps.npz"),
            vecnormalize=Path(f"{base}_vecnormalize_{step}_steps.pkl"),
            legacy_replay_buffer=Path(f"{base}_replay_buffer_{step}_steps.pkl"),
        )

    def checkpoints(self) -> list[Checkpoint]:
        """Every checkpoint model in the folder, oldest first."""
        if not self.run_dir.is_dir():
            return []
        steps = sorted(
            int(m.group(1)) for p in self.run_dir.iterdir() if (m := _CHECKPOINT.match(p.name))
        )
        return [self.checkpoint(step) for step in steps]

    @classmethod
    def new(cls, log_folder: Path, algo: str, env_id: str) -> RunLayout:
        """The next free ``log_folder/<algo>/<env>_<n>`` (created)."""
        algo_folder = Path(log_folder) / algo
        name = env_id.translate(FOLDER_NAME)
        run_dir = algo_folder / f"{name}_{latest_run_id(algo_folder, name) + 1}"
        run_dir.mkdir(parents=True, exist_ok=False)
        return cls(run_dir, env_id)

    @classmethod
    def latest(cls, log_folder: Path, algo: str, env_id: str) -> RunLayout:
        """The newest existing run of ``algo`` on ``env_id``; ValueError if there is none, or
        if the newest folder is not a run of this project (e.g. rl_zoo3's: same layout)."""
        algo_folder = Path(log_folder) / algo
        name = env_id.translate(FOLDER_NAME)
        n = latest_run_id(algo_folder, name)
        if n == 0:
            raise ValueError(
                f"no run of {algo} on {env_id} in {algo_folder} to resume; allowed: start one "
                "without --resume, or give its folder with --run-dir"
            )
        layout = cls(algo_folder / f"{name}_{n}", env_id)
        reason = layout.foreign()
        if reason is not None:
            own = [
                candidate.run_dir
                for k in range(n - 1, 0, -1)
                if (candidate := cls(algo_folder / f"{name}_{k}", env_id)).args_file.is_file()
                and candidate.foreign() is None
            ]
            hint = f"--run-dir {own[0]} (the latest run of this project)" if own else "a new run"
            raise ValueError(
                f"--resume takes the latest run, and {reason}; it is left untouched. "
                f"Allowed: {hint}{'' if own else ' (without --resume)'}"
            )
        return layout


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
    segments: tuple[Mapping[str, Any], ...] = ()
    """The earlier runs' segments of the folder's ``result.json``, which a resume extends."""
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    """The env options: the yml entry's, overridden by the command's."""

    @classmethod
    def open(cls, config: TrainConfig, held: contextlib.ExitStack) -> RunFolder:
        """The folder of ``config``'s run, locked (before its files are read) until ``held``
        closes; every refusal is raised here, before any work, leaving the folder untouched."""
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
            layout = layout or RunLayout.new(config.log_folder, AMORTISED, config.env_id)
            run = cls(layout, config, env_kwargs=config.env_kwargs)
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
        if not config.verbose or amortised:
            return run
        # what this command is about to do, before any work (stdout)
        hp, checkpoint, target = run.hp, run.checkpoint, run.target
        assert hp is not None
        if target != hp.n_timesteps:
            unit = step_granularity(hp)
            per_env = f"n_steps {unit // hp.n_envs}" if config.algo == "ppo" else "train_freq"
            print(
                f"n_timesteps {hp.n_timesteps} is not a whole number of {config.algo.upper()} "
                f"iterations ({unit} env steps = {per_env} x n_envs {hp.n_envs}); training runs "
                f"to {target}"
            )
        if checkpoint is not None:
            print(
                f"resuming {run.layout.run_dir} from checkpoint {checkpoint.model.name} "
                f"(step {checkpoint.step} of {target})"
            )
        elif run.layout.args_file.is_file():
            print(f"{run.layout.run_dir} has no complete checkpoint: starting it again from step 0")
        return run

    @classmethod
    def _resumable(cls, config: TrainConfig, layout: RunLayout | None) -> RunFolder:
        """A PPO / SAC run in ``layout`` (None: a new folder): its settings, hyperparameters
        and checkpoint, every file a resume loads read as it will read it."""
        checkpoint = hp = None
        if layout is not None:
            resume = config.resume  # the merge below turns a resume into a run of a folder
            if layout.args_file.is_file():
                config = _merge_saved(config, saved.read_run_yaml(layout.args_file), layout)
            # config.yml: the hyperparameters the run started with, which a resume keeps
            entry = (
                saved.read_run_yaml(layout.config_file) if layout.config_file.is_file() else None
            )
            if layout.checkpoints():
                if entry is None:  # resuming from the current yml would mix two runs' settings
                    raise ValueError(
                        f"{layout.config_file} is missing: the hyperparameters the run started "
                        "with cannot be restored; allowed: a run folder with its config.yml (or "
                        "a new run)"
                    )
                try:
                    hp = resolve_hyperparams(
                        entry, algo=config.algo, n_timesteps=config.n_timesteps
                    )
                except ValueError as error:
                    raise ValueError(f"{layout.config_file}: {error}") from None
            elif resume:
                raise ValueError(
                    f"{layout.run_dir} has no complete checkpoint to resume from (save_freq "
                    "<= 0, or killed before the first); allowed: start a new run"
                )
        if hp is None:
            entry = load_entry(config.algo, config.env_id, config.hyperparams_file)
            hp = resolve_hyperparams(
                entry,
                config.hyperparams,
                algo=config.algo,
                n_envs=config.n_envs,
                n_timesteps=config.n_timesteps,
            )
        env_kwargs = {**hp.env_kwargs, **config.env_kwargs}
        try:  # the env's options, before any work
            gym.make(config.env_id, disable_env_checker=True, **env_kwargs).close()
        except TypeError as error:
            raise ValueError(f"{config.env_id}: {error}") from error
        segments: tuple[Mapping[str, Any], ...] = ()
        if layout is not None and layout.checkpoints():
            checkpoint = _latest_intact(layout, config, hp, env_kwargs)
            segments = saved.read_result_segments(layout.result_file)
        unit = step_granularity(hp)
        target = -(-hp.n_timesteps // unit) * unit  # where SB3's learn stops: whole iterations
        if checkpoint is not None and checkpoint.step >= target:
            raise RunComplete(  # type: ignore[union-attr]
                f"{layout.run_dir} is complete: its last checkpoint is at {checkpoint.step} env "
                f"steps and the target is {target}; nothing was trained or changed. To train on, "
                f"give a larger target (-n N with N > {checkpoint.step})"
            )
        if checkpoint is None and layout is not None:
            finished = [p.name for p in (layout.final_model, layout.result_file) if p.is_file()]
            if finished:
                raise ValueError(
                    f"{layout.run_dir} holds a finished run ({', '.join(finished)}) and no "
                    "checkpoint to continue from (it ran with save_freq <= 0); a new run there "
                    "would overwrite it, so it is left untouched. Allowed: a new run (no "
                    "--run-dir) or another folder"
                )
        layout = layout or RunLayout.new(config.log_folder, config.algo, config.env_id)
        return cls(layout, config, hp, checkpoint, target, segments, MappingProxyType(env_kwargs))

    def model(self, venv: Any) -> Any:
        """The model this run trains on ``venv``: new, or the checkpoint's seeded by its step
        (a resumed segment is reproducible given its checkpoint; RNG states are not saved)."""
        assert self.hp is not None
        config, checkpoint = self.config, self.checkpoint
        algo, seed = config.algo, config.seed
        settings = {
            "tensorboard_log": self.layout.tensorboard if config.tensorboard else None,
            # SB3's log table only with log_table (or verbose 2); the run's messages follow verbose
            "verbose": config.verbose if config.log_table or config.verbose >= 2 else 0,
            "device": config.device,
        }
        if checkpoint is None:
            return saved.build_model(algo, self.hp, venv, seed=seed, **settings)
        model = saved.load_model(
            algo, checkpoint.model, self.hp, venv, seed=seed, **checkpoint.loads(algo), **settings
        )
        model.set_random_seed(seed + model.num_timesteps)
        return model

    def start(self, settings: Mapping[str, Any]) -> None:
        """A run from step 0 writes ``config.yml`` (``settings``) and ``args.yml`` and drops an
        earlier start's evaluation curve; a continued run keeps its own."""
        if self.checkpoint is None:
            write_yaml(self.layout.config_file, settings)
            write_yaml(self.layout.args_file, self.config.to_dict())
            self.layout.evaluations.unlink(missing_ok=True)


def _check_claimable(layout: RunLayout, amortised: bool) -> None:
    """ValueError unless a run may start or go on in ``layout``'s folder."""
    run_dir = layout.run_dir
    if not amortised:
        reason = layout.foreign()
        if reason is not None:
            raise ValueError(
                f"--run-dir: {reason}; it is left untouched. Allowed: a run folder of "
                "python -m train (to continue it), or an absent or empty folder (a new run)"
            )
    elif run_dir.exists() and (
        not run_dir.is_dir() or any(p.name != LOCK_FILE for p in run_dir.iterdir())
    ):
        raise ValueError(
            f"run_dir = {run_dir}: not an empty folder; an amortised run is not resumed "
            "(it trains in minutes). Allowed: a new or empty folder"
        )


def _merge_saved(config: TrainConfig, args: Mapping[str, Any], layout: RunLayout) -> TrainConfig:
    """The config of a run being continued: its saved settings, this command's target steps."""
    for key, mine in (("algo", config.algo), ("env", config.env_id)):
        if args.get(key) != mine:
            raise ValueError(
                f"{layout.run_dir} is a run of {key} = {args.get(key)!r}, not {mine!r}; "
                "allowed: the same algo and env, or a new run"
            )
    for key, mine in (("env_kwargs", config.env_kwargs), ("hyperparams", config.hyperparams)):
        if mine and plain(dict(mine)) != args.get(key):
            raise ValueError(
                f"{layout.run_dir} was started with {key} = {args.get(key)!r}; this command "
                f"gives {plain(dict(mine))!r}. A resumed run keeps its settings; allowed: the "
                "same values or none, or a new run"
            )
    kept = {
        key: int(args.get(key, getattr(config, key))) for key in ("seed", "eval_freq", "save_freq")
    }
    return replace(
        config,
        **kept,
        n_envs=args.get("n_envs"),
        n_timesteps=config.n_timesteps or args.get("n_timesteps"),
        env_kwargs=args.get("env_kwargs") or {},
        hyperparams=args.get("hyperparams") or {},
        hyperparams_file=args.get("conf_file"),
        resume=False,
        run_dir=layout.run_dir,
    )


def _latest_intact(
    layout: RunLayout, config: TrainConfig, hp: Hyperparams, env_kwargs: Mapping[str, Any]
) -> Checkpoint:
    """The newest checkpoint whose files load as a resume loads them (its model, SAC's replay
    buffer, the VecNormalize statistics), each read once, nothing unpickled: one cut short (a
    kill while saving) is skipped with a warning, one that is refused raises its ValueError."""
    for checkpoint in reversed(layout.checkpoints()):
        needed = [checkpoint.model]
        needed += [checkpoint.replay_buffer] if config.algo == "sac" else []
        needed += [checkpoint.vecnormalize] if hp.normalize is not None else []
        missing = [path.name for path in needed if not path.is_file()]
        problem = f"{missing[0]} is missing" if missing else None
        legacy = checkpoint.legacy_replay_buffer
        if checkpoint.replay_buffer.name in missing and legacy.exists():
            problem = (
                f"its replay buffer is {legacy.name}, the pickled format of earlier versions, "
                "which is never loaded (a pickle can run code)"
            )
        try:
            if problem is None:
                loads = checkpoint.loads(config.algo)
                model = saved.load_on_copy(
                    config.algo, checkpoint.model, hp, config.env_id, env_kwargs, **loads
                )
                model.get_env().close()  # type: ignore[union-attr]
                if hp.normalize is not None:
                    saved.read_normalizer(checkpoint.vecnormalize)
                return checkpoint
        except saved.Incomplete as error:
            problem = error.damage
        warnings.warn(
            f"skipping checkpoint {checkpoint.model.name} of {layout.run_dir}: {problem} "
            "(killed while saving?); an earlier intact checkpoint is used if there is one",
            RuntimeWarning,
            stacklevel=4,
        )
    raise ValueError(
        f"{layout.run_dir}: no checkpoint is intact "
        f"({', '.join(c.model.name for c in layout.checkpoints())}: see the warnings above); it is "
        "left untouched. Allowed: move the damaged checkpoints away to start this run again "
        "from step 0, or a new run"
    )
