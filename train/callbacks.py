"""Callbacks of a training run: physical metrics to TensorBoard, and an EvalCallback that resumes.

SB3's own logger only knows rewards; here every vector step's ``info`` dicts (the model's
metrics of each evaluated stroke, with its normalised score against the reference optimum,
docs/reference.md) are averaged into ``physics/*`` scalars, and the best stroke seen so far
(from :class:`~train.vec.StrokeRecorder`) is logged beside them.
"""

from __future__ import annotations

import warnings
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, EvalCallback

from train.vec import StrokeRecorder

#: ``info`` entries averaged over each vector step into ``physics/<name>``.
LOGGED_METRICS: tuple[str, ...] = (
    "objective",
    "efficiency",
    "lift_to_weight",
    "power_per_mass",
    "constraint_violation",
    "feasible",
    "score",
)


class PhysicsLogger(BaseCallback):
    """Logs batch means of the physical metrics and the best stroke seen so far."""

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
            self.logger.record("physics/best_feasible", float(best["feasible"]))
            self.logger.record("physics/best_objective", float(best["objective"]))
            best_score = float(best.get("score", np.nan))
            if not np.isnan(best_score):
                self.logger.record("physics/best_score", best_score)
        self.logger.record("physics/evaluations", self.recorder.evaluations)
        return True


class ResumableEvalCallback(EvalCallback):
    """``EvalCallback`` that, on a resumed run, keeps the evaluations made before the kill.

    SB3's EvalCallback rewrites ``evaluations.npz`` from its in-memory lists, so a plain resume
    would lose the curve up to the checkpoint; this one starts from the file's rows up to the
    checkpoint's step, and from its best mean reward (so ``best_model.zip`` is only replaced by
    a better model).
    """

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
                steps = data["timesteps"]
                results = data["results"]
                lengths = data["ep_lengths"]
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


class SaveVecNormalize(BaseCallback):
    """Saves the training VecNormalize statistics (called by EvalCallback on a new best model,
    so ``best_model.zip`` is loaded with the statistics it was evaluated with)."""

    def __init__(self, path: Path, verbose: int = 0) -> None:
        super().__init__(verbose)
        self.path = Path(path)

    def _on_step(self) -> bool:
        normalizer = self.model.get_vec_normalize_env()
        if normalizer is not None:
            normalizer.save(str(self.path))
        return True
