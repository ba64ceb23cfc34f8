"""Model options: resolution, inflow model, conventions (one frozen, validated dataclass)."""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from types import MappingProxyType
from typing import Any, Literal, get_args

Induction = Literal["coupled", "isolated", "none"]
PowerConvention = Literal["absolute", "elastic", "aerodynamic"]
ThrustSplit = Literal["sign", "body"]
Spin = Literal["pitch", "total"]
HoverInflow = Literal["momentum", "none"]
Slipstream = Literal["mean", "convected", "vortex"]


#: Below this free-stream speed normal to a wing's stroke plane, |V·sin(β + γ)| [m/s], the wing
#: counts as hovering for ``ModelOptions.hover_inflow``: far below any flight speed the model is
#: used at (0.25-2 m/s) and any induced velocity (of order 1 m/s), so in practice only V = 0.
HOVER_NORMAL_SPEED = 1e-9


def _is_int(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _is_real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def _check_choice(name: str, value: Any, kind: Any) -> None:
    allowed = get_args(kind)
    if value not in allowed:
        raise ValueError(
            f"ModelOptions.{name} = {value!r}; allowed: {', '.join(map(repr, allowed))}"
        )


#: Most time samples per cycle the model takes (``n_time``, a measured wing's samples) [-]:
#: the cycle means hold (n/2, n) Fourier tables, 512 MiB at this size.
MAX_TIME_SAMPLES = 8192


@dataclass(frozen=True)
class ModelOptions:
    """How the model is evaluated. Defaults are the paper's model with docs/model.md's decisions.

    The default resolution is justified by the convergence study in
    ``tests/physics/test_convergence.py`` (mean forces and power within 0.5 % of a 4× refined
    run on random Table 4 strokes).
    """

    n_time: int = 128
    """Samples per wing-beat cycle [-] on the motion-following grid (docs/model.md §3)."""
    n_blade: int = 24
    """Blade elements (annuli) per wing [-], Gauss-Legendre in a smoothing map of r/R."""
    induction: Induction = "coupled"
    """Momentum inflow (docs/model.md §5): ``"coupled"`` each pair's own inflow plus the fore-wing's
    slipstream on the hind-wing (the paper's tandem model); ``"isolated"`` each pair's own
    inflow only (coupling off: the paper's single-wing baseline); ``"none"`` no induced
    velocity at all."""
    interference: float = 1.0
    """C_hf, share of the fore-wing's induced velocity seen by the hind-wing [-] (Eq. 21)."""
    power: PowerConvention = "absolute"
    """Power accounting per wing pair [W] (docs/model.md §6.3): ``"absolute"`` P = N_w·(mean|P_aero|
    + mean|P_iner|) (Eqs. 18-19, the paper); ``"elastic"`` N_w·mean(max(P_aero + P_iner, 0))
    (Berman & Wang's elastic storage); ``"aerodynamic"`` N_w·mean(max(P_aero, 0)): the inertial
    power fully recovered and negative aerodynamic power not recovered."""
    thrust_split: ThrustSplit = "sign"
    """T/D reading (docs/model.md §7): ``"sign"`` T and D are the cycle means of the forward and
    rearward parts of each wing's horizontal force (the paper's literal reading, gross
    efficiency); ``"body"`` T is the net horizontal wing force and D the body's parasite drag."""
    spin: Spin = "pitch"
    """Rotation rate Ω in the circulation and added mass: ``"pitch"`` η̇ (the paper, Berman &
    Wang) or ``"total"`` the section's true spin about the span η̇ − φ̇·sin θ (docs/model.md §4)."""
    hover_inflow: HoverInflow = "momentum"
    """Induced velocity where the free stream has no component normal to a wing's stroke plane,
    |V·sin(β + γ)| < ``HOVER_NORMAL_SPEED`` (in practice V = 0, hover; docs/model.md §5.5):
    ``"momentum"`` the momentum inflow of ``induction`` as at any speed; ``"none"`` no induced
    velocity on that wing (Eqs. 20-21 read literally: the inflow v_z·(1 + a) is zero where
    v_z = 0). At V_n ≠ 0 both are the same."""
    slipstream: Slipstream = "mean"
    """How the hind-wing sees the fore-wing's slipstream under ``induction="coupled"``
    (docs/model.md §5.7): ``"mean"`` the fore-wing's cycle-mean induced velocity, the same at
    every instant (blind to the fore/hind phase); ``"convected"`` the fore-wing's wake as it
    varies over the cycle, following its instantaneous normal loading, convected from the
    fore- to the hind-wing's stroke plane (``Dragonfly.root_spacing``, ``root_drop``) with a
    delay. Both have the same cycle mean; the fore-wing is the same under both. ``"vortex"``
    each pair's lifting line and prescribed wake act on the other pair's elements by
    Biot-Savart, both ways, iterated to a fixed point (docs/model.md §5.8): the fore-wing
    then depends on the phase too; each pair's own inflow stays the momentum solve."""
    tolerance: float = 1e-4
    """Relative tolerance of the per-annulus inflow solve [-]."""
    max_evaluations: int = 30
    """Cap on force sweeps per annulus in the inflow solve [-]; hitting it is reported."""

    def __post_init__(self) -> None:
        if not _is_int(self.n_time) or not 8 <= self.n_time <= MAX_TIME_SAMPLES:
            raise ValueError(
                f"ModelOptions.n_time = {self.n_time!r}; allowed: an integer 8 to "
                f"{MAX_TIME_SAMPLES}"
            )
        if not _is_int(self.n_blade) or not 2 <= self.n_blade <= 512:
            raise ValueError(
                f"ModelOptions.n_blade = {self.n_blade!r}; allowed: an integer 2 to 512"
            )
        _check_choice("induction", self.induction, Induction)
        _check_choice("power", self.power, PowerConvention)
        _check_choice("thrust_split", self.thrust_split, ThrustSplit)
        _check_choice("spin", self.spin, Spin)
        _check_choice("hover_inflow", self.hover_inflow, HoverInflow)
        _check_choice("slipstream", self.slipstream, Slipstream)
        if not (_is_real(self.interference) and 0.0 <= self.interference <= 2.0):
            raise ValueError(f"ModelOptions.interference = {self.interference!r}; allowed: 0 to 2")
        if not (_is_real(self.tolerance) and 1e-12 <= self.tolerance <= 1e-1):
            raise ValueError(f"ModelOptions.tolerance = {self.tolerance!r}; allowed: 1e-12 to 0.1")
        if not _is_int(self.max_evaluations) or not 2 <= self.max_evaluations <= 1000:
            raise ValueError(
                f"ModelOptions.max_evaluations = {self.max_evaluations!r}; allowed: an integer 2 to 1000"
            )

    def phase_resolved(self, speed: float | None = None) -> bool:
        """Whether the model's results depend on the fore/hind phase (docs/model.md §5.7).

        Only the pairs' view of each other can carry the phase between them (they meet
        nowhere else in the model): it does under ``slipstream="convected"`` (the hind-wing)
        and ``"vortex"`` (both pairs) with ``induction="coupled"`` and C_hf > 0. The mean slipstream is the same at every
        instant, ``"isolated"`` and ``"none"`` have no slipstream, C_hf = 0 hides it, and so
        does ``hover_inflow="none"`` in hover, where no wing has an induced velocity (all
        tested in ``tests/physics/test_slipstream.py``).

        Parameters
        ----------
        speed : float or None
            The flight speed V [m/s] the question is asked at; below ``HOVER_NORMAL_SPEED``
            it is hover. None: a speed above it (forward flight).
        """
        if self.induction != "coupled" or self.interference == 0.0:
            return False
        hovering = speed is not None and abs(speed) < HOVER_NORMAL_SPEED
        if hovering and self.hover_inflow == "none":
            return False
        return self.slipstream in ("convected", "vortex")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def preset(cls, name: str, **fields: Any) -> ModelOptions:
        """The options of the preset ``name`` (:data:`PRESETS`) with ``fields`` over them, e.g.
        ``ModelOptions.preset("paper", n_time=256)``; raises ValueError naming the presets."""
        if name not in PRESETS:
            raise ValueError(
                f"ModelOptions.preset({name!r}); allowed: {', '.join(map(repr, PRESETS))}"
            )
        known = set(asdict(cls()))
        unknown = sorted(set(fields) - known)
        if unknown:
            raise ValueError(
                f"ModelOptions.preset({name!r}, ...): unknown field(s) {unknown}; allowed: "
                f"{', '.join(sorted(known))}"
            )
        return cls(**{**PRESETS[name], **fields})


#: Named sets of model options over the defaults (:meth:`ModelOptions.preset`; an env takes one
#: as ``options=``). ``paper``: the model options of the reading of the paper's open decisions
#: that reproduces the most of its claims at the paper preset (docs/reproduction.md, "Readings at
#: the paper preset"; ``--reading paper`` of ``python -m eval``). What it means physically, and
#: why it is not what momentum theory says: docs/model.md §5.5.
PRESETS: Mapping[str, Mapping[str, Any]] = MappingProxyType(
    {"paper": MappingProxyType({"hover_inflow": "none"})}
)
