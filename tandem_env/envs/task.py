"""The batched core every front end shares: conditions, observations, rewards and infos for B strokes.

The single env is this core at B = 1, the native vector env at B = num_envs, and the SB3
adapter reuses the vector env's core, so the three cannot drift apart: the same stroke in the
same condition gives bit-identical rewards and infos whichever front end evaluates it (the
model itself is bit-identical per stroke at any batch size). Nothing here imports Gymnasium.

Infos are built as *columns* (name -> (B,) array, ``"stroke"`` a nested dict of columns) and
turned into per-env dicts (single env, SB3) or Gymnasium's masked dict of arrays (vector env)
by the helpers at the bottom, without a Python loop over metrics per env.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..physics import (
    N_PARAMETERS,
    PARAMETER_NAMES,
    Result,
    evaluate,
    normalised_to_physical,
)
from ..physics.checks import is_real, real_array
from .config import AccelerateConfig, FlightConfig, LevelFlightConfig, PenaltyConfig

Columns = dict[str, Any]
"""Info columns: name -> (B,) array, or a nested dict of columns (``"stroke"``)."""

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
    violation: np.ndarray
    """(B,) sum of normalised constraint violations [-] (0 when feasible)."""
    penalty: np.ndarray
    """(B,) reward lost to the constraints [reward units] (exactly 0 when feasible)."""
    reward: np.ndarray
    """(B,) objective − penalty."""
    feasible: np.ndarray
    """(B,) bool, every constraint of the task met."""

    @classmethod
    def scored(
        cls,
        physical: np.ndarray,
        result: Result,
        objective: np.ndarray,
        violation: np.ndarray,
        feasible: np.ndarray,
        penalty: PenaltyConfig,
    ) -> StepBatch:
        """The batch of a task's objective, violation and feasibility, its reward penalised
        by the env's ``penalty`` (exactly the objective where feasible)."""
        lost = penalty.penalty(violation, feasible)
        return cls(
            physical=physical,
            result=result,
            objective=objective,
            violation=violation,
            penalty=lost,
            reward=objective - lost,
            feasible=feasible,
        )

    def __len__(self) -> int:
        return int(self.reward.shape[0])

    @property
    def terminated(self) -> np.ndarray:
        """(B,) bool, all True: a one-cycle episode ends with its stroke."""
        return np.ones(len(self), dtype=np.bool_)

    @property
    def truncated(self) -> np.ndarray:
        """(B,) bool, all False: a one-cycle episode is never cut short."""
        return np.zeros(len(self), dtype=np.bool_)

    def info_columns(self) -> Columns:
        """Every metric of the model plus the task's reward terms and the named stroke."""
        columns: Columns = {}
        for name, values in self.result.as_dict().items():
            columns[name] = (
                values if values.dtype == bool else values.astype(np.float64, copy=False)
            )
        columns["objective"] = self.objective
        columns["constraint_violation"] = self.violation
        columns["penalty"] = self.penalty
        columns["feasible"] = self.feasible
        stroke: Columns = {}
        for j, name in enumerate(PARAMETER_NAMES):
            column = self.physical[:, j]
            # N is an integer parameter; strokes_to_dicts reports it as int, and so do we.
            stroke[name] = column.astype(int) if name in _HARMONIC else column.copy()
        columns["stroke"] = stroke
        return columns


