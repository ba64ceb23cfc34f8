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
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

CHECKPOINT_PREFIX = "rl_model"
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
        """The newest existing run of ``algo`` on ``env_id``; ValueError if there is none."""
        algo_folder = Path(log_folder) / algo
        n = latest_run_id(algo_folder, env_name(env_id))
        if n == 0:
            raise ValueError(
                f"no run of {algo} on {env_id} in {algo_folder} to resume; allowed: start one "
                "without --resume, or give its folder with --run-dir"
            )
        return cls(algo_folder / f"{env_name(env_id)}_{n}", env_id)
