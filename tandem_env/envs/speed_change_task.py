"""The batched core of ``TandemWing/SpeedChange-v0``: episode states, observations, one cycle for B envs.

As :mod:`tandem_env.envs.task` is for the one-cycle envs, this is the one implementation the
single env (B = 1), the native vector env (B = n) and the SB3 adapter share: a step evaluates
all B strokes in ONE :func:`tandem_env.evaluate` call, each at its own speed and flight-path
angle, then advances each body by :mod:`tandem_env.envs.dynamics`. The same stroke from the
same state gives bit-identical results whichever front end steps it. Nothing here imports
Gymnasium.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from ..physics import evaluate
from .config import MODEL_SPEED_LIMITS
from .dynamics import advance, cycle_time, flight_path, net_force
from .speed_change_config import SpeedChangeConfig, check_speed_option
from .task import Columns, FlightTask, StepBatch

#: What each observation entry is, in order (each mapped to [-1, 1], see ``observe``).
OBSERVATION_NAMES: tuple[str, ...] = (
    "forward_speed",
    "vertical_speed",
    "altitude",
    "target_speed",
    "cycles_left",
)

#: ``reset(options=...)`` keys: the episode's start and target forward speeds [m/s] (inside
#: ``speed_envelope``) and its start vertical speed [m/s] (default 0).
RESET_OPTIONS: tuple[str, ...] = ("start_speed", "target_speed", "vertical_speed")


@dataclass(frozen=True)
class Flight:
    """The state of B episodes, each field a (B,) array (``cycle`` int64, the rest float64)."""

    forward_speed: np.ndarray
    """u [m/s]."""
    vertical_speed: np.ndarray
    """w [m/s], + up."""
    altitude: np.ndarray
    """h [m], relative to the altitude at reset (the altitude to hold)."""
    distance: np.ndarray
    """Horizontal distance flown since reset [m]."""
    time: np.ndarray
    """Flight time since reset [s]."""
    target_speed: np.ndarray
    """u* [m/s]."""
    cycle: np.ndarray
    """Cycles flown since reset [-]."""

    @classmethod
    def empty(cls, count: int) -> Flight:
        arrays = {f.name: np.zeros(count) for f in fields(cls)}
        arrays["cycle"] = np.zeros(count, dtype=np.int64)
        return cls(**arrays)

    def take(self, index: np.ndarray) -> Flight:
        """The episodes ``index`` (copies)."""
        return Flight(**{f.name: getattr(self, f.name)[index] for f in fields(self)})

    def put(self, index: np.ndarray, other: Flight) -> None:
        """Overwrite episodes ``index`` with ``other`` (in place)."""
        for f in fields(self):
            getattr(self, f.name)[index] = getattr(other, f.name)

    def columns(self) -> Columns:
        """The state as info columns (copies)."""
        return {f.name: getattr(self, f.name).copy() for f in fields(self)}


@dataclass(frozen=True)
class CycleBatch:
    """B wing-beat cycles flown: the model's evaluation, the motion and the reward terms."""

    strokes: StepBatch
    """The evaluated strokes with the model's result and the power penalty (``reward`` there is
    objective − penalty, the env's reward)."""
    after: Flight
    """The state after the cycle."""
    cycle_time: np.ndarray
    force_horizontal: np.ndarray
    force_vertical: np.ndarray
    energy: np.ndarray
    terms: dict[str, np.ndarray]
    """``reward_progress``, ``reward_speed``, ``reward_altitude``, ``reward_energy``,
    ``reward_termination`` (:class:`~tandem_env.envs.speed_change_config.SpeedChangeReward`)."""
    left_altitude_band: np.ndarray
    left_speed_band: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray

    @property
    def reward(self) -> np.ndarray:
        return self.strokes.reward

    def __len__(self) -> int:
        return len(self.strokes)

    def info_columns(self) -> Columns:
        """The model's metrics and stroke (as the one-cycle envs report them) plus the motion."""
        columns = self.strokes.info_columns()
        columns.update(self.after.columns())
        columns.update(
            cycle_time=self.cycle_time,
            force_horizontal=self.force_horizontal,
            force_vertical=self.force_vertical,
            energy=self.energy,
            **self.terms,
            left_altitude_band=self.left_altitude_band,
            left_speed_band=self.left_speed_band,
        )
        return columns


