"""What every flight env's configuration shares: frozen, validated dataclasses built from ``gym.make`` kwargs.

Every option of an env is a field of its config, so ``env.config`` describes (and reproduces)
what it does; :meth:`FlightConfig.from_kwargs` maps the flat ``gym.make`` keywords onto it.
The env layer's validators are here too: each value is checked once, where an env receives it
(a config field when built, an action in ``step``, a reset option in ``reset``), with a
``ValueError`` naming it, its value and what is allowed.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import MISSING, dataclass, field, fields, replace
from typing import Any, ClassVar

import numpy as np

from ..physics import N_PARAMETERS, PARAMETER_NAMES, PLANFORMS, Dragonfly, ModelOptions
from ..physics.backends import check_backend
from ..physics.checks import is_real, real_array, shown
from ..physics.insect import insect_mapping, load_insect
from .declaration import TaskCondition, TaskDeclaration, TaskObjectives, check_declarations, refusal

#: ``ModelOptions`` fields whose ``gym.make`` keyword differs from the field's name: ``power``
#: was Accelerate's old condition name, so the power accounting is ``power_convention`` there.
_RENAMED_MODEL_OPTIONS: dict[str, str] = {"power": "power_convention"}
#: ``gym.make`` kwargs of the :class:`~tandem_env.physics.ModelOptions` fields -> field name:
#: every field, read from the dataclass, under its own name but for the renamed.
MODEL_OPTION_KWARGS: dict[str, str] = {
    _RENAMED_MODEL_OPTIONS.get(f.name, f.name): f.name for f in fields(ModelOptions)
}
#: ``gym.make`` kwargs that choose how the model is computed, not what it computes (the torch
#: backend equals the numba kernel within 1e-8, docs/model.md §12.1): a record's key leaves them
#: out (:attr:`agents.jobs.Job.key`), so backends share records.
EXECUTION_KWARGS: tuple[str, ...] = ("backend", "device")
#: Model options that must be real numbers (checked here, because ``ModelOptions`` would raise
#: a bare ``TypeError`` from ``math.isfinite`` on a string).
_REAL_MODEL_OPTIONS = ("interference", "tolerance")


def insect_keyword(value: Any) -> dict[str, Any] | None:
    """The ``insect`` env keyword in its canonical form, one per insect however given: the
    mapping of what differs from the paper's specimen, or None for the specimen itself."""
    return insect_mapping(load_insect(value)) or None


def _overridden(
    config: type, kwargs: dict[str, Any], name: str, keywords: Mapping[str, str], allowed: str
) -> Any:
    """``kwargs[name]`` (``ModelOptions`` or ``PenaltyConfig``; default the ``config`` class's)
    with the fields that flat ``keywords`` (keyword -> field) of ``kwargs`` set over it, all
    popped; its ValueError names each field by the keyword given for it."""
    kind = {"options": ModelOptions, "penalty": PenaltyConfig}[name]
    spec = next(f for f in fields(config) if f.name == name)  # SpeedChange's: the body split
    default = spec.default if spec.default_factory is MISSING else spec.default_factory()
    value = kwargs.pop(name, None)
    value = default if value is None else value
    if not isinstance(value, kind):
        raise refusal(f"{config.name}: {name}", value, allowed)
    given = {field: keyword for keyword, field in keywords.items() if keyword in kwargs}
    if not given:
        return value
    try:  # the dataclass validates, naming the rule
        return replace(value, **{field: kwargs.pop(keyword) for field, keyword in given.items()})
    except ValueError as error:  # each field named by its keyword, e.g. power_convention
        text = str(error)
        owner = kind.__name__
        for name, keyword in given.items():
            if keyword != name:
                text = re.sub(rf"\b{owner}\.{name}\b", f"{keyword} ({owner}.{name})", text)
        raise ValueError(f"{config.name}: {text}") from None


def normalise_condition(config: FlightConfig) -> None:
    """Validate and store the fields of ``type(config).CONDITION``: its envelope and, inside
    it, a fixed value or a sampled range (:func:`fixed_or_sampled`)."""
    declared = type(config).CONDITION
    if declared is None:
        raise TypeError(f"{type(config).__name__} declares no condition")
    name, _, envelope_name = declared.keywords
    store_checked(config, envelope_name, check_interval, declared.unit, declared.limits)
    fixed_or_sampled(config, name, envelope_name, declared.unit, declared.default)


