"""``TandemWing/SpeedChange-v0``: change speed and hold altitude over many wing-beats.

The core (one cycle of B episodes: ONE model call, then the dynamics below), the vector env and
the single env; declaration and config: :mod:`~tandem_env.envs.speed_change_config`.

The dynamics: cycle-averaged longitudinal point-mass dynamics of the insect.

Earth axes: x forward (horizontal), z up. The body is a point of mass m moving with forward speed
u and vertical speed w; its speed along the flight path is V = sqrt(u² + w²) and its flight-path
angle γ = atan2(w, u) (+ climbing). Over one wing-beat cycle of duration Δt the net force

    F = F_wings + D_body + W,                                                   (1)
    F_wings = (Σ F̄_x, Σ F̄_z)   the wings' cycle-mean forces in earth axes at (V, γ),
    D_body  = −½·ρ·V²·(C_D·S)_body · (cos γ, sin γ)   parasite drag, against the velocity,
    W       = (0, −m·g),

is held constant (the quasi-steady model gives cycle means only), and the state is advanced
exactly for a constant force (a zero-order hold on the force, i.e. explicit Euler in velocity)::

    u' = u + F_x/m·Δt,            w' = w + F_z/m·Δt,                             (2)
    x' = x + u·Δt + ½·F_x/m·Δt²,  h' = h + w·Δt + ½·F_z/m·Δt².                   (3)

The scheme is first order in Δt in how the force follows the velocity (evaluated at the cycle's
start) and exact for the motion under it; Eq. (3) is the trapezoidal rule on the velocity,
h' − h = ½(w + w')·Δt.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from gymnasium import spaces
from gymnasium.vector import VectorEnv

from ..physics import PARAMETER_NAMES, SPEED_LIMITS, Dragonfly, Result
from .base import EnvGenerators, EnvOptions, FlightEnv, FlightVectorEnv, fly
from .config import reset_options
from .render import Frame, history_of
from .speed_change_config import MAX_BAND_SPEED, SPEED_CHANGE, SpeedChangeConfig
from .step_batch import Columns, StepBatch, row

_FORE_FREQUENCY = PARAMETER_NAMES.index("fore_frequency")
_HIND_FREQUENCY = PARAMETER_NAMES.index("hind_frequency")


def flight_path(
    forward_speed: np.ndarray, vertical_speed: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(V [m/s], γ [rad]) of velocities (u, w) [m/s]: V = sqrt(u² + w²), γ = atan2(w, u)."""
    return np.hypot(forward_speed, vertical_speed), np.arctan2(vertical_speed, forward_speed)


def cycle_time(physical: np.ndarray) -> np.ndarray:
    """Duration of one step Δt = max(1/f_fore, 1/f_hind) [s] of physical strokes (B, 28).

    Each wing pair beats at its own frequency and the model's forces and powers are each pair's
    mean over its own cycle. The step lasts the longer of the two periods, so that both pairs
    complete at least one whole beat within it: the slower pair's mean is then never applied
    over a fraction of its beat, where its forces would be far from their mean.
    """
    return 1.0 / np.minimum(physical[:, _FORE_FREQUENCY], physical[:, _HIND_FREQUENCY])


def body_drag(speed: np.ndarray, insect: Dragonfly) -> np.ndarray:
    """Body parasite drag D_b = ½·ρ·V²·(C_D·S)_body [N] at speed V [m/s] (docs/model.md §1.5)."""
    return 0.5 * insect.air_density * speed**2 * insect.body_drag_area


def net_force(result: Result, insect: Dragonfly) -> tuple[np.ndarray, np.ndarray]:
    """Net force (F_x, F_z) [N] of Eq. (1) in earth axes, for strokes evaluated at
    ``result.speed`` and ``result.flight_path_angle``.

    The wing forces are the per-pair fields (``fore/hind_horizontal_force`` and
    ``fore/hind_lift_to_weight``), which do not depend on ``thrust_split``; with
    ``thrust_split="body"`` the result equals (F̄_h·W, F̄_v·W) exactly in exact arithmetic.
    """
    weight, gamma = insect.weight, result.flight_path_angle
    drag = body_drag(result.speed, insect)
    fx = result.fore_horizontal_force + result.hind_horizontal_force - drag * np.cos(gamma)
    lift = (result.fore_lift_to_weight + result.hind_lift_to_weight) * weight
    fz = lift - drag * np.sin(gamma) - weight
    return fx, fz


