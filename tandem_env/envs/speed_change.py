"""``TandemWing/SpeedChange-v0``: change speed and hold altitude over many wing-beats.

The task in one place: its declaration (:data:`SPEED_CHANGE`: the power cap of level flight),
its config and reward weights, its batched core (episode states, observations, one cycle for B
envs: ONE :func:`tandem_env.evaluate` call, each stroke at its own speed and flight-path angle,
then each body advanced by :mod:`tandem_env.envs.dynamics`), the vector env and the single env
(the vector env at B = 1, :mod:`tandem_env.envs.base`). One step is one wing-beat cycle chosen
from the current state; the episode lasts up to ``max_cycles`` cycles.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from ..physics import SPEED_LIMITS, ModelOptions, stroke_history
from ..physics.checks import shown
from .base import (
    Columns,
    EnvGenerators,
    EnvOptions,
    FlightEnv,
    FlightVectorEnv,
    LastStep,
    StepBatch,
    fly,
    row,
)
from .config import FlightConfig
from .declaration import POWER_CAP, TaskDeclaration
from .dynamics import advance, cycle_time, flight_path, net_force
from .level_flight import LEVEL_FLIGHT
from .validate import check_count, check_interval, check_real, option_value, reset_options

#: Speeds the episode's start and target are drawn from by default [m/s]: the level-flight
#: envelope (``LEVEL_FLIGHT.condition.envelope``), where a steady level stroke exists.
LEVEL_FLIGHT_ENVELOPE: tuple[float, float] = LEVEL_FLIGHT.condition.envelope  # type: ignore[union-attr]
#: Most cycles an episode may last [-] (about 4.5 h of flight at 30 Hz): the cycle counters
#: are int64 and the observation divides by it.
MAX_CYCLES = 500_000

#: Fastest forward (and vertical) speed a SpeedChange episode may reach [m/s]: the top of the
#: default ``forward_speed_band``. One step holds the wings' cycle-mean force, evaluated at the
#: cycle's start, over the whole cycle (a zero-order hold, explicit in the velocity). The force
#: grows with V, and above this speed that step is no longer resolved: at 4 m/s some strokes
#: already reverse the flight in one cycle, and at 19.9 m/s most do (19.9 -> -29 m/s). So the
#: config refuses a band beyond it rather than report such steps as ordinary ones.
MAX_BAND_SPEED: float = 3.0

SPEED_CHANGE = TaskDeclaration(
    name="SpeedChange",
    summary="Multi-cycle flight: reach a target speed and hold altitude, one stroke per wing-beat.",
    # No single condition: two speeds (start and target) share one envelope (speed_envelope),
    # a range defaults to the whole envelope, and the harness does not run multi-cycle episodes.
    constraints=(POWER_CAP,),
)


@dataclass(frozen=True)
class SpeedChangeReward:
    """Weights of the reward's terms, each with the unit given.

    Per cycle k of duration Δt_k [s], with u, h the state before and u', h' after the cycle and
    u* the target speed::

        reward_progress    = progress    · (|u − u*| − |u' − u*|)     speed error removed [m/s]
        reward_speed       = −speed      · |u' − u*| · Δt              speed error × time [m]
        reward_altitude    = −altitude   · |h'| · Δt                   altitude error × time [m·s]
        reward_energy      = −energy     · P · Δt                      energy spent [J]
        reward_termination = −termination · (cycles not flown)         only when terminated

    Progress credits each stroke at once with the speed it gained towards u* (and charges
    overshoot); over an episode it sums to the initial minus the final speed error. The speed,
    altitude and energy terms are time integrals, so reaching u* sooner, holding altitude and
    flying efficiently all pay. A weight of 0 switches a term off.
    """

    progress: float = 1.0
    """Per m/s of speed error removed [1/(m/s)]."""
    speed: float = 1.0
    """Per metre of speed error × time [1/m] (1 (m/s)·s of error costs 1)."""
    altitude: float = 2.0
    """Per metre-second of altitude error [1/(m·s)]."""
    energy: float = 50.0
    """Per joule spent by the wings [1/J]: level flight at 40 W/kg for 1.3 s costs about 0.3."""
    termination: float = 0.2
    """Per cycle not flown when the episode terminates early [reward units per cycle]. With the
    default weights the speed, altitude and energy terms of a cycle inside the default bands
    cost at most (2.75 m/s · 1 + 0.5 m · 2 + 90 W/kg · 121.9 mg · 50)/30 Hz ≈ 0.14 (power within
    the cap; :meth:`SpeedChangeConfig.max_cycle_cost`), so leaving the bands early does not
    pay (progress sums to at most the speed error over any stretch of flight)."""

    TERMS: ClassVar[tuple[str, ...]] = ("progress", "speed", "altitude", "energy", "termination")
    UNITS: ClassVar[dict[str, str]] = {
        "progress": "1/(m/s)",
        "speed": "1/m",
        "altitude": "1/(m·s)",
        "energy": "1/J",
        "termination": "per cycle not flown",
    }

    def __post_init__(self) -> None:
        for name in self.TERMS:
            value = check_real(
                "SpeedChangeReward", name, getattr(self, name), f"[{self.UNITS[name]}]", 0.0, 1e9
            )
            object.__setattr__(self, name, value)

    @classmethod
    def build(cls, value: Any) -> SpeedChangeReward:
        """A reward from a ``SpeedChangeReward``, a mapping of some terms to weights, or None."""
        if value is None:
            return cls()
        if isinstance(value, cls):
            return value
        if isinstance(value, Mapping):
            unknown = sorted(set(value) - set(cls.TERMS))
            if unknown:
                raise ValueError(
                    f"SpeedChange: unknown reward term(s) {', '.join(map(repr, unknown))}; "
                    f"allowed: {', '.join(cls.TERMS)} (weights >= 0)"
                )
            return cls(**value)
        raise ValueError(
            f"SpeedChange: reward = {value!r}; allowed: a SpeedChangeReward or a dict of weights "
            f"for the terms {', '.join(cls.TERMS)}"
        )


def _inside(
    owner: str, name: str, value: float, envelope_name: str, envelope: tuple[float, float]
) -> None:
    if not envelope[0] <= value <= envelope[1]:
        raise ValueError(
            f"{owner}.{name} = {shown(value, *envelope)} m/s; allowed: a speed inside "
            f"{owner}.{envelope_name} = "
            f"({envelope[0]:g}, {envelope[1]:g}) m/s (for other speeds widen {envelope_name})"
        )


def _speed_option(owner: str, config: Any, name: str, envelope: tuple[float, float]) -> None:
    """A fixed ``{name}`` or a sampled ``{name}_range`` inside the envelope (default: all of it)."""
    fixed, sampled = getattr(config, name), getattr(config, f"{name}_range")
    if fixed is not None and sampled is not None:
        raise ValueError(
            f"{owner}: {name} = {fixed!r} and {name}_range = {sampled!r} are both given; "
            f"allowed: a fixed {name} or a sampled {name}_range, not both"
        )
    if fixed is not None:
        value = check_real(owner, name, fixed, "m/s", *SPEED_LIMITS)
        _inside(owner, name, value, "speed_envelope", envelope)
        object.__setattr__(config, name, value)
        return
    given = envelope if sampled is None else sampled
    low, high = check_interval(owner, f"{name}_range", given, "m/s", SPEED_LIMITS)
    _inside(owner, f"{name}_range low", low, "speed_envelope", envelope)
    _inside(owner, f"{name}_range high", high, "speed_envelope", envelope)
    object.__setattr__(config, f"{name}_range", (low, high))


def _body_split_options() -> ModelOptions:
    return ModelOptions(thrust_split="body")


@dataclass(frozen=True, kw_only=True)
class SpeedChangeConfig(FlightConfig):
    """Change speed and hold altitude over many wing-beats (see ``SpeedChangeEnv``).

    Start speed u₀ and target speed u* are each fixed (``start_speed``, ``target_speed``) or
    drawn uniformly at every reset from ``start_speed_range`` / ``target_speed_range``, which
    default to the whole ``speed_envelope`` (the level-flight envelope, 0.25-2.0 m/s).
    """

    options: ModelOptions = field(default_factory=_body_split_options)
    """Model options; default ``thrust_split="body"``, so that the reported T − D and L − W
    are exactly the net forces of the dynamics (wings + body drag + weight)."""
    start_speed: float | None = None
    """Fixed forward speed at reset u₀ [m/s] (else drawn from ``start_speed_range``)."""
    start_speed_range: tuple[float, float] | None = None
    """(low, high) [m/s] u₀ is drawn from; default ``speed_envelope``."""
    target_speed: float | None = None
    """Fixed target forward speed u* [m/s] (else drawn from ``target_speed_range``)."""
    target_speed_range: tuple[float, float] | None = None
    """(low, high) [m/s] u* is drawn from; default ``speed_envelope``."""
    speed_envelope: tuple[float, float] = LEVEL_FLIGHT_ENVELOPE
    """(low, high) [m/s]: start and target speeds must lie inside; the target's observation is
    normalised over it. Default the level-flight envelope, 0.25-2.0 m/s."""
    max_cycles: int = 48
    """Wing-beat cycles per episode before truncation [-]: 48 cycles of 22-33 ms (30-45 Hz)
    are 1.1-1.6 s of flight."""
    altitude_band: float = 0.5
    """|h| [m] beyond which the episode terminates (h: altitude relative to the start)."""
    forward_speed_band: tuple[float, float] = (0.0, MAX_BAND_SPEED)
    """(low, high) [m/s]: a forward speed u outside terminates the episode; the observation of u
    is normalised over it. The low end may not be below 0: the model covers forward flight only
    (|γ| ≤ 90°); the high end not above :data:`MAX_BAND_SPEED` (3 m/s), where one cycle's step
    stops being resolved."""
    vertical_speed_scale: float = 2.0
    """|w| [m/s] mapped to ±1 in the observation (clipped beyond; w is not bounded)."""
    reward: SpeedChangeReward = field(default_factory=SpeedChangeReward)
    """Weights of the reward's terms (``gym.make`` accepts a dict of some of them)."""

    DECLARATION: ClassVar[TaskDeclaration] = SPEED_CHANGE
    # The condition the training tools vary per evaluation env: the target speed.
    condition_key: ClassVar[str] = "target_speed"

    def __post_init__(self) -> None:
        super().__post_init__()
        owner = type(self).__name__
        envelope = check_interval(owner, "speed_envelope", self.speed_envelope, "m/s", SPEED_LIMITS)
        object.__setattr__(self, "speed_envelope", envelope)
        _speed_option(owner, self, "start_speed", envelope)
        _speed_option(owner, self, "target_speed", envelope)
        cycles = check_count(
            owner, "max_cycles", self.max_cycles, 1, MAX_CYCLES, "wing-beat cycles per episode"
        )
        object.__setattr__(self, "max_cycles", cycles)
        object.__setattr__(
            self,
            "altitude_band",
            check_real(owner, "altitude_band", self.altitude_band, "m", 1e-6, 1e3),
        )
        band = check_interval(
            owner, "forward_speed_band", self.forward_speed_band, "m/s", SPEED_LIMITS
        )
        if band[1] > MAX_BAND_SPEED:
            raise ValueError(
                f"{owner}.forward_speed_band = {self.forward_speed_band!r} m/s; allowed: a band "
                f"within 0 to {MAX_BAND_SPEED:g} m/s (MAX_BAND_SPEED: beyond it one wing-beat's "
                "step, the cycle-mean force held over the cycle, is not resolved and can reverse "
                "the flight)"
            )
        _inside(owner, "speed_envelope low", envelope[0], "forward_speed_band", band)
        _inside(owner, "speed_envelope high", envelope[1], "forward_speed_band", band)
        object.__setattr__(self, "forward_speed_band", band)
        object.__setattr__(
            self,
            "vertical_speed_scale",
            check_real(owner, "vertical_speed_scale", self.vertical_speed_scale, "m/s", 1e-6, 1e3),
        )
        object.__setattr__(self, "reward", SpeedChangeReward.build(self.reward))

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> FlightConfig:
        """As :meth:`FlightConfig.from_kwargs`, with ``thrust_split="body"`` unless given."""
        if "options" not in kwargs:
            kwargs["options"] = _body_split_options()
        return super().from_kwargs(**kwargs)

    # --- the condition the training tools vary: the target speed -----------------------------
    @property
    def envelope(self) -> tuple[float, float]:
        return self.speed_envelope

    @property
    def condition_range(self) -> tuple[float, float] | None:
        return self.target_speed_range

    @property
    def fixed_condition(self) -> float | None:
        return self.target_speed

    @property
    def available_power(self) -> float:
        """The power cap [W/kg]: the insect's maximum (90 W/kg), as in level flight."""
        return self.insect.max_power_per_mass

    def max_cycle_cost(self) -> float:
        """Largest speed, altitude and energy cost of one cycle flown inside the bands with power
        within the cap [reward units].

        The slowest cycle lasts 1/30 Hz (Table 4's lowest frequency); the speed error is at most
        the forward band's width past the envelope, the altitude error the band. The
        termination weight should exceed this, so that ending an episode early never pays.
        """
        from ..physics import LOWER, PARAMETER_NAMES

        slowest = 1.0 / LOWER[PARAMETER_NAMES.index("fore_frequency")]
        band = self.forward_speed_band
        env = self.speed_envelope
        speed_error = max(band[1] - env[0], env[1] - band[0])
        power = self.available_power * self.insect.body_mass
        w = self.reward
        return slowest * (
            w.speed * speed_error + w.altitude * self.altitude_band + w.energy * power
        )

    def describe(self) -> str:
        def part(name: str) -> str:
            fixed, sampled = getattr(self, name), getattr(self, f"{name}_range")
            if fixed is not None:
                return f"{fixed:g} m/s"
            return f"U({sampled[0]:g}, {sampled[1]:g}) m/s"

        return f"u0 = {part('start_speed')} -> u* = {part('target_speed')}"


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
    ``reward_termination`` (:class:`~tandem_env.envs.speed_change.SpeedChangeReward`)."""
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


class SpeedChangeCore:
    """Draw episodes, observe them and fly one cycle of B of them (see the module docstring)."""

    option_key = "target_speed"
    """The reset option the training tools set per evaluation env (the target speed)."""

    def __init__(self, config: SpeedChangeConfig) -> None:
        self.config = config

    # --- episodes --------------------------------------------------------------------------
    def draw(
        self,
        count: int,
        rngs: EnvGenerators,
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
            # Within ±MAX_BAND_SPEED (checked in _options), as u is within the band.
            flight.vertical_speed[k] = given.get("vertical_speed", 0.0)
        return flight

    def _options(self, options: Mapping[str, Any] | None) -> dict[str, float]:
        cfg = self.config
        given = reset_options(cfg.name, options, RESET_OPTIONS, {})
        low, high = cfg.speed_envelope
        out = {
            key: option_value(cfg.name, key, given[key], low, high, "m/s", "the speed envelope")
            for key in ("start_speed", "target_speed")
            if key in given
        }
        if "vertical_speed" in given:
            limit = MAX_BAND_SPEED
            out["vertical_speed"] = option_value(
                cfg.name,
                "vertical_speed",
                given["vertical_speed"],
                -limit,
                limit,
                "m/s",
                "the range",
            )
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
    def step(self, physical: np.ndarray, flight: Flight) -> CycleBatch:
        """Fly one cycle of each episode from its (validated, physical) stroke: ONE batched
        model call, then Eqs. (1)-(3) of :mod:`tandem_env.envs.dynamics` and the reward terms."""
        cfg = self.config
        count = len(flight.cycle)
        speed, gamma = flight_path(flight.forward_speed, flight.vertical_speed)
        result = fly(cfg, physical, speed, np.full(count, cfg.available_power), gamma)
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
        left_speed = (u < low) | (u > high) | (np.hypot(u, w) > SPEED_LIMITS[1])
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
        # The power cap as in level flight (SPEED_CHANGE's one constraint), penalised per cycle
        # by the env's PenaltyConfig (exactly 0 within the cap).
        scores = SPEED_CHANGE.score(result, cfg)
        strokes = StepBatch.scored(physical, result, objective, scores, cfg.penalty)
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


def frame_for(
    core: SpeedChangeCore, title: str, flight: Flight | None, index: int, last: LastStep | None
) -> Any:
    """The render frame of episode ``index`` of ``flight`` (imports matplotlib lazily)."""
    from .render import HISTORY_SAMPLES, Frame

    cfg = core.config
    if flight is None:
        return Frame(title=f"{title}  {cfg.describe()}", subtitle="not reset yet", history=None)
    state = row(flight.columns(), index)
    heading = (
        f"{title}  u = {state['forward_speed']:.3g} m/s -> u* = {state['target_speed']:.3g} m/s, "
        f"h = {state['altitude']:+.3g} m, cycle {state['cycle']}/{cfg.max_cycles}"
    )
    if last is None:
        return Frame(title=heading, subtitle="no cycle flown since reset", history=None)
    batch, k = last.batch, last.index
    result = batch.strokes.result
    subtitle = (
        f"reward {float(batch.reward[k]):.4g} | F_x {float(batch.force_horizontal[k]) * 1e3:+.3f} "
        f"mN | F_z {float(batch.force_vertical[k]) * 1e3:+.3f} mN | "
        f"P/m {float(result.power_per_mass[k]):.1f} W/kg | Δt {float(batch.cycle_time[k]) * 1e3:.1f} ms"
    )
    history = stroke_history(
        batch.strokes.physical[k],
        float(result.speed[k]),
        float(result.available_power[k]),
        flight_path_angle=float(result.flight_path_angle[k]),
        insect=cfg.insect,
        options=cfg.options,
        n_samples=HISTORY_SAMPLES,
    )
    return Frame(title=heading, subtitle=subtitle, history=history)


class SpeedChangeVectorEnv(FlightVectorEnv):
    """n :class:`SpeedChangeEnv` in one batched model call per step.

    Args: as :class:`~tandem_env.envs.base.FlightVectorEnv` (``num_envs``, ``render_mode``,
    ``autoreset_mode``, ``config`` or the env's keyword options).
    """

    config_class = SpeedChangeConfig
    core_class = SpeedChangeCore
    config: SpeedChangeConfig
    core: SpeedChangeCore

    @property
    def conditions(self) -> np.ndarray:
        """(n,) target speed of each sub-env's episode [m/s]."""
        return self._flight.target_speed.copy()

    @property
    def flight(self) -> Flight:
        """The state of every sub-env's episode (a copy)."""
        return self._flight.take(np.arange(self.num_envs))

    def _observation_space(self) -> spaces.Box:
        """Box(-1, 1, (5,), float32): u, w, h, u*, cycles left, each normalised (see the env)."""
        return spaces.Box(-1.0, 1.0, (len(OBSERVATION_NAMES),), dtype=np.float32)

    def _init_episodes(self, n: int) -> None:
        self._flight = Flight.empty(n)

    def _start(self, index: np.ndarray, rng: EnvGenerators, options: EnvOptions) -> Columns:
        flight = self.core.draw(index.size, rng, options)
        self._flight.put(index, flight)
        self._observations[index] = self.core.observe(flight)
        return self.core.reset_columns(flight)

    def _fly(self, index: np.ndarray, physical: np.ndarray) -> tuple[CycleBatch, np.ndarray]:
        """Fly one cycle of sub-envs ``index`` in one model call; (batch, observations)."""
        batch = self.core.step(physical, self._flight.take(index))
        self._flight.put(index, batch.after)
        observations = self.core.observe(batch.after)
        self._observations[index] = observations
        return batch, observations

    def _frame(self, i: int, title: str) -> Any:
        flight = self._flight if self._started[i] else None
        return frame_for(self.core, title, flight, i, self._last[i])


class SpeedChangeEnv(FlightEnv):
    """Change forward speed and hold altitude over many wing-beats of the tandem-wing dragonfly.

    ## Description

    The quasi-steady tandem-wing model (Faisal & Filippone 2016) evaluates one wing-beat cycle
    of a stroke at the body's current velocity: speed V = sqrt(u² + w²) along a flight path
    inclined by γ = atan2(w, u), forces in earth axes. The cycle-mean wing forces plus the body's
    parasite drag and its weight then move the body as a point mass for one cycle
    (:mod:`tandem_env.envs.dynamics`). The task: reach the target forward speed u*, hold the
    start altitude, spend little energy, within the power cap (90 W/kg). Each stroke is chosen
    from the current state, so a policy can do what no fixed stroke can: accelerate hard, then
    settle.

    ## Action Space

    ``Box(-1, 1, (28,), float32)``: the next cycle's normalised stroke, exactly as in
    ``TandemWing/LevelFlight-v0`` (``tandem_env.normalised_to_physical``; ``clip_actions``).

    ## Observation Space

    ``Box(-1, 1, (5,), float32)``: forward speed u over ``forward_speed_band`` (0-3 m/s),
    vertical speed w / ``vertical_speed_scale`` (2 m/s, clipped), altitude error
    h / ``altitude_band`` (0.5 m), target speed u* over ``speed_envelope`` (0.25-2 m/s) and
    cycles left over (0, ``max_cycles``), each mapped linearly to [-1, 1].

    ## Dynamics

    One step lasts Δt = max(1/f_fore, 1/f_hind) (both pairs complete a beat). The net force
    F = F_wings + D_body + W is held over the cycle and the state advanced exactly for a constant
    force: u' = u + F_x/m·Δt, w' = w + F_z/m·Δt, h' = h + w·Δt + ½F_z/m·Δt².

    ## Rewards

    ``reward = objective − penalty``, ``objective`` the sum of the weighted terms
    (:class:`~tandem_env.envs.speed_change.SpeedChangeReward`; u, h before and u', h'
    after the cycle): progress w_progress·(|u − u*| − |u' − u*|) [1/(m/s)], speed error
    −w_speed·|u' − u*|·Δt [1/m], altitude error −w_altitude·|h'|·Δt [1/(m·s)], energy
    −w_energy·P·Δt [1/J], and −w_termination·(cycles not flown) on termination; ``penalty`` the
    power cap of level flight, ``penalty_weight``·max(0, P/m − 90)/90 per cycle (exactly 0
    within the cap).

    ## Starting State

    u = u₀, w = 0, h = 0; u₀ and u* each fixed (``start_speed``, ``target_speed``) or drawn
    uniformly from ``start_speed_range`` / ``target_speed_range`` (default the level-flight
    envelope 0.25-2.0 m/s) with the env's seeded ``np_random``.
    ``reset(options={"start_speed": .., "target_speed": .., "vertical_speed": ..})`` sets them
    for one episode.

    ## Episode End

    Terminates when |h| > ``altitude_band`` (0.5 m) or u leaves ``forward_speed_band``
    (0-3 m/s: the model covers forward flight only); truncates after ``max_cycles`` (48) cycles,
    1.1-1.6 s of flight. ``info`` holds the state after the cycle (``forward_speed``,
    ``vertical_speed``, ``altitude``, ``distance``, ``time``, ``cycle``, ``target_speed``),
    ``cycle_time``, the net ``force_horizontal`` / ``force_vertical`` [N], ``energy`` [J], each
    reward term, the band flags, and every field of the model's ``Result`` for the stroke at the
    cycle's start (``speed`` V, ``flight_path_angle`` γ, ``power``, ``efficiency``, ...).

    ## Arguments

    ``gym.make("TandemWing/SpeedChange-v0", **kwargs)``, see
    :class:`~tandem_env.envs.speed_change.SpeedChangeConfig`: ``start_speed``,
    ``start_speed_range``, ``target_speed``, ``target_speed_range``, ``speed_envelope``,
    ``max_cycles``, ``altitude_band``, ``forward_speed_band``, ``vertical_speed_scale``,
    ``reward`` (a dict of weights), and every model, penalty and action option of the other envs
    (``thrust_split`` defaults to ``"body"`` here). Invalid values raise ``ValueError``.

    ## Version History

    * v0: initial version.
    """

    vector_class = SpeedChangeVectorEnv
    config: SpeedChangeConfig
    title = "SpeedChange"

    @property
    def flight(self) -> Flight | None:
        """The current episode's state (B = 1 arrays), or None before the first reset."""
        return self.batch.flight if self.batch._started[0] else None
