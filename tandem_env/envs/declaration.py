"""A task's declaration, in one place: its condition, objectives, constraints and sweep.

Each task module puts one :class:`TaskDeclaration` on its env config as ``DECLARATION``; the
env scores strokes by it (:meth:`TaskDeclaration.score`), and the harness, the commands and the
training tools read it; nothing copies it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from functools import partial
from itertools import pairwise
from types import MappingProxyType
from typing import Any, Literal, get_args, get_origin, get_type_hints

import numpy as np

from ..physics import Result
from ..physics.checks import is_real


def refusal(what: str, value: Any, allowed: str, unit: str = "") -> ValueError:
    """The ``ValueError`` refusing ``value`` of ``what`` (e.g. ``"LevelFlightConfig.speed"``), in
    the one form the env layer's checks share: ``"{what} = {value!r} {unit}; allowed: …"``."""
    return ValueError(f"{what} = {value!r}{' ' + unit if unit else ''}; allowed: {allowed}")


def _identifier(owner: str, name: str, value: Any) -> None:
    if not isinstance(value, str) or not value.isidentifier():
        allowed = "a Python identifier (it is a keyword argument or an info key), e.g. 'speed'"
        raise refusal(f"{owner}.{name}", value, allowed)


def _text(owner: str, name: str, value: Any) -> None:
    if not isinstance(value, str) or not value.strip():
        raise refusal(f"{owner}.{name}", value, "a non-empty string")


def _pair(owner: str, name: str, value: Any, unit: str) -> tuple[float, float]:
    pair = isinstance(value, tuple) and len(value) == 2
    if not (pair and all(is_real(v) and math.isfinite(v) for v in value) and value[0] < value[1]):
        allowed = f"a tuple (low, high) of finite numbers with low < high [{unit}]"
        raise refusal(f"{owner}.{name}", value, allowed)
    return float(value[0]), float(value[1])