def fixed_or_sampled(
    config: Any, name: str, envelope_name: str, unit: str, default: float | None
) -> None:
    """Validate and store a fixed ``{name}`` or a sampled ``{name}_range`` of ``config`` (not
    both), inside its (checked) ``{envelope_name}``; with neither, ``default`` as the fixed value,
    or the whole envelope as the range if ``default`` is None."""
    owner, range_name = type(config).__name__, f"{name}_range"
    envelope = getattr(config, envelope_name)
    fixed, sampled = getattr(config, name), getattr(config, range_name)
    if fixed is not None and sampled is not None:
        raise ValueError(
            f"{owner}: {name} = {fixed!r} and {range_name} = {sampled!r} are both given; "
            f"allowed: a fixed {name} or a sampled {range_name}, not both"
        )
    inside = (
        f"inside {owner}.{envelope_name} = ({envelope[0]:g}, {envelope[1]:g}) {unit} (for other "
        f"values widen {envelope_name})"
    )
    if fixed is None and sampled is None and default is None:
        sampled = envelope
    if sampled is not None:
        allowed = f"allowed: a pair (low, high) of finite numbers, low < high, {inside}"
        if isinstance(sampled, str | bytes) or not hasattr(sampled, "__len__") or len(sampled) != 2:
            raise ValueError(f"{owner}.{range_name} = {sampled!r}; {allowed}")
        low, high = sampled
        if not (is_real(low) and is_real(high) and envelope[0] <= low < high <= envelope[1]):
            raise ValueError(f"{owner}.{range_name} = {sampled!r} {unit}; {allowed}")
        object.__setattr__(config, range_name, (float(low), float(high)))
    else:
        value = default if fixed is None else fixed
        if not (is_real(value) and envelope[0] <= value <= envelope[1]):  # NaN fails it
            raise refusal(f"{owner}.{name}", value, f"a finite number {inside}", unit)
        object.__setattr__(config, name, float(value))


@dataclass(frozen=True)
class PenaltyConfig:
    """How constraint violations lower the reward: ``reward = objective − penalty``,
    ``penalty = weight · violation + offset · [stroke infeasible]``, ``violation`` the sum of the
    task's normalised constraint violations, so a feasible stroke is rewarded with exactly its
    objective. The default is a linear ("exact", L1) penalty, continuous at the feasibility
    boundary (why these defaults: docs/envs.md, "Rewards and the penalty").
    """

    weight: float = 10.0
    """Reward lost per unit of normalised violation [reward units per unit violation]. 10 is
    well above the Lagrange multipliers of both tasks (dη/d(L/W) and dF̄/d(P/P_avail) are
    of order 0.1-4), so trading a constraint for objective never pays."""
    offset: float = 0.0
    """Constant subtracted from every infeasible stroke [reward units]. 0 keeps the reward
    continuous; a positive value makes every feasible stroke beat every nearly-feasible one
    (a step that PSO tolerates and RL may not)."""

    def __post_init__(self) -> None:
        for name in ("weight", "offset"):
            store_checked(self, name, check_real, "", 0.0, 1e6)
        if self.weight == 0.0 and self.offset == 0.0:
            raise ValueError(
                "PenaltyConfig.weight and PenaltyConfig.offset are both 0, so infeasible strokes "
                "would not be penalised; allowed: weight > 0 or offset > 0"
            )

    def penalty(self, violation: np.ndarray, feasible: np.ndarray) -> np.ndarray:
        """Penalty (B,) [reward units] of normalised violations (B,) and feasibility flags (B,)."""
        # Exactly 0.0 for feasible strokes (violation == 0 there), so reward == objective.
        return np.where(feasible, 0.0, self.weight * violation + self.offset)


#: ``gym.make`` kwargs of the :class:`PenaltyConfig` fields -> field name.
_PENALTY_KWARGS: dict[str, str] = {f"penalty_{f.name}": f.name for f in fields(PenaltyConfig)}