class FlightTask:
    """Task logic over a batch: draw conditions, observe them, score strokes.

    The condition's reset option and the objective's metric come from the config's declarations
    (``CONDITION``, ``OBJECTIVES``); subclasses define how the condition enters the model, the
    normalised violation and the feasibility flag.
    """

    config: FlightConfig

    def __init__(self, config: FlightConfig) -> None:
        self.config = config
        self._low, self._high = config.envelope

    # --- conditions ----------------------------------------------------------------------------
    @property
    def option_key(self) -> str:
        """The ``reset(options=...)`` key that sets the condition for one episode."""
        return self.config.declared_condition.reset_option

    def draw_conditions(
        self,
        count: int,
        rngs: Callable[[int], np.random.Generator],
        options: Sequence[Mapping[str, Any] | None],
    ) -> np.ndarray:
        """Conditions for ``count`` episodes starting now, (count,) float64.

        ``rngs(k)`` gives episode k's generator (created lazily, as ``Env.np_random`` is);
        ``options[k]`` its reset options. A sampled condition draws exactly one
        ``uniform(low, high)`` from that generator; a fixed or overridden one draws nothing,
        so the single env, the vector env and SyncVectorEnv consume the streams identically.
        """
        values = np.empty(count)
        cfg = self.config
        for k in range(count):
            override = self._override(options[k])
            if override is not None:
                values[k] = override
            elif cfg.condition_range is None:
                values[k] = cfg.fixed_condition
            else:
                values[k] = rngs(k).uniform(*cfg.condition_range)
        return values

    def _override(self, options: Mapping[str, Any] | None) -> float | None:
        if not options:
            return None
        if not isinstance(options, Mapping):
            raise ValueError(f"reset options = {options!r}; allowed: None or a dict")
        unknown = sorted(set(options) - {self.option_key})
        if unknown:
            raise ValueError(
                f"{self.config.name}: unknown reset option(s) {unknown}; allowed: "
                f"{self.option_key!r} (sets the condition of this episode)"
            )
        value = options[self.option_key]
        low, high = self._low, self._high
        if not is_real(value) or not np.isfinite(value) or not low <= value <= high:
            raise ValueError(
                f"{self.config.name}: reset option {self.option_key} = {value!r}; allowed: a "
                f"number in the observation envelope {low:g} to {high:g}"
            )
        return float(value)

    def observe(self, values: np.ndarray) -> np.ndarray:
        """(B, 1) float32 observations: each condition mapped from the envelope to [-1, 1]."""
        scaled = 2.0 * (np.asarray(values, dtype=np.float64) - self._low) / (self._high - self._low)
        return np.clip(scaled - 1.0, -1.0, 1.0).astype(np.float32)[:, None]

    def flight_conditions(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(speed [m/s], available power [W/kg]) arrays (B,) for conditions ``values``."""
        raise NotImplementedError

    def reset_columns(self, values: np.ndarray) -> Columns:
        """Reset info columns: the flight condition of each new episode."""
        speed, power = self.flight_conditions(values)
        return {"speed": speed, "available_power": power}

    # --- strokes ---------------------------------------------------------------------------------
    def strokes(self, actions: Any, count: int) -> np.ndarray:
        """Validated (count, 28) physical strokes from normalised actions (count, 28)."""
        arr = real_array(
            actions, "actions", f"real numbers in [-1, 1] of shape ({count}, {N_PARAMETERS})"
        )
        if arr.shape != (count, N_PARAMETERS):
            raise ValueError(
                f"actions must have shape ({count}, {N_PARAMETERS}) here (one action of 28 "
                f"normalised parameters per env); got shape {arr.shape}"
            )
        finite = np.isfinite(arr)
        if not finite.all():
            row, col = np.argwhere(~finite)[0]
            raise ValueError(
                f"action {row}: {PARAMETER_NAMES[col]} = {arr[row, col]!r} is not finite; "
                "allowed: finite numbers in [-1, 1]"
            )
        if self.config.clip_actions:
            arr = np.clip(arr, -1.0, 1.0)
        elif np.any(np.abs(arr) > 1.0):
            row, col = np.argwhere(np.abs(arr) > 1.0)[0]
            raise ValueError(
                f"action {row}: {PARAMETER_NAMES[col]} = {arr[row, col]:g} is outside the action "
                "space; allowed: [-1, 1] (make the env with clip_actions=True to clip instead)"
            )
        return normalised_to_physical(arr)

    def step(self, actions: Any, values: np.ndarray) -> StepBatch:
        """Evaluate one wing-beat of each stroke in its condition, in ONE batched model call."""
        values = np.asarray(values, dtype=np.float64)
        physical = self.strokes(actions, values.shape[0])
        speed, power = self.flight_conditions(values)
        result = evaluate(
            physical, speed, power, insect=self.config.insect, options=self.config.options
        )
        return StepBatch.scored(
            physical,
            result,
            self.objective(result),
            self.violation(result),
            self.feasible(result),
            self.config.penalty,
        )

    def objective(self, result: Result) -> np.ndarray:
        """(B,) the declared objective's metric of each stroke [-]."""
        return getattr(result, self.config.objective_metric)

    def violation(self, result: Result) -> np.ndarray:
        raise NotImplementedError

    def feasible(self, result: Result) -> np.ndarray:
        raise NotImplementedError


class LevelFlightTask(FlightTask):
    """η = T·V/P with L = W, T = D (within ``constraint_tolerance``·W) and P/m <= 90 W/kg."""

    config: LevelFlightConfig

    def flight_conditions(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return values.copy(), np.full(values.shape, self.config.available_power)

    def violation(self, result: Result) -> np.ndarray:
        # Forces are already fractions of W; the power excess becomes a fraction of the cap, so
        # the three terms share one scale (a 10 % miss costs the same whichever constraint).
        return (
            result.lift_violation
            + result.thrust_violation
            + result.power_violation / result.available_power
        )

    def feasible(self, result: Result) -> np.ndarray:
        return result.level_feasible


class AccelerateTask(FlightTask):
    """F̄_v, F̄_h or F̄_a with F̄_v >= 0, F̄_h >= 0 and P/m <= the available power."""

    config: AccelerateConfig

    def flight_conditions(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.full(values.shape, self.config.speed), values.copy()

    def violation(self, result: Result) -> np.ndarray:
        return (
            result.vertical_deficit
            + result.horizontal_deficit
            + result.power_violation / result.available_power
        )

    def feasible(self, result: Result) -> np.ndarray:
        return result.accelerate_feasible


def make_task(config: FlightConfig) -> FlightTask:
    """The task for a config."""
    if isinstance(config, LevelFlightConfig):
        return LevelFlightTask(config)
    if isinstance(config, AccelerateConfig):
        return AccelerateTask(config)
    raise ValueError(f"no task for config {type(config).__name__}")


# --- columns -> per-env dicts / Gymnasium vector infos -------------------------------------------
def row(columns: Columns, index: int) -> dict[str, Any]:
    """One env's info dict: plain Python floats, bools and ints (nested dicts stay dicts)."""
    return {
        key: row(value, index) if isinstance(value, dict) else value[index].item()
        for key, value in columns.items()
    }


def take_columns(columns: Columns, index: np.ndarray) -> Columns:
    """The rows ``index`` of info columns (nested dicts too)."""
    return {
        key: take_columns(value, index) if isinstance(value, dict) else value[index]
        for key, value in columns.items()
    }


def rows(columns: Columns, count: int) -> list[dict[str, Any]]:
    """All ``count`` info dicts at once (``tolist`` per column, not per value)."""
    keys = list(columns)
    lists = [
        rows(columns[key], count) if isinstance(columns[key], dict) else columns[key].tolist()
        for key in keys
    ]
    if not keys:
        return [{} for _ in range(count)]
    return [dict(zip(keys, values, strict=True)) for values in zip(*lists, strict=True)]


def add_columns(
    infos: dict[str, Any], columns: Columns, index: np.ndarray, num_envs: int
) -> dict[str, Any]:
    """Scatter columns for envs ``index`` into Gymnasium's vector info dict, with ``_key`` masks.

    Reproduces ``VectorEnv._add_info`` applied env by env (same keys, dtypes and masks), so
    the native vector env's infos equal SyncVectorEnv's.
    """
    for key, values in columns.items():
        if isinstance(values, dict):
            array = add_columns(infos.get(key, {}), values, index, num_envs)
        else:
            array = infos.get(key)
            if array is None:
                array = np.zeros(num_envs, dtype=values.dtype)
            array[index] = values
        mask = infos.get(f"_{key}")
        if mask is None:
            mask = np.zeros(num_envs, dtype=np.bool_)
        mask[index] = True
        infos[key], infos[f"_{key}"] = array, mask
    return infos
