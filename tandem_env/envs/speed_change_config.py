"""Declaration (:data:`SPEED_CHANGE`), reward weights and config of ``TandemWing/SpeedChange-v0``."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

from ..physics import PARAMETER_NAMES, SPEED_LIMITS, ModelOptions
from ..physics.checks import is_integer
from ..physics.stroke import WING_NAMES
from .config import FlightConfig, check_interval, check_real, fixed_or_sampled, store_checked
from .declaration import FLIGHT_LIMITS, TaskDeclaration, refusal
from .level_flight import LEVEL_FLIGHT

#: Speeds the episode's start and target are drawn from by default [m/s]: the level-flight
#: envelope (``LEVEL_FLIGHT.condition.envelope``), where a steady level stroke exists.
LEVEL_FLIGHT_ENVELOPE: tuple[float, float] = LEVEL_FLIGHT.condition.envelope  # type: ignore[union-attr]
#: Most cycles an episode may last [-] (about 4.5 h of flight at 30 Hz): the cycle counters
#: are int64 and the observation divides by it.
MAX_CYCLES = 500_000

#: Fastest forward (and vertical) speed a SpeedChange episode may reach [m/s]: above it one
#: step's cycle-mean force (held from the cycle's start) is not resolved (at 4 m/s some strokes
#: reverse the flight in one cycle), so a wider band is refused.
MAX_BAND_SPEED: float = 3.0

SPEED_CHANGE = TaskDeclaration(
    name="SpeedChange",
    summary="Multi-cycle flight: reach a target speed and hold altitude, one stroke per wing-beat.",
    # No single condition: two speeds (start and target) share one envelope (speed_envelope),
    # a range defaults to the whole envelope, and the harness does not run multi-cycle episodes.
    constraints=FLIGHT_LIMITS,
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

    Over an episode progress sums to the initial minus the final speed error; the other terms are
    time integrals (docs/envs.md). A weight of 0 switches a term off.
    """

    progress: float = field(default=1.0, metadata={"unit": "1/(m/s)"})
    """Per m/s of speed error removed [1/(m/s)]."""
    speed: float = field(default=1.0, metadata={"unit": "1/m"})
    """Per metre of speed error × time [1/m] (1 (m/s)·s of error costs 1)."""
    altitude: float = field(default=2.0, metadata={"unit": "1/(m·s)"})
    """Per metre-second of altitude error [1/(m·s)]."""
    energy: float = field(default=50.0, metadata={"unit": "1/J"})
    """Per joule spent by the wings [1/J]: level flight at 40 W/kg for 1.3 s costs about 0.3."""
    termination: float = field(default=0.2, metadata={"unit": "per cycle not flown"})
    """Per cycle not flown when the episode terminates early: above the most a cycle inside
    the bands costs (:meth:`SpeedChangeConfig.max_cycle_cost`, ≈ 0.14)."""

    def __post_init__(self) -> None:
        for term in fields(self):
            store_checked(self, term.name, check_real, f"[{term.metadata['unit']}]", 0.0, 1e9)

    @classmethod
    def build(cls, value: Any) -> SpeedChangeReward:
        """A reward from a ``SpeedChangeReward``, a mapping of some terms to weights, or None."""
        if value is None:
            return cls()
        if isinstance(value, cls):
            return value
        terms = [term.name for term in fields(cls)]
        if isinstance(value, Mapping):
            unknown = sorted(set(value) - set(terms))
            if unknown:
                raise ValueError(
                    f"SpeedChange: unknown reward term(s) {', '.join(map(repr, unknown))}; "
                    f"allowed: {', '.join(terms)} (weights >= 0)"
                )
            return cls(**value)
        allowed = f"a SpeedChangeReward or a dict of weights for the terms {', '.join(terms)}"
        raise refusal("SpeedChange: reward", value, allowed)


#: SpeedChange's default model options: the body's drag in the thrust split (see ``options``).
BODY_SPLIT = ModelOptions(thrust_split="body")