@dataclass(frozen=True, kw_only=True)
class FlightConfig:
    """Options every flight environment shares (the model, the penalty, the action handling)."""

    insect: Dragonfly = field(default_factory=Dragonfly)
    """The insect (wings, planform, masses, air); default the paper's specimen, tear-drop wings.
    A mapping of the fields that differ from it, or a YAML file's path holding one, is read
    into a :class:`~tandem_env.physics.Dragonfly` (:func:`~tandem_env.physics.insect.load_insect`,
    docs/envs.md)."""
    options: ModelOptions = field(default_factory=ModelOptions)
    """Model resolution, inflow coupling and conventions (``thrust_split`` among them)."""
    penalty: PenaltyConfig = field(default_factory=PenaltyConfig)
    """How constraint violations lower the reward."""
    clip_actions: bool = False
    """Clip actions into [-1, 1]; else one outside raises ``ValueError`` (non-finite: always)."""
    backend: str = "numba"
    """The model's implementation (``tandem_env.physics.BACKENDS``): ``"numba"``, the compiled
    kernel (default), or ``"torch"``, its port (the same results within 1e-8; imports torch)."""
    device: str | None = None
    """The torch device of ``backend="torch"`` (``"cpu"``, ``"cuda"``, ``"cuda:1"``; None: the
    CPU), stored by its canonical name; only with the torch backend."""

    #: The task's declaration (condition, objectives, constraints, sweep): its one home.
    DECLARATION: ClassVar[TaskDeclaration | None] = None
    #: The task's name in messages (``DECLARATION.name``).
    name: ClassVar[str] = "FlightConfig"
    #: ``DECLARATION.condition`` (None for a task without one condition), read from it.
    CONDITION: ClassVar[TaskCondition | None] = None
    #: ``DECLARATION.objectives``, read from it.
    OBJECTIVES: ClassVar[TaskObjectives | None] = None
    #: The ``info`` key reporting the observed condition: ``CONDITION.keyword`` where declared.
    condition_key: ClassVar[str] = ""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        check_declarations(cls)  # a declaration naming a missing field fails at import
        declared = cls.__dict__.get("DECLARATION")
        if declared is not None:
            cls.name = declared.name
            cls.CONDITION, cls.OBJECTIVES = declared.condition, declared.objectives
            if declared.condition is not None:
                cls.condition_key = declared.condition.keyword

    def __post_init__(self) -> None:
        owner = type(self).__name__
        object.__setattr__(self, "insect", load_insect(self.insect, f"{owner}.insect"))
        kinds = {
            "options": (ModelOptions, "a tandem_env.ModelOptions instance"),
            "penalty": (PenaltyConfig, "a tandem_env.envs.PenaltyConfig"),
            "clip_actions": (bool | np.bool_, "True or False"),
        }
        for name, (kind, allowed) in kinds.items():
            if not isinstance(getattr(self, name), kind):
                raise refusal(f"{owner}.{name}", getattr(self, name), allowed)
        object.__setattr__(self, "clip_actions", bool(self.clip_actions))
        try:
            backend, device = check_backend(self.backend, self.device)
        except ValueError as error:
            raise ValueError(f"{owner}: {error}") from None
        object.__setattr__(self, "backend", backend)
        object.__setattr__(self, "device", device)
        chosen = self.OBJECTIVES.keyword if self.OBJECTIVES is not None else None
        if chosen is not None and getattr(self, chosen) not in self.OBJECTIVES.choices:
            allowed = ", ".join(map(repr, self.OBJECTIVES.choices))
            raise refusal(f"{owner}.{chosen}", getattr(self, chosen), allowed)
        if self.CONDITION is not None:  # its envelope, fixed value or range
            normalise_condition(self)
        for spec in fields(self):  # a task's real fields, each declared with its unit and range
            if "real" in spec.metadata:
                store_checked(self, spec.name, check_real, *spec.metadata["real"])

    # --- the observed flight condition (read from the fields CONDITION names) ---------------
    @property
    def declared_condition(self) -> TaskCondition:
        """``CONDITION``; NotImplementedError for a config that declares none."""
        if self.CONDITION is None:
            raise NotImplementedError(f"{type(self).__name__} declares no CONDITION")
        return self.CONDITION

    @property
    def envelope(self) -> tuple[float, float]:
        """The range the observed condition is normalised over, to [-1, 1]."""
        return getattr(self, self.declared_condition.envelope_keyword)

    @property
    def condition_range(self) -> tuple[float, float] | None:
        """The range the condition is sampled from at reset, or None for a fixed condition."""
        return getattr(self, f"{self.condition_key or self.declared_condition.keyword}_range")

    @property
    def fixed_condition(self) -> float | None:
        """The fixed condition (``condition_key``'s), or None when it is sampled."""
        return getattr(self, self.condition_key or self.declared_condition.keyword)

    @property
    def objective_metric(self) -> str:
        """The ``info`` metric (a ``Result`` field) this config maximises, e.g. ``"efficiency"``."""
        if self.OBJECTIVES is None:
            raise NotImplementedError(f"{type(self).__name__} declares no OBJECTIVES")
        return self.OBJECTIVES.metric(self)

    @property
    def available_power(self) -> float:
        """The power cap [W/kg]: the insect's maximum (90 W/kg, docs/model.md §7), unless the
        task's condition is the available power (Accelerate's field of that name)."""
        return self.insect.max_power_per_mass

    @property
    def thrust_split(self) -> str:
        """The thrust/drag reading used (docs/model.md §7)."""
        return self.options.thrust_split

    @property
    def planform(self) -> str:
        """The wings' planform."""
        return self.insect.planform

    # --- construction from flat keyword arguments ----------------------------------------------
    @classmethod
    def allowed_kwargs(cls) -> tuple[str, ...]:
        """Every keyword ``from_kwargs`` (and so ``gym.make``) accepts for this task."""
        own = tuple(f.name for f in fields(cls) if f.init)
        return (*own, "planform", "rotational_coefficient", *MODEL_OPTION_KWARGS, *_PENALTY_KWARGS)

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> FlightConfig:
        """Build the config from the ``gym.make`` kwargs: the fields, ``planform`` and
        ``rotational_coefficient`` (C_r of both wings [-], Table 3) over ``insect``, every
        :data:`MODEL_OPTION_KWARGS` over ``options`` (default the config's own),
        ``penalty_weight`` / ``penalty_offset`` over ``penalty``; a condition's old keyword is
        refused naming the new one."""
        renamed = cls.CONDITION.renamed() if cls.CONDITION is not None else {}
        old = sorted(set(kwargs) & set(renamed))
        if old:
            raise ValueError(
                f"{cls.name}: {', '.join(f'{k!r} was renamed; use {renamed[k]!r}' for k in old)}"
            )
        unknown = sorted(set(kwargs) - set(cls.allowed_kwargs()))
        if unknown:
            raise ValueError(
                f"{cls.name}: unknown argument(s) {', '.join(map(repr, unknown))}; allowed: "
                f"{', '.join(sorted(cls.allowed_kwargs()))}"
            )
        kwargs = dict(kwargs)
        insect = kwargs.pop("insect", None)
        insect = Dragonfly() if insect is None else load_insect(insect, f"{cls.name}: insect")
        if "planform" in kwargs:
            planform = kwargs.pop("planform")
            if planform not in PLANFORMS:
                raise refusal(f"{cls.name}: planform", planform, ", ".join(map(repr, PLANFORMS)))
            insect = insect.with_planform(planform)
        if "rotational_coefficient" in kwargs:
            given = kwargs.pop("rotational_coefficient")
            c_r = check_real(cls.name, "rotational_coefficient", given, "", 0, 100)
            wings = {
                w: replace(getattr(insect, w), rotational_coefficient=c_r) for w in ("fore", "hind")
            }
            insect = replace(insect, **wings)
        for name in _REAL_MODEL_OPTIONS:
            if name in kwargs and not is_real(kwargs[name]):
                raise refusal(f"{cls.name}: {name}", kwargs[name], "a finite number")
        allowed = "a tandem_env.ModelOptions"
        options = _overridden(cls, kwargs, "options", MODEL_OPTION_KWARGS, allowed)
        penalty = kwargs.get("penalty")
        if isinstance(penalty, Mapping):
            extra = sorted(set(penalty) - {f.name for f in fields(PenaltyConfig)})
            if extra:
                raise ValueError(
                    f"{cls.name}: penalty has unknown key(s) {extra}; allowed: weight, offset"
                )
            kwargs["penalty"] = PenaltyConfig(**penalty)
        allowed = "a PenaltyConfig or a dict of its fields (weight, offset)"
        penalty = _overridden(cls, kwargs, "penalty", _PENALTY_KWARGS, allowed)
        return cls(insect=insect, options=options, penalty=penalty, **kwargs)

    def describe(self) -> str:
        """One line naming the condition, for titles and reprs (the declared condition's)."""
        return self.declared_condition.describe(self.fixed_condition, self.condition_range)


