"""B evaluated strokes of a task, scored, before they are split per env (:class:`StepBatch`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..physics import PARAMETER_NAMES, Result
from .columns import Columns
from .config import PenaltyConfig
from .declaration import Scores

_HARMONIC = {name for name in PARAMETER_NAMES if name.endswith("_elevation_harmonic")}


@dataclass(frozen=True)
class StepBatch:
    """B evaluated strokes: what ``step`` returns and records, before it is split per env."""

    physical: np.ndarray
    """(B, 28) physical strokes (Table 4 units)."""
    result: Result
    """The model's full result, (B,) arrays."""
    objective: np.ndarray
    """(B,) the task's objective [-]."""
    scores: Scores
    """The task's constraint violations and feasibility (its declaration's constraints)."""
    penalty: np.ndarray
    """(B,) reward lost to the constraints [reward units] (exactly 0 when feasible)."""
    reward: np.ndarray
    """(B,) objective − penalty."""
    score: np.ndarray | None
    """(B,) the normalised score [-] (:mod:`tandem_env.envs.reference`); None where the
    reference table does not describe the env."""

    @classmethod
    def scored(
        cls,
        physical: np.ndarray,
        result: Result,
        objective: np.ndarray,
        scores: Scores,
        penalty: PenaltyConfig,
        score: np.ndarray | None = None,
    ) -> StepBatch:
        """The batch, its reward the objective penalised by the env's ``penalty``."""
        lost = penalty.penalty(scores.total, scores.feasible)
        return cls(physical, result, objective, scores, lost, objective - lost, score)

    def __len__(self) -> int:
        return int(self.reward.shape[0])

    @property
    def feasible(self) -> np.ndarray:
        """(B,) bool, every constraint of the task met."""
        return self.scores.feasible

    @property
    def terminated(self) -> np.ndarray:
        """(B,) bool, all True: a one-cycle episode ends with its stroke."""
        return np.ones(len(self), dtype=np.bool_)

    @property
    def truncated(self) -> np.ndarray:
        """(B,) bool, all False: a one-cycle episode is never cut short."""
        return np.zeros(len(self), dtype=np.bool_)

    def info_columns(self) -> Columns:
        """Every metric of the model, the task's constraints and reward terms, the stroke."""
        columns: Columns = {}
        for name, values in self.result.as_dict().items():
            columns[name] = values if values.dtype == bool else values.astype(float, copy=False)
        columns.update(self.scores.violations)
        columns |= {"objective": self.objective, "constraint_violation": self.scores.total}
        columns |= {"penalty": self.penalty, "feasible": self.scores.feasible}
        if self.score is not None:
            columns["score"] = self.score
        # N is an integer parameter; strokes_to_dicts reports it as int, and so do we.
        columns["stroke"] = {
            name: column.astype(int) if name in _HARMONIC else column.copy()
            for name, column in zip(PARAMETER_NAMES, self.physical.T, strict=True)
        }
        return columns
