"""Where a run's files live: the rl-baselines3-zoo folder layout, and finding checkpoints.

::

    logs/<algo>/<env>_<n>/                  e.g. logs/sac/TandemWing-LevelFlight-v0_1/
        <env>.zip                           final model
        best_model.zip                      best deterministic evaluation (EvalCallback)
        evaluations.npz                     EvalCallback's timesteps / results / ep_lengths
        rl_model_<N>_steps.zip              checkpoints (the last two kept) ...
        rl_model_replay_buffer_<N>_steps.pkl    ... with the SAC replay buffer
        rl_model_vecnormalize_<N>_steps.pkl     ... and VecNormalize statistics if used
        <k>.monitor.csv                     episodes (one per stroke) of training segment k
        result.json                         summary: best stroke seen, final evaluation, timing
        tb/<ALGO>_1/                        TensorBoard events
        <env>/config.yml, args.yml          hyperparameters and arguments (zoo's params folder)
        <env>/vecnormalize.pkl              final VecNormalize statistics if used
        best_model_vecnormalize.pkl         ... and those of best_model.zip

``<env>`` is the env id with ``/`` replaced by ``-`` (the zoo's ``EnvironmentName``).

rl-baselines3-zoo writes the same layout into the same folders (``logs/<algo>/<env>_<n>/``,
``rl_model_<N>_steps.zip``, ``<env>/args.yml``), so a run of this project is recognised by the
``made_by`` entry of its ``args.yml`` (:data:`MADE_BY`); :meth:`RunLayout.foreign` says why a
folder is not one, and ``python -m train`` never resumes in, or writes into, such a folder.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import yaml

CHECKPOINT_PREFIX = "rl_model"
#: The ``made_by`` entry of ``args.yml`` that marks a run folder written by ``python -m train``.
MADE_BY = "tandem-env python -m train"
#: An ``args.yml`` key only this project writes (runs from before ``made_by`` have it; the
#: zoo calls its thread count ``num_threads``).
_LEGACY_KEY = "torch_threads"
_CHECKPOINT = re.compile(rf"^{CHECKPOINT_PREFIX}_(\d+)_steps\.zip$")


def env_name(env_id: str) -> str:
    """The env id as a folder name: ``TandemWing/LevelFlight-v0`` -> ``TandemWing-LevelFlight-v0``."""
    return env_id.replace("/", "-")


def latest_run_id(algo_folder: Path, name: str) -> int:
    """Greatest ``n`` of the ``<name>_<n>`` folders in ``algo_folder`` (0 if none), as the zoo."""
    best = 0
    if algo_folder.is_dir():
        for path in algo_folder.iterdir():
            stem, _, number = path.name.rpartition("_")
            if path.is_dir() and stem == name and number.isdigit():
                best = max(best, int(number))
    return best


class RunComplete(Exception):
    """A resumed run has nothing left to train (its checkpoint is at or past the target);
    nothing was changed. ``python -m train`` prints the message and exits with status 0."""

    def __init__(self, run_dir: Path, step: int, target: int) -> None:
        self.run_dir, self.step, self.target = run_dir, step, target
        super().__init__(
            f"{run_dir} is complete: its last checkpoint is at {step} env steps and the target "
            f"is {target}; nothing was trained or changed. To train on, give a larger target "
            f"(-n N with N > {step})"
        )


@dataclass(frozen=True)
class Checkpoint:
    """One checkpoint: the model after ``step`` env steps and its companions."""

    step: int
    model: Path
    replay_buffer: Path
    vecnormalize: Path

    def complete(self, *, replay_buffer: bool, vecnormalize: bool) -> bool:
        """All files a faithful resume needs are there."""
        needed = [self.model]
        if replay_buffer:
            needed.append(self.replay_buffer)
        if vecnormalize:
            needed.append(self.vecnormalize)
        return all(p.is_file() and p.stat().st_size > 0 for p in needed)

    def paths(self) -> tuple[Path, ...]:
        return (self.model, self.replay_buffer, self.vecnormalize)


@dataclass(frozen=True)
class RunLayout:
    """The files of one run folder."""

    run_dir: Path
    env_id: str

    @property
    def name(self) -> str:
        return env_name(self.env_id)

    @property
    def final_model(self) -> Path:
        return self.run_dir / f"{self.name}.zip"

    @property
    def best_model(self) -> Path:
        return self.run_dir / "best_model.zip"

    @property
    def evaluations(self) -> Path:
        return self.run_dir / "evaluations.npz"

    @property
    def params_dir(self) -> Path:
        return self.run_dir / self.name

    @property
    def config_file(self) -> Path:
        return self.params_dir / "config.yml"

    @property
    def args_file(self) -> Path:
        return self.params_dir / "args.yml"

    @property
    def vecnormalize(self) -> Path:
        return self.params_dir / "vecnormalize.pkl"

    @property
    def tensorboard(self) -> Path:
        return self.run_dir / "tb"

    @property
    def result_file(self) -> Path:
        return self.run_dir / "result.json"

    def monitor_files(self) -> list[Path]:
        return sorted(self.run_dir.glob("*.monitor.csv"))

    def next_monitor_file(self) -> Path:
        """A fresh Monitor file per training segment (VecMonitor truncates an existing one)."""
        return self.run_dir / f"{len(self.monitor_files())}.monitor.csv"

    def foreign(self) -> str | None:
        """None if this folder is a run of ``python -m train`` on this env, or is absent or
        empty (a new run may start there); otherwise why it is not, in words."""
        if not self.run_dir.exists():
            return None
        if not self.run_dir.is_dir():
            return f"{self.run_dir} is a file, not a run folder"
        if not self.args_file.is_file():
            if not any(self.run_dir.iterdir()):
                return None
            others = sorted(p.parent.name for p in self.run_dir.glob("*/args.yml"))
            if others:
                return (
                    f"{self.run_dir} holds a run of {', '.join(others)} (its */args.yml), not of "
                    f"{self.env_id}"
                )
            return f"{self.run_dir} holds files but no {self.name}/args.yml: not a training run"
        text = self.args_file.read_text()
        try:
            args = yaml.load(text, Loader=yaml.UnsafeLoader)  # the zoo writes python tags
        except yaml.YAMLError as error:
            return f"{self.args_file} is not readable YAML ({error})"
        if isinstance(args, dict) and args.get("made_by") == MADE_BY:
            return None
        if isinstance(args, dict) and _LEGACY_KEY in args and "!!python" not in text:
            return None
        looks_like = ""
        if "!!python/object/apply:collections.OrderedDict" in text or (
            isinstance(args, dict) and "trained_agent" in args
        ):
            looks_like = (
                " (it looks like an rl-baselines3-zoo run: rl_zoo3.train writes the same layout)"
            )
        return f"{self.run_dir} was not written by python -m train{looks_like}"

    def checkpoint(self, step: int) -> Checkpoint:
        base = self.run_dir / CHECKPOINT_PREFIX
        return Checkpoint(
            step=step,
            model=Path(f"{base}_{step}_steps.zip"),
            replay_buffer=Path(f"{base}_replay_buffer_{step}_steps.pkl"),
            vecnormalize=Path(f"{base}_vecnormalize_{step}_steps.pkl"),
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
        n = latest_run_id(algo_folder, env_name(env_id)) + 1
        run_dir = algo_folder / f"{env_name(env_id)}_{n}"
        run_dir.mkdir(parents=True, exist_ok=False)
        return cls(run_dir, env_id)

    @classmethod
    def latest(cls, log_folder: Path, algo: str, env_id: str) -> RunLayout:
        """The newest existing run of ``algo`` on ``env_id``; ValueError if there is none, or
        if the newest folder is not a run of this project (e.g. rl_zoo3's: same layout)."""
        algo_folder = Path(log_folder) / algo
        name = env_name(env_id)
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
                candidate
                for k in range(n - 1, 0, -1)
                if (candidate := cls(algo_folder / f"{name}_{k}", env_id)).args_file.is_file()
                and candidate.foreign() is None
            ]
            hint = (
                f"--run-dir {own[0].run_dir} (the latest run of this project)"
                if own
                else ("a new run (without --resume)")
            )
            raise ValueError(
                f"--resume takes the latest run, and {reason}; it is left untouched. "
                f"Allowed: {hint}"
            )
        return layout