@dataclass(frozen=True)
class TaskCondition:
    """The flight condition a task is optimised at and observes, e.g. the flight speed: its
    config has the fields ``{keyword}`` (fixed), ``{keyword}_range`` (sampled at each reset) and
    ``{keyword}_envelope`` (the observation's range)."""

    keyword: str
    """The condition's one name: constructor keyword, reset option, ``info`` key and record
    name, e.g. ``"speed"`` or ``"available_power"``."""
    label: str
    """What it is, in words, for help texts and axis labels, e.g. ``"flight speed"``."""
    symbol: str
    """Its symbol in titles and plots, e.g. ``"V"`` or ``"P_avail"``."""
    unit: str
    """Its unit, e.g. ``"m/s"``."""
    limits: tuple[float, float]
    """What the model accepts [unit]: an envelope must lie inside (the physics' limits)."""
    default: float
    """The condition when neither ``{keyword}`` nor ``{keyword}_range`` is given [unit]."""
    envelope: tuple[float, float]
    """Default ``{keyword}_envelope`` [unit]: the paper's range of the condition."""
    sweep: tuple[float, ...]
    """The paper's sweep [unit], increasing, inside ``envelope``: what the studies run at."""
    metavar: str = ""
    """Placeholder of the value on the command line, e.g. ``"V"``; default ``symbol``."""
    option: str = ""
    """Its command-line option without the dashes (``python -m eval optimize``), e.g.
    ``"power"`` for ``--power``; default the keyword."""
    former_keyword: str | None = None
    """The condition's old name, refused with a message naming the new one (``"power"`` for
    ``"available_power"``), or None."""

    def __post_init__(self) -> None:
        owner = "TaskCondition"
        # "" (the default) stands for the keyword's option and the symbol's placeholder
        object.__setattr__(self, "option", self.keyword if self.option == "" else self.option)
        object.__setattr__(self, "metavar", self.symbol if self.metavar == "" else self.metavar)
        for name in ("keyword", "option", "former_keyword"):
            if name != "former_keyword" or self.former_keyword is not None:
                _identifier(owner, name, getattr(self, name))
        for name in ("label", "symbol", "unit", "metavar"):
            _text(owner, name, getattr(self, name))
        limits = _pair(owner, "limits", self.limits, self.unit)
        envelope = _pair(owner, "envelope", self.envelope, self.unit)
        what, inside = f"{owner} {self.keyword!r}: ", f"({envelope[0]:g}, {envelope[1]:g})"
        if not limits[0] <= envelope[0] < envelope[1] <= limits[1]:
            allowed = f"inside limits = ({limits[0]:g}, {limits[1]:g}) {self.unit}"
            raise refusal(f"{what}envelope", self.envelope, allowed, self.unit)
        if not (is_real(self.default) and envelope[0] <= self.default <= envelope[1]):
            allowed = f"a number inside envelope = {inside} {self.unit}"
            raise refusal(f"{what}default", self.default, allowed, self.unit)
        sweep = self.sweep
        ok = isinstance(sweep, tuple) and len(sweep) > 0
        ok = ok and all(is_real(v) and envelope[0] <= v <= envelope[1] for v in sweep)
        if not (ok and all(a < b for a, b in pairwise(sweep))):
            allowed = f"a non-empty, increasing tuple of numbers inside envelope = {inside}"
            raise refusal(f"{what}sweep", sweep, f"{allowed} {self.unit}")
        stored = {"limits": limits, "envelope": envelope, "default": float(self.default)}
        for name, value in {**stored, "sweep": tuple(float(v) for v in sweep)}.items():
            object.__setattr__(self, name, value)

    @property
    def range_keyword(self) -> str:
        """Constructor keyword of a range sampled at every reset, e.g. ``"speed_range"``."""
        return f"{self.keyword}_range"

    @property
    def envelope_keyword(self) -> str:
        """Constructor keyword of the observation's envelope, e.g. ``"speed_envelope"``."""
        return f"{self.keyword}_envelope"

    @property
    def keywords(self) -> tuple[str, str, str]:
        """The three config fields the condition needs: fixed value, range, envelope."""
        return self.keyword, self.range_keyword, self.envelope_keyword

    def renamed(self) -> dict[str, str]:
        """Old keyword -> new keyword, for the three fields (empty without a former name)."""
        old = self.former_keyword
        if old is None:
            return {}
        return dict(zip((old, f"{old}_range", f"{old}_envelope"), self.keywords, strict=True))

    def describe(self, fixed: float | None, sampled: tuple[float, float] | None) -> str:
        """``"V = 1.5 m/s"`` or ``"V ~ U(0.25, 2) m/s"``, for titles and reprs."""
        if sampled is not None:
            return f"{self.symbol} ~ U({sampled[0]:g}, {sampled[1]:g}) {self.unit}"
        return f"{self.symbol} = {fixed:g} {self.unit}"


@dataclass(frozen=True)
class TaskObjectives:
    """What a task maximises: each objective choice and its ``info`` metric (one entry and
    ``keyword=None`` for a fixed objective)."""

    metrics: Mapping[str, str]
    """Objective choice -> the ``info`` metric (a :class:`~tandem_env.physics.Result` field)
    it maximises, e.g. ``{"vertical": "excess_vertical"}``."""
    default: str
    """The choice used when none is given."""
    keyword: str | None = None
    """Constructor keyword selecting the objective, or None when there is only one."""
    unit: str = "-"
    """Unit of the objective's values."""
    choices: tuple[str, ...] = field(init=False)
    """The choices, in declaration order."""

    def __post_init__(self) -> None:
        owner = "TaskObjectives"
        metrics = self.metrics
        named = isinstance(metrics, Mapping) and all(isinstance(k, str) and k for k in metrics)
        if not (named and metrics):
            allowed = "a non-empty mapping of objective choice -> info metric (a Result field)"
            raise refusal(f"{owner}.metrics", self.metrics, allowed)
        for choice, metric in self.metrics.items():
            _identifier(f"{owner}.metrics[{choice!r}]", "metric", metric)
        if self.default not in self.metrics:
            allowed = f"one of {', '.join(map(repr, self.metrics))}"
            raise refusal(f"{owner}.default", self.default, allowed)
        if self.keyword is not None:
            _identifier(owner, "keyword", self.keyword)
        elif len(self.metrics) > 1:
            raise ValueError(
                f"{owner}: {len(self.metrics)} objectives ({', '.join(self.metrics)}) but no "
                "keyword to choose between them; allowed: a keyword, or one objective"
            )
        _text(owner, "unit", self.unit)
        object.__setattr__(self, "metrics", MappingProxyType(dict(self.metrics)))
        object.__setattr__(self, "choices", tuple(self.metrics))

    def choice(self, config: Any) -> str:
        """The objective ``config`` maximises."""
        return self.default if self.keyword is None else getattr(config, self.keyword)

    def metric(self, config: Any) -> str:
        """The ``info`` metric ``config`` maximises, e.g. ``"efficiency"``."""
        return self.metrics[self.choice(config)]