@dataclass(frozen=True, kw_only=True)
class SpeedChangeConfig(FlightConfig):
    """Change speed and hold altitude over many wing-beats (see ``SpeedChangeEnv``)."""

    options: ModelOptions = BODY_SPLIT
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
    altitude_band: float = field(default=0.5, metadata={"real": ("m", 1e-6, 1e3)})
    """|h| [m] beyond which the episode terminates (h: altitude relative to the start)."""
    forward_speed_band: tuple[float, float] = (0.0, MAX_BAND_SPEED)
    """(low, high) [m/s]: a forward speed u outside terminates the episode; u's observation is
    normalised over it. Within 0 (forward flight only) and :data:`MAX_BAND_SPEED`."""
    vertical_speed_scale: float = field(default=2.0, metadata={"real": ("m/s", 1e-6, 1e3)})
    """|w| [m/s] mapped to ±1 in the observation (clipped beyond; w is not bounded)."""
    reward: SpeedChangeReward = field(default_factory=SpeedChangeReward)
    """Weights of the reward's terms (``gym.make`` accepts a dict of some of them)."""

    DECLARATION: ClassVar[TaskDeclaration] = SPEED_CHANGE
    # The condition the training tools vary per evaluation env: the target speed.
    condition_key: ClassVar[str] = "target_speed"

    def __post_init__(self) -> None:
        super().__post_init__()
        owner = type(self).__name__
        envelope = store_checked(self, "speed_envelope", check_interval, "m/s", SPEED_LIMITS)
        fixed_or_sampled(self, "start_speed", "speed_envelope", "m/s", None)
        fixed_or_sampled(self, "target_speed", "speed_envelope", "m/s", None)
        if not is_integer(self.max_cycles) or not 1 <= self.max_cycles <= MAX_CYCLES:
            allowed = f"an integer from 1 to {MAX_CYCLES} (wing-beat cycles per episode)"
            raise refusal(f"{owner}.max_cycles", self.max_cycles, allowed)
        object.__setattr__(self, "max_cycles", int(self.max_cycles))
        given = self.forward_speed_band
        band = store_checked(self, "forward_speed_band", check_interval, "m/s", SPEED_LIMITS)
        if band[1] > MAX_BAND_SPEED:
            allowed = (
                f"a band within 0 to {MAX_BAND_SPEED:g} m/s (MAX_BAND_SPEED: beyond it one "
                "wing-beat's step, the cycle-mean force held over the cycle, is not resolved and "
                "can reverse the flight)"
            )
            raise refusal(f"{owner}.forward_speed_band", given, allowed, "m/s")
        for end, value in zip(("low", "high"), envelope, strict=True):
            if not band[0] <= value <= band[1]:
                raise ValueError(
                    f"{owner}.speed_envelope {end} = {value:g} m/s; allowed: a speed inside "
                    f"{owner}.forward_speed_band = ({band[0]:g}, {band[1]:g}) m/s"
                )
        object.__setattr__(self, "reward", SpeedChangeReward.build(self.reward))

    @property
    def envelope(self) -> tuple[float, float]:
        """The target speed's envelope (``speed_envelope``): the condition the training tools
        vary (``condition_key``; its fixed value and range are ``target_speed`` and
        ``target_speed_range``)."""
        return self.speed_envelope

    def max_cycle_cost(self) -> float:
        """Largest speed, altitude and energy cost of one cycle inside the bands with power
        within the cap [reward units]: the slowest cycle (the insect's lowest frequency), the
        largest speed and altitude errors. The termination weight should exceed it."""
        lowest = self.insect.stroke_bounds.lower
        slowest = 1.0 / min(lowest[PARAMETER_NAMES.index(f"{w}_frequency")] for w in WING_NAMES)
        band, env, w = self.forward_speed_band, self.speed_envelope, self.reward
        speed_error = max(band[1] - env[0], env[1] - band[0])
        power = self.available_power * self.insect.body_mass
        cost = w.speed * speed_error + w.altitude * self.altitude_band + w.energy * power
        return slowest * cost

    def describe(self) -> str:
        def part(name: str) -> str:
            fixed, sampled = getattr(self, name), getattr(self, f"{name}_range")
            if fixed is not None:
                return f"{fixed:g} m/s"
            return f"U({sampled[0]:g}, {sampled[1]:g}) m/s"

        return f"u0 = {part('start_speed')} -> u* = {part('target_speed')}"