# --- the env layer's validators ------------------------------------------------------------
RENDER_MODES: tuple[str, ...] = ("human", "rgb_array")


def check_real(owner: str, name: str, value: Any, unit: str, low: float, high: float) -> float:
    """``value`` as a float if it is a finite real number in [low, high]; else a ValueError."""
    if not is_real(value) or not math.isfinite(value) or not low <= value <= high:
        allowed = f"a finite number from {low:g} to {high:g}{' ' + unit if unit else ''}"
        raise refusal(f"{owner}.{name}", value, allowed, unit)
    return float(value)


def check_interval(
    owner: str, name: str, value: Any, unit: str, limits: tuple[float, float]
) -> tuple[float, float]:
    """``value`` as a ``(low, high)`` float pair with limits[0] <= low < high <= limits[1]."""
    pair = () if isinstance(value, str | bytes) or not hasattr(value, "__len__") else tuple(value)
    finite = len(pair) == 2 and all(is_real(v) and math.isfinite(v) for v in pair)
    if not (finite and limits[0] <= pair[0] < pair[1] <= limits[1]):
        allowed = f"a pair (low, high) of finite numbers with {limits[0]:g} <= low < high <= "
        raise refusal(f"{owner}.{name}", value, f"{allowed}{limits[1]:g} {unit}", unit)
    return float(pair[0]), float(pair[1])