@dataclass(frozen=True)
class Constraint:
    """One constraint of a task: its violation from the model's result, >= 0 and exactly 0
    where the constraint holds."""

    name: str
    """The ``info`` key reporting the violation, e.g. ``"lift_violation"``."""
    text: str
    """The constraint in symbols, for docs and messages, e.g. ``"|L/W − 1| ≤ tol"``."""
    unit: str
    """Unit of the violation, e.g. ``"-"`` (a fraction of W) or ``"W/kg"``."""
    violation: Callable[[Result, Any], np.ndarray] | None = None
    """``violation(result, config)``: (B,) violation [unit], 0 where the constraint holds (a
    module-level function, so that envs pickle); None: ``max(0, −margin)``."""
    scale: Callable[[Result, Any], np.ndarray] | None = None
    """``scale(result, config)``: (B,) divisor making the violation a fraction (the power cap
    for the power excess) in the reward's sum; None when it already is one."""
    margin: Callable[[Result, Any], np.ndarray] | None = None
    """``margin(result, config)``: (B,) signed margin [-] with ``max(0, −margin) == violation /
    scale``, smooth across the boundary (what the polish needs); None for none."""
    applies: Callable[[Any], bool] | None = None
    """``applies(config)``: whether ``config`` asks for this constraint; None: always."""

    def __post_init__(self) -> None:
        if self.violation is None and self.margin is None:
            raise TypeError(f"Constraint {self.name!r}: allowed: a violation or a margin (or both)")


def _power_excess(result: Result, _: Any) -> np.ndarray:
    return np.maximum(0.0, result.power_per_mass - result.available_power)


def _power_cap(result: Result, _: Any) -> np.ndarray:
    return result.available_power


def _power_margin(result: Result, _: Any) -> np.ndarray:
    return 1.0 - result.power_per_mass / result.available_power


#: The power cap every flight task has: P/m ≤ the available power (a fraction of it in the sum).
POWER_CAP = Constraint(
    "power_violation", "P/m ≤ P_avail", "W/kg", _power_excess, _power_cap, _power_margin
)


def _gap_margin(result: Result, config: Any, distance: str = "wing_gap") -> Any:
    return getattr(result, distance) / config.insect.min_wing_gap - 1.0


def _gap_set(config: Any) -> bool:
    return config.insect.min_wing_gap is not None


#: The wings' gap where they come closest, and where next (a margin at each: docs/envs.md).
WING_GAP = Constraint(
    "wing_gap_violation", "gap ≥ min_wing_gap", "-", margin=_gap_margin, applies=_gap_set
)
NEXT_WING_GAP = replace(
    WING_GAP, name="wing_gap_next_violation", margin=partial(_gap_margin, distance="wing_gap_next")
)
FLIGHT_LIMITS = (POWER_CAP, WING_GAP, NEXT_WING_GAP)  # every flight task's, besides its own


@dataclass(frozen=True)
class Scores:
    """A batch's constraint violations, their normalised sum and the feasibility flags."""

    violations: dict[str, np.ndarray]
    """Each constraint's violation (B,) [its unit], by its ``info`` name."""
    total: np.ndarray
    """(B,) sum of the normalised violations [-], 0 where feasible."""
    feasible: np.ndarray
    """(B,) bool: every constraint holds."""