def advance(
    forward_speed: np.ndarray,
    vertical_speed: np.ndarray,
    distance: np.ndarray,
    altitude: np.ndarray,
    force_x: np.ndarray,
    force_z: np.ndarray,
    mass: float,
    dt: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Eqs. (2)-(3): (u', w', x', h') after Δt [s] under the constant force (F_x, F_z) [N];
    velocities in m/s, positions in m, mass in kg; every array (B,)."""
    ax, az = force_x / mass, force_z / mass
    return (
        forward_speed + ax * dt,
        vertical_speed + az * dt,
        distance + forward_speed * dt + 0.5 * ax * dt * dt,
        altitude + vertical_speed * dt + 0.5 * az * dt * dt,
    )


#: What each observation entry is, in order (each mapped to [-1, 1], see ``observe``).
OBSERVATION_NAMES = ("forward_speed", "vertical_speed", "altitude", "target_speed", "cycles_left")


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

    def __getitem__(self, index: np.ndarray) -> Flight:
        """The episodes ``index`` (copies)."""
        return Flight(**{f.name: getattr(self, f.name)[index] for f in fields(self)})

    def __setitem__(self, index: np.ndarray, other: Flight) -> None:
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
    motion: Columns
    """(B,) ``cycle_time`` [s], net ``force_horizontal`` / ``force_vertical`` [N], ``energy``
    [J], the reward terms and the flags ``left_altitude_band``, ``left_speed_band``."""
    terminated: np.ndarray
    truncated: np.ndarray

    @property
    def reward(self) -> np.ndarray:
        return self.strokes.reward

    def __len__(self) -> int:
        return len(self.strokes)

    def info_columns(self) -> Columns:
        """The model's metrics and stroke (as the one-cycle envs report them) plus the motion."""
        return {**self.strokes.info_columns(), **self.after.columns(), **self.motion}


class SpeedChangeCore:
    """Draw episodes, observe them and fly one cycle of B of them (see the module docstring)."""

    option_key = "target_speed"
    """The reset option the training tools set per evaluation env (the target speed)."""

    def __init__(self, config: SpeedChangeConfig) -> None:
        self.config = config

    # --- episodes --------------------------------------------------------------------------
    def draw(self, count: int, rngs: EnvGenerators, options: EnvOptions) -> Flight:
        """States of ``count`` new episodes: u = u₀, w = w₀ (0), h = 0, target u*; episode k
        draws u₀, then u*, from ``rngs(k)`` where sampled and not set by ``options[k]``."""
        cfg = self.config
        low, high = cfg.speed_envelope
        ranges = {  # key -> (low, high, unit, what the range is)
            "start_speed": (low, high, "m/s", "the speed envelope"),
            "target_speed": (low, high, "m/s", "the speed envelope"),
            "vertical_speed": (-MAX_BAND_SPEED, MAX_BAND_SPEED, "m/s", "the range"),
        }
        flight = Flight.empty(count)
        for k in range(count):
            given = reset_options(cfg.name, options[k], ranges, {})
            for name, state in (("start_speed", "forward_speed"), ("target_speed", "target_speed")):
                value = given.get(name, getattr(cfg, name))  # None: sampled
                if value is None:
                    value = rngs(k).uniform(*getattr(cfg, f"{name}_range"))
                getattr(flight, state)[k] = value
            # Within ±MAX_BAND_SPEED (checked above), as u is within the band.
            flight.vertical_speed[k] = given.get("vertical_speed", 0.0)
        return flight

    def observe(self, flight: Flight) -> np.ndarray:
        """(B, 5) float32 observations (:data:`OBSERVATION_NAMES`), clipped to [-1, 1]: u over
        ``forward_speed_band``, w / ``vertical_speed_scale``, h / ``altitude_band``, u* over
        ``speed_envelope``, cycles left over (0, ``max_cycles``)."""
        cfg = self.config

        def scaled(value: np.ndarray, band: tuple[float, float]) -> np.ndarray:
            return 2.0 * (value - band[0]) / (band[1] - band[0]) - 1.0

        columns = [
            scaled(flight.forward_speed, cfg.forward_speed_band),
            flight.vertical_speed / cfg.vertical_speed_scale,
            flight.altitude / cfg.altitude_band,
            scaled(flight.target_speed, cfg.speed_envelope),
            scaled((cfg.max_cycles - flight.cycle).astype(np.float64), (0.0, cfg.max_cycles)),
        ]
        return np.clip(np.stack(columns, axis=1), -1.0, 1.0).astype(np.float32)

    def reset_columns(self, flight: Flight) -> Columns:
        """Reset info columns: the start state and the power cap."""
        power = np.full(len(flight.cycle), self.config.available_power)
        return {**flight.columns(), "available_power": power}

    # --- one cycle -------------------------------------------------------------------------
    def step(self, physical: np.ndarray, flight: Flight) -> CycleBatch:
        """Fly one cycle of each episode from its (validated, physical) stroke: ONE batched
        model call, then Eqs. (1)-(3) (the module docstring) and the reward terms."""
        cfg = self.config
        speed, gamma = flight_path(flight.forward_speed, flight.vertical_speed)
        result = fly(cfg, physical, speed, np.full(len(flight.cycle), cfg.available_power), gamma)
        dt = cycle_time(physical)
        fx, fz = net_force(result, cfg.insect)
        before = (flight.forward_speed, flight.vertical_speed, flight.distance, flight.altitude)
        u, w, x, h = advance(*before, fx, fz, cfg.insect.body_mass, dt)
        # the state after: u, w, h, x, the time, the same target u* and the cycle count
        after = Flight(u, w, h, x, flight.time + dt, flight.target_speed.copy(), flight.cycle + 1)
        low, high = cfg.forward_speed_band
        left_altitude = np.abs(h) > cfg.altitude_band
        left_speed = (u < low) | (u > high) | (np.hypot(u, w) > SPEED_LIMITS[1])
        terminated = left_altitude | left_speed
        truncated = after.cycle >= cfg.max_cycles

        weights = cfg.reward
        energy = result.power * dt
        not_flown = (cfg.max_cycles - after.cycle).astype(np.float64)
        error = np.abs(u - flight.target_speed)
        removed = np.abs(flight.forward_speed - flight.target_speed) - error
        terms = {
            "reward_progress": weights.progress * removed,
            "reward_speed": -weights.speed * error * dt,
            "reward_altitude": -weights.altitude * np.abs(h) * dt,
            "reward_energy": -weights.energy * energy,
            "reward_termination": np.where(terminated, -weights.termination * not_flown, 0.0),
        }
        objective = sum(terms.values())
        # every flight task's limits, penalised per cycle by the env's PenaltyConfig (0 within)
        scores = SPEED_CHANGE.score(result, cfg)
        motion = {"cycle_time": dt, "force_horizontal": fx, "force_vertical": fz, "energy": energy}
        motion |= {**terms, "left_altitude_band": left_altitude, "left_speed_band": left_speed}
        penalty = cfg.penalty.penalty(scores.total, scores.feasible)
        strokes = StepBatch(physical, result, objective, scores, penalty)
        return CycleBatch(strokes, after, motion, terminated, truncated)


# VectorEnv among the direct bases too: skrl tells a vector env by its class's direct bases.
class SpeedChangeVectorEnv(FlightVectorEnv, VectorEnv):
    """n :class:`SpeedChangeEnv` in one batched model call per step (as ``FlightVectorEnv``)."""

    config_class = SpeedChangeConfig
    core_class = SpeedChangeCore
    config: SpeedChangeConfig
    core: SpeedChangeCore

    @property
    def conditions(self) -> np.ndarray:
        """(n,) target speed of each sub-env's episode [m/s]."""
        return self._state.target_speed.copy()

    @property
    def flight(self) -> Flight:
        """The state of every sub-env's episode (a copy)."""
        return self._state[np.arange(self.num_envs)]

    def _observation_space(self) -> spaces.Box:
        """Box(-1, 1, (5,), float32): u, w, h, u*, cycles left, each normalised (see the env)."""
        return spaces.Box(-1.0, 1.0, (len(OBSERVATION_NAMES),), dtype=np.float32)

    def _init_episodes(self, n: int) -> None:
        self._state = Flight.empty(n)

    def _fly(self, index: np.ndarray, physical: np.ndarray) -> tuple[CycleBatch, np.ndarray]:
        """Fly one cycle of sub-envs ``index`` in one model call; (batch, observations)."""
        batch = self.core.step(physical, self._state[index])
        self._state[index] = batch.after
        observations = self.core.observe(batch.after)
        self._observations[index] = observations
        return batch, observations

    def frame(self, i: int, title: str) -> Frame:
        """The render frame of sub-env ``i``: its state, its last cycle's forces and power."""
        cfg, last = self.config, self._last[i]
        if not self._started[i]:
            return Frame(title=f"{title}  {cfg.describe()}", subtitle="not reset yet", history=None)
        state = row(self._state.columns(), i)
        heading = (
            f"{title}  u = {state['forward_speed']:.3g} m/s -> u* = {state['target_speed']:.3g} "
            f"m/s, h = {state['altitude']:+.3g} m, cycle {state['cycle']}/{cfg.max_cycles}"
        )
        if last is None:
            return Frame(title=heading, subtitle="no cycle flown since reset", history=None)
        batch, k = last.batch, last.index
        result, motion = batch.strokes.result, row(batch.motion, k)
        subtitle = (
            f"reward {float(batch.reward[k]):.4g} | F_x {motion['force_horizontal'] * 1e3:+.3f} "
            f"mN | F_z {motion['force_vertical'] * 1e3:+.3f} mN | P/m "
            f"{float(result.power_per_mass[k]):.1f} W/kg | Δt {motion['cycle_time'] * 1e3:.1f} ms"
        )
        return Frame(heading, subtitle, history_of(batch.strokes, k, cfg.insect, cfg.options))


class SpeedChangeEnv(FlightEnv):
    """Change forward speed and hold altitude over many wing-beats of the tandem-wing dragonfly.

    Each step evaluates one wing-beat cycle of the stroke at the body's velocity (V =
    sqrt(u² + w²) along γ = atan2(w, u)), then moves the body as a point mass for one cycle
    (Eqs. (1)-(3), the module docstring). The task: reach the target forward speed u*, hold the
    start altitude and spend little energy within the power cap (90 W/kg); a policy can
    accelerate hard, then settle, as no fixed stroke can (docs/envs.md, "SpeedChange").

    * Action: the next cycle's normalised stroke, as in ``TandemWing/LevelFlight-v0``.
    * Observation: ``Box(-1, 1, (5,), float32)``, :data:`OBSERVATION_NAMES` each mapped to
      [-1, 1] (:meth:`SpeedChangeCore.observe`).
    * Reward: the weighted terms of :class:`~tandem_env.envs.speed_change_config.SpeedChangeReward`
      less the power cap's penalty, ``penalty_weight``·max(0, P/m − 90)/90 per cycle.
    * Start: u = u₀, w = 0, h = 0; u₀ and u* fixed (``start_speed``, ``target_speed``) or drawn
      from ``start_speed_range`` / ``target_speed_range`` (default 0.25-2.0 m/s);
      ``reset(options={"start_speed": .., "target_speed": .., "vertical_speed": ..})`` sets them
      for one episode.
    * End: terminates when |h| > ``altitude_band`` or u leaves ``forward_speed_band``; truncates
      after ``max_cycles``. ``info`` holds the state after the cycle, its motion and reward
      terms (:class:`CycleBatch`) and the model's ``Result`` for the stroke.
    * Keywords: :class:`~tandem_env.envs.speed_change_config.SpeedChangeConfig`'s fields and every
      model, penalty and action option of the other envs (``thrust_split`` defaults to
      ``"body"`` here); invalid values raise ``ValueError``. v0: initial version.
    """

    vector_class = SpeedChangeVectorEnv
    vector_env: SpeedChangeVectorEnv
    config: SpeedChangeConfig

    @property
    def flight(self) -> Flight | None:
        """The current episode's state (B = 1 arrays), or None before the first reset."""
        return self.vector_env.flight if self.vector_env.started[0] else None
