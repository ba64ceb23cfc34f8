"""B evaluated strokes of a task, scored, before they are split per env (:class:`StepBatch`), and
their info columns: name -> (B,) array (or a nested dict of columns, ``"stroke"``) for B envs,
split into per-env dicts or Gymnasium's masked dict of arrays without a loop per metric.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..physics import PARAMETER_NAMES, Result
from .declaration import Scores

Columns = dict[str, Any]
"""Info columns: name -> (B,) array, or a nested dict of columns (``"stroke"``)."""


def row(columns: Columns, index: int) -> dict[str, Any]:
    """One env's info dict: plain Python floats, bools and ints (nested dicts stay dicts)."""
    return {
        k: row(v, index) if isinstance(v, dict) else v[index].item() for k, v in columns.items()
    }


def take_columns(columns: Columns, index: np.ndarray) -> Columns:
    """The rows ``index`` of info columns (nested dicts too)."""
    return {
        k: take_columns(v, index) if isinstance(v, dict) else v[index] for k, v in columns.items()
    }


def rows(columns: Columns, count: int) -> list[dict[str, Any]]:
    """All ``count`` info dicts at once (``tolist`` per column, not per value)."""
    lists = [rows(v, count) if isinstance(v, dict) else v.tolist() for v in columns.values()]
    if not lists:
        return [{} for _ in range(count)]
    return [dict(zip(columns, values, strict=True)) for values in zip(*lists, strict=True)]


def add_columns(
    infos: dict[str, Any], columns: Columns, index: np.ndarray, num_envs: int
) -> dict[str, Any]:
    """Scatter columns for envs ``index`` into Gymnasium's vector info dict with ``_key``
    masks, as ``VectorEnv._add_info`` env by env would (so infos equal SyncVectorEnv's)."""
    for key, values in columns.items():
        if isinstance(values, dict):
            array = add_columns(infos.get(key, {}), values, index, num_envs)
        else:
            array = infos.get(key)
            array = np.zeros(num_envs, dtype=values.dtype) if array is None else array
            array[index] = values
        mask = infos.get(f"_{key}")
        mask = np.zeros(num_envs, dtype=np.bool_) if mask is None else mask
        mask[index] = True
        infos[key], infos[f"_{key}"] = array, mask
    return infos


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
    score: np.ndarray | None = None
    """(B,) the normalised score [-] (:mod:`tandem_env.envs.reference`); None where the
    reference table does not describe the env."""
    reward: np.ndarray = field(init=False)
    """(B,) objective − penalty."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "reward", self.objective - self.penalty)

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