class SpeedChangeTask:
    """Draw episodes, observe them and fly one cycle of B of them (see the module docstring)."""

    option_key = "target_speed"
    """The reset option the training tools set per evaluation env (the target speed)."""

    def __init__(self, config: SpeedChangeConfig) -> None:
        self.config = config
        # Action validation and the normalised -> physical map are the one-cycle envs'.
        self._actions = FlightTask(config)

    # --- episodes --------------------------------------------------------------------------
    def draw(
        self,
        count: int,
        rngs: Callable[[int], np.random.Generator],
        options: Sequence[Mapping[str, Any] | None],
    ) -> Flight:
        """States of ``count`` new episodes: u = u₀, w = w₀ (0), h = 0, target u*.

        Episode k draws from ``rngs(k)`` one ``uniform`` for u₀ and then one for u*, each only
        if it is sampled and not set by ``options[k]``, so every front end consumes the streams
        identically.
        """
        cfg = self.config
        flight = Flight.empty(count)
        for k in range(count):
            given = self._options(options[k])
            values = {}
            for name in ("start_speed", "target_speed"):
                if name in given:
                    values[name] = given[name]
                elif getattr(cfg, name) is not None:
                    values[name] = getattr(cfg, name)
                else:
                    values[name] = rngs(k).uniform(*getattr(cfg, f"{name}_range"))
            flight.forward_speed[k] = values["start_speed"]
            flight.target_speed[k] = values["target_speed"]
            flight.vertical_speed[k] = given.get("vertical_speed", 0.0)
        return flight

    def _options(self, options: Mapping[str, Any] | None) -> dict[str, float]:
        if not options:
            return {}
        if not isinstance(options, Mapping):
            raise ValueError(f"reset options = {options!r}; allowed: None or a dict")
        unknown = sorted(set(options) - set(RESET_OPTIONS))
        if unknown:
            raise ValueError(
                f"{self.config.name}: unknown reset option(s) {unknown}; allowed: "
                f"{', '.join(map(repr, RESET_OPTIONS))}"
            )
        out = {}
        for key in ("start_speed", "target_speed"):
            if key in options:
                out[key] = check_speed_option(self.config, key, options[key])
        if "vertical_speed" in options:
            value = options["vertical_speed"]
            ok = isinstance(value, int | float | np.integer | np.floating) and not isinstance(
                value, bool | np.bool_
            )
            limit = MODEL_SPEED_LIMITS[1] / 2.0
            if not ok or not np.isfinite(value) or abs(value) > limit:
                raise ValueError(
                    f"{self.config.name}: reset option vertical_speed = {value!r}; allowed: a "
                    f"number from {-limit:g} to {limit:g} m/s"
                )
            out["vertical_speed"] = float(value)
        return out

    def observe(self, flight: Flight) -> np.ndarray:
        """(B, 5) float32 observations in [-1, 1] (:data:`OBSERVATION_NAMES`): u over
        ``forward_speed_band``, w / ``vertical_speed_scale``, h / ``altitude_band``, u* over
        ``speed_envelope``, cycles left over (0, ``max_cycles``); clipped to [-1, 1]."""
        cfg = self.config

        def scaled(value: np.ndarray, band: tuple[float, float]) -> np.ndarray:
            return 2.0 * (value - band[0]) / (band[1] - band[0]) - 1.0

        obs = np.stack(
            [
                scaled(flight.forward_speed, cfg.forward_speed_band),
                flight.vertical_speed / cfg.vertical_speed_scale,
                flight.altitude / cfg.altitude_band,
                scaled(flight.target_speed, cfg.speed_envelope),
                scaled((cfg.max_cycles - flight.cycle).astype(np.float64), (0.0, cfg.max_cycles)),
            ],
            axis=1,
        )
        return np.clip(obs, -1.0, 1.0).astype(np.float32)

    def reset_columns(self, flight: Flight) -> Columns:
        """Reset info columns: the start state and the power cap."""
        columns = flight.columns()
        columns["available_power"] = np.full(len(flight.cycle), self.config.available_power)
        return columns

    # --- one cycle -------------------------------------------------------------------------
    def step(self, actions: Any, flight: Flight) -> CycleBatch:
        """Fly one cycle of each episode: ONE batched model call, then Eqs. (1)-(3) of
        :mod:`tandem_env.envs.dynamics` and the reward terms."""
        cfg = self.config
        count = len(flight.cycle)
        physical = self._actions.strokes(actions, count)
        speed, gamma = flight_path(flight.forward_speed, flight.vertical_speed)
        result = evaluate(
            physical,
            speed,
            np.full(count, cfg.available_power),
            flight_path_angle=gamma,
            insect=cfg.insect,
            options=cfg.options,
        )
        dt = cycle_time(physical)
        fx, fz = net_force(result, cfg.insect)
        u, w, x, h = advance(
            flight.forward_speed,
            flight.vertical_speed,
            flight.distance,
            flight.altitude,
            fx,
            fz,
            cfg.insect.body_mass,
            dt,
        )
        after = Flight(
            forward_speed=u,
            vertical_speed=w,
            altitude=h,
            distance=x,
            time=flight.time + dt,
            target_speed=flight.target_speed.copy(),
            cycle=flight.cycle + 1,
        )
        low, high = cfg.forward_speed_band
        left_altitude = np.abs(h) > cfg.altitude_band
        left_speed = (u < low) | (u > high) | (np.hypot(u, w) > MODEL_SPEED_LIMITS[1])
        terminated = left_altitude | left_speed
        truncated = after.cycle >= cfg.max_cycles

        weights = cfg.reward
        energy = result.power * dt
        not_flown = (cfg.max_cycles - after.cycle).astype(np.float64)
        error = np.abs(u - flight.target_speed)
        terms = {
            "reward_progress": weights.progress
            * (np.abs(flight.forward_speed - flight.target_speed) - error),
            "reward_speed": -weights.speed * error * dt,
            "reward_altitude": -weights.altitude * np.abs(h) * dt,
            "reward_energy": -weights.energy * energy,
            "reward_termination": np.where(terminated, -weights.termination * not_flown, 0.0),
        }
        objective = (
            terms["reward_progress"]
            + terms["reward_speed"]
            + terms["reward_altitude"]
            + terms["reward_energy"]
            + terms["reward_termination"]
        )
        # The power cap as in level flight: the excess as a fraction of the cap, penalised per
        # cycle by the env's PenaltyConfig (exactly 0 within the cap).
        violation = result.power_violation / result.available_power
        feasible = result.power_violation == 0.0
        strokes = StepBatch.scored(physical, result, objective, violation, feasible, cfg.penalty)
        return CycleBatch(
            strokes=strokes,
            after=after,
            cycle_time=dt,
            force_horizontal=fx,
            force_vertical=fz,
            energy=energy,
            terms=terms,
            left_altitude_band=left_altitude,
            left_speed_band=left_speed,
            terminated=terminated,
            truncated=truncated,
        )