def store_checked(config: Any, name: str, check: Callable[..., Any], *limits: Any) -> Any:
    """Check the field ``name`` of the frozen dataclass ``config`` with ``check(owner, name,
    value, *limits)`` (a validator above) and store what it returns; that value."""
    value = check(type(config).__name__, name, getattr(config, name), *limits)
    object.__setattr__(config, name, value)
    return value


def check_render_mode(render_mode: Any) -> str | None:
    """``render_mode`` if it is None or one of :data:`RENDER_MODES`."""
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise refusal("render_mode", render_mode, f"None, {', '.join(map(repr, RENDER_MODES))}")
    return render_mode


def action_array(actions: Any, shape: tuple[int, ...]) -> np.ndarray:
    """``actions`` as a float64 array of ``shape`` (real numbers; values not checked yet)."""
    if len(shape) == 1:
        what, allowed = "action", f"{N_PARAMETERS} real numbers in [-1, 1] (a normalised stroke)"
    else:
        what, allowed = "actions", f"real numbers of shape {shape} (one normalised stroke per env)"
    arr = real_array(actions, what, allowed)
    if arr.shape != shape:
        raise ValueError(
            f"{what} must have shape {shape} here (one normalised stroke of {N_PARAMETERS} "
            f"parameters per env, fore-wing first); got shape {arr.shape}"
        )
    return arr


def action_values(arr: np.ndarray, clip: bool) -> np.ndarray:
    """Actions (an array from :func:`action_array`) finite and inside [-1, 1], or clipped into
    it when ``clip``; only the actions that are evaluated are checked (a vector env ignores the
    actions of the sub-envs it resets)."""
    flat = arr.reshape(-1, N_PARAMETERS)
    finite = np.isfinite(flat)
    if not finite.all():
        row, col = np.argwhere(~finite)[0]
        raise ValueError(
            f"action {row}: {PARAMETER_NAMES[col]} = {flat[row, col]!r} is not finite; "
            "allowed: finite numbers in [-1, 1]"
        )
    if clip:
        return np.clip(arr, -1.0, 1.0)
    outside = np.abs(flat) > 1.0
    if outside.any():
        row, col = np.argwhere(outside)[0]
        raise ValueError(
            f"action {row}: {PARAMETER_NAMES[col]} = {shown(flat[row, col], -1, 1)} is outside "
            "the action space; allowed: [-1, 1]. A client that does not clip its policy's "
            "actions to the space (skrl, a hand-written loop) should make the env with "
            "clip_actions=True, which clips them"
        )
    return arr


def reset_options(
    owner: str,
    options: Any,
    ranges: Mapping[str, tuple[float, float, str, str]],
    renamed: Mapping[str, str],
) -> dict[str, float]:
    """The numbers ``options`` of ``reset`` set (empty for None): its keys all of ``ranges``
    (key -> (low, high, unit, what that range is)), each value finite and in its range; an
    old key of ``renamed`` is refused naming its new one."""
    if not options:
        return {}
    if not isinstance(options, Mapping):
        raise refusal("reset options", options, "None or a dict")
    for key in options:
        if key in renamed:
            raise ValueError(f"{owner}: reset option {key!r} was renamed; use {renamed[key]!r}")
    unknown = sorted(set(options) - set(ranges))
    if unknown:
        raise ValueError(
            f"{owner}: unknown reset option(s) {unknown}; allowed: {', '.join(map(repr, ranges))}"
        )
    values = {}
    for key, value in options.items():
        low, high, unit, where = ranges[key]
        if not is_real(value) or not math.isfinite(value) or not low <= value <= high:
            allowed = f"a number in {where} {low:g} to {high:g} {unit}"
            raise refusal(f"{owner}: reset option {key}", value, allowed)
        values[key] = float(value)
    return values