@dataclass(frozen=True)
class TaskDeclaration:
    """Everything a task is, in one place (see the module docstring)."""

    name: str
    """The task's name in messages, e.g. ``"LevelFlight"``."""
    summary: str
    """One line for ``--help`` and docs."""
    constraints: tuple[Constraint, ...]
    """What a feasible stroke satisfies (a feasible stroke is rewarded with its objective);
    empty for an unconstrained task."""
    condition: TaskCondition | None = None
    """The one flight condition the task is optimised at and observes, or None (a task with
    several, such as SpeedChange's start and target speeds)."""
    objectives: TaskObjectives | None = None
    """What the task maximises as an ``info`` metric, or None (a reward of several terms)."""

    def __post_init__(self) -> None:
        _text("TaskDeclaration", "name", self.name)
        _text("TaskDeclaration", "summary", self.summary)
        kinds = isinstance(self.condition, TaskCondition | None)
        kinds = kinds and isinstance(self.objectives, TaskObjectives | None)
        if (self.condition is None) != (self.objectives is None) or not kinds:
            raise TypeError(
                f"TaskDeclaration {self.name!r}: condition = {self.condition!r}, objectives = "
                f"{self.objectives!r}; allowed: a TaskCondition and a TaskObjectives, or neither"
            )
        if not isinstance(self.constraints, tuple) or not all(
            isinstance(c, Constraint) for c in self.constraints
        ):
            raise TypeError(
                f"TaskDeclaration {self.name!r}: constraints = {self.constraints!r}; allowed: a "
                "tuple of Constraint (empty for an unconstrained task)"
            )

    def constraints_of(self, config: Any) -> tuple[Constraint, ...]:
        """The constraints ``config`` asks for (:attr:`Constraint.applies`), in order."""
        return tuple(c for c in self.constraints if c.applies is None or c.applies(config))

    def score(self, result: Result, config: Any) -> Scores:
        """The constraints of ``config``'s task on a batch's model ``result``."""
        violations: dict[str, np.ndarray] = {}
        total = np.zeros(result.power.shape)
        feasible = np.ones(result.power.shape, dtype=np.bool_)
        for constraint in self.constraints_of(config):
            if constraint.violation is None:
                value = np.maximum(0.0, -constraint.margin(result, config))  # type: ignore[misc]
            else:
                value = constraint.violation(result, config)
            violations[constraint.name] = value
            scale = 1.0 if constraint.scale is None else constraint.scale(result, config)
            total = total + value / scale
            feasible &= value == 0.0
        return Scores(violations, total, feasible)


def check_declarations(cls: type) -> None:
    """Check a config class's ``DECLARATION`` against its own fields, when the class is
    defined (a declaration naming a missing field fails at import, naming both)."""
    declaration = getattr(cls, "DECLARATION", None)
    if not isinstance(declaration, TaskDeclaration | None):
        raise TypeError(
            f"{cls.__name__}: DECLARATION = {declaration!r}; allowed: a TaskDeclaration "
            "(tandem_env.envs.declaration)"
        )
    if declaration is None or declaration.condition is None or declaration.objectives is None:
        return
    condition, objectives = declaration.condition, declaration.objectives
    fields = {name for klass in cls.__mro__ for name in getattr(klass, "__annotations__", {})}
    needed = [*condition.keywords, *([objectives.keyword] if objectives.keyword else [])]
    missing = [name for name in needed if name not in fields]
    if missing:
        raise TypeError(
            f"{cls.__name__} declares the condition {condition.keyword!r} and objectives "
            f"{objectives.choices} but has no field(s) {', '.join(map(repr, missing))}; a "
            f"declared condition needs the fields {', '.join(condition.keywords)}"
            + (f" and {objectives.keyword}" if objectives.keyword else "")
        )
    if objectives.keyword is None:
        return
    try:  # an objective field typed ``Literal`` must offer exactly the declared choices
        hint = get_type_hints(cls).get(objectives.keyword)
    except NameError:  # an annotation not resolvable yet: nothing to compare
        return
    if get_origin(hint) is Literal and set(get_args(hint)) != set(objectives.choices):
        raise TypeError(
            f"{cls.__name__}.{objectives.keyword} is typed {hint} but OBJECTIVES declares "
            f"{objectives.choices}; allowed: the same choices in both (each with its info "
            "metric in OBJECTIVES.metrics)"
        )
