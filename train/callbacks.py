"""Callbacks of a training run: physical metrics to TensorBoard, an EvalCallback that resumes,
checkpoints (:class:`RunCheckpoint`) and Ctrl-C (:class:`StopOnInterrupt`).

SB3's own logger only knows rewards; here every vector step's ``info`` dicts (the model's
metrics of each evaluated stroke, with its normalised score against the reference optimum,
docs/reference.md) are averaged into ``physics/*`` scalars, and the best stroke seen so far
(from :class:`~train.vec.StrokeRecorder`) is logged beside them.
"""

from __future__ import annotations

import contextlib
import signal
import threading
import warnings
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, EvalCallback

from train.run_folder import Checkpoint, RunLayout
from train.saved import save_checkpoint
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
        recorder = self.recorder
        best = recorder.best_info
        scalars = {"evaluations": recorder.evaluations}
        if best is not None:
            scalars = {
                "best_reward": recorder.max_reward,
                "best_feasible": float(best["feasible"]),
                "best_objective": float(best["objective"]),
                "best_score": float(best.get("score", np.nan)),
                **scalars,
            }
        for name, value in scalars.items():
            if name != "best_score" or not np.isnan(value):  # NaN: no reference score
                self.logger.record(f"physics/{name}", value)
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


class RunCheckpoint(BaseCallback):
    """Checkpoints every ``save_freq`` env steps, keeping the newest ``keep``.

    Unlike SB3's CheckpointCallback (which saves inside ``on_step``, before an off-policy
    algorithm stores that step's transitions, so a resumed SAC would miss one vector step of
    its replay buffer), this saves at the end of a rollout: the buffer holds every transition
    up to the checkpoint's step. Files are named as CheckpointCallback names them.
    """

    def __init__(self, layout: RunLayout, save_freq: int, keep: int, verbose: int = 0) -> None:
        super().__init__(verbose)
        self.layout = layout
        self.save_freq = save_freq
        self.keep = keep
        self._next = save_freq

    def _init_callback(self) -> None:
        self._next = (self.model.num_timesteps // self.save_freq + 1) * self.save_freq

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        step = self.model.num_timesteps
        if step >= self._next:
            checkpoint = save_checkpoint(self.model, self.layout, self.keep)
            self._next = (step // self.save_freq + 1) * self.save_freq
            if self.verbose >= 2:
                print(f"Saved checkpoint {checkpoint.model}")


class StopOnInterrupt(BaseCallback):
    """Ctrl-C (SIGINT) while :meth:`catching` stops ``learn`` at the next env step (not a
    KeyboardInterrupt wherever it lands); :meth:`save` then checkpoints the last rollout's end
    (:attr:`boundary`: the unfinished rollout's steps are collected again on resume). A second
    Ctrl-C raises KeyboardInterrupt at once."""

    def __init__(self) -> None:
        super().__init__()
        self.requested = False
        self.boundary = 0

    def _init_callback(self) -> None:
        self.boundary = self.model.num_timesteps

    def _on_rollout_end(self) -> None:
        self.boundary = self.model.num_timesteps

    def _on_step(self) -> bool:
        return not self.requested

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

    def save(self, layout: RunLayout, keep: int) -> Checkpoint:
        """The checkpoint of the last whole iteration, the ``keep`` newest kept."""
        self.model.num_timesteps = self.boundary
        return save_checkpoint(self.model, layout, keep)
