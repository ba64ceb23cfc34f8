"""A reading of the paper: one named, documented choice for each decision the paper leaves open.

The paper leaves modelling decisions open (docs/model.md §1.3, §5, §6, §7: thrust and drag,
power, C_r, spin, hover inflow, C_hf, F̄_h). A :class:`Reading` names one combination of them
and changes only the env keywords of the studies' jobs (:meth:`eval.studies.base.StudyPlan.jobs`);
the default reading changes nothing. The paper does not state its search either (PSO, no swarm
size or stopping rule): a reading may carry a :class:`Search` that replaces the plan's method and
budgets (:data:`PAPER_SEARCHES`, docs/efficiency.md)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any

from agents.methods import get_method, preset_batch_setting
from agents.polish import split_settings
from agents.tasks import available_tasks
from eval.studies.presets import fail, is_int, is_name, is_number
from tandem_env import Dragonfly, ModelOptions
from tandem_env.envs import ACCELERATE
from tandem_env.envs.config import MODEL_OPTION_KWARGS
from tandem_env.envs.declaration import refusal

#: ModelOptions fields that set the numerics (resolution, solver), not a reading of the paper.
NUMERICAL_OPTIONS: frozenset[str] = frozenset({"n_time", "n_blade", "tolerance", "max_evaluations"})
#: The ModelOptions fields a reading may set: every modelling decision.
DECISION_OPTIONS: tuple[str, ...] = tuple(
    f.name for f in fields(ModelOptions) if f.name not in NUMERICAL_OPTIONS
)
DECISIONS = f"modelling decisions: {', '.join(DECISION_OPTIONS)}"
#: Accelerating-flight objectives whose optimum can stand for the paper's F̄_h (Fig. 7).
CHOICES: tuple[str, ...] = ACCELERATE.objectives.choices  # type: ignore[assignment]
HORIZONTAL_OBJECTIVES: tuple[str, ...] = tuple(o for o in CHOICES if o.startswith("horizontal"))
#: A reading's changes besides its model options (:meth:`Reading.changes`).
OWN_FIELDS = ("rotational_coefficient", "horizontal_objective", "search")
#: C_r of the default insect's wings (Table 3: π) [-].
DEFAULT_ROTATIONAL = Dragonfly().fore.rotational_coefficient
_KWARG_OF = {option: kwarg for kwarg, option in MODEL_OPTION_KWARGS.items()}


def _fail(name: str, field_name: str, value: Any, allowed: str) -> None:
    raise ValueError(f"Reading {name!r}: {field_name} = {value!r}; allowed: {allowed}")


def _pairs(value: Any, where: str) -> tuple[tuple[str, Any], ...]:
    """``value`` (pairs or a mapping) as sorted (name, value) pairs with distinct names."""
    items = value.items() if isinstance(value, Mapping) else value
    try:
        pairs = tuple(sorted((k, v) for k, v in items))
    except (TypeError, ValueError):
        raise refusal(where, value, "(name, value) pairs or a mapping") from None
    names = [k for k, _ in pairs]
    if not all(isinstance(k, str) and k for k in names) or len(set(names)) != len(names):
        raise ValueError(f"{where} = {value!r}; allowed: each name once, as text")
    return pairs


@dataclass(frozen=True)
class Search:
    """How every job of a reading searches (method, budget, settings), replacing the plan's
    method and the preset's budget: ``swarm_size`` × ``iterations`` evaluations for every task,
    or ``budgets`` per task, or the preset's; a polish takes its share of it."""

    method: str
    """A harness method name, e.g. ``"pso"`` (:func:`agents.methods.available_methods`)."""
    swarm_size: int | None = None
    """Strokes per iteration (the method's batch), >= 2; None: the plan's."""
    iterations: int | None = None
    """Iterations per run (the initial swarm counts as one), >= 1; with ``swarm_size`` the
    budget of every task."""
    budgets: tuple[tuple[str, int], ...] = ()
    """Model evaluations per run by task name, sorted (a mapping is accepted); a task not named
    keeps the preset's."""
    settings: tuple[tuple[str, Any], ...] = ()
    """Method settings, e.g. ``{"polish": "none"}``, sorted (or a mapping)."""

    def __post_init__(self) -> None:
        method = self.method
        if not is_name(method) or ":" in method:
            allowed = "a harness method name without ':' such as 'pso' or 'cmaes'"
            fail("method", method, allowed, "Search")
        for name, low in (("swarm_size", 2), ("iterations", 1)):
            value = getattr(self, name)
            if value is not None and not is_int(value, low):
                fail(name, value, f"None or an integer >= {low}", "Search")
        if self.iterations is not None and self.swarm_size is None:
            raise ValueError(
                f"Search.iterations = {self.iterations!r} without swarm_size; allowed: both "
                "(budget = swarm_size × iterations) or neither"
            )
        budgets = _pairs(self.budgets, "Search.budgets")
        tasks = available_tasks()
        for task, value in budgets:
            if task not in tasks or not is_int(value, 1):
                allowed = f"tasks {', '.join(tasks)} with an integer >= 1 (model evaluations)"
                fail(f"budgets[{task!r}]", value, allowed, "Search")
        if budgets and self.iterations is not None:
            raise ValueError(
                f"Search.budgets = {dict(budgets)!r} and iterations = {self.iterations!r}; "
                "allowed: one of the two"
            )
        settings = _pairs(self.settings, "Search.settings")
        given = {k for k, _ in settings}
        if budget_keys := sorted(given & {"iterations", "max_evaluations", "budget"}):
            raise ValueError(
                f"Search.settings sets {budget_keys}; allowed: the budget as iterations or "
                "budgets, not a method setting"
            )
        if self.swarm_size is not None and "swarm_size" in given:
            raise ValueError(
                f"Search.settings sets ['swarm_size'] and swarm_size = {self.swarm_size!r}; "
                "allowed: the batch size once, as swarm_size"
            )
        object.__setattr__(self, "budgets", budgets)
        object.__setattr__(self, "settings", settings)
        try:  # the settings are validated by their owners, the polish and the method
            _, own = split_settings(method, dict(settings))
            get_method(method, {**own, **self._batch(None)})
        except (ValueError, NotImplementedError) as error:
            raise ValueError(f"Search of method {method!r}: {error}") from None

    def _batch(self, preset_swarm: int | None) -> dict[str, int]:
        """The batch setting: its ``swarm_size`` (every ask/tell optimiser's alias), else
        ``preset_swarm`` where a study's preset sets the method's batch."""
        if self.swarm_size is not None:
            return {"swarm_size": self.swarm_size}
        key = preset_batch_setting(self.method)
        if key is None or preset_swarm is None or {"swarm_size", key} & dict(self.settings).keys():
            return {}
        return {key: preset_swarm}

    def budget(self, task: str) -> int | None:
        """Model evaluations per run of ``task``; None where the preset's budget stays."""
        if self.iterations is not None:
            assert self.swarm_size is not None  # checked in __post_init__
            return self.swarm_size * self.iterations
        return dict(self.budgets).get(task)

    def method_config(self, preset_swarm: int) -> tuple[tuple[str, Any], ...]:
        """A job's method settings: ``settings`` and the batch (``swarm_size``, else the
        preset's ``preset_swarm``), sorted."""
        return tuple(sorted({**dict(self.settings), **self._batch(preset_swarm)}.items()))

    def to_dict(self) -> dict[str, Any]:
        """Plain form (pairs become dicts); ``Search(**d)`` rebuilds it."""
        return {**asdict(self), "budgets": dict(self.budgets), "settings": dict(self.settings)}

    def describe(self) -> str:
        """``pso 40×50 (2000 evaluations), polish=none``."""
        if self.iterations is not None:
            size = f" {self.swarm_size}×{self.iterations} ({self.budget('level')} evaluations)"
        else:
            size = f" swarm {self.swarm_size}" if self.swarm_size is not None else ""
            size += "".join(f", {t} {b} evaluations" for t, b in self.budgets)
        return self.method + size + "".join(f", {k}={v}" for k, v in self.settings)


@dataclass(frozen=True)
class Reading:
    """One reading of the paper: the options it changes from the documented defaults."""

    name: str
    """Short identifier, e.g. ``"default"`` or ``"body"``; a column of the matrix."""
    description: str
    """One line: what this reading assumes and where the paper leaves it open."""
    options: tuple[tuple[str, Any], ...] = ()
    """:class:`~tandem_env.ModelOptions` fields (``DECISION_OPTIONS``) and values, sorted (a
    mapping is accepted)."""
    rotational_coefficient: float | None = None
    """C_r of both wings [-] (Table 3); None keeps the insect's (π)."""
    horizontal_objective: str = "horizontal"
    """The accelerating objective whose optimum gives F̄_h (``HORIZONTAL_OBJECTIVES``)."""
    search: Search | None = None
    """How every job searches (a :class:`Search` or a mapping of its fields); None: the plan's."""
    derived_from: tuple[str, ...] = field(default=(), compare=False)
    """The single readings a combination was derived from (empty for a single reading)."""

    def __post_init__(self) -> None:
        if not is_name(self.name):
            _fail(str(self.name), "name", self.name, "a non-empty name without outer spaces")
        if any(c in self.name for c in '/\\:*?"<>|'):
            _fail(self.name, "name", self.name, "a name usable as a folder name (no / \\ : * ?)")
        if not isinstance(self.description, str) or not self.description.strip():
            _fail(self.name, "description", self.description, "a one-line description")
        pairs = _pairs(self.options, f"Reading {self.name!r}: options")
        for key in (k for k, _ in pairs if k not in DECISION_OPTIONS):
            _fail(self.name, "options", key, f"ModelOptions fields that are {DECISIONS}")
        object.__setattr__(self, "options", pairs)
        if (c_r := self.rotational_coefficient) is not None and not (is_number(c_r) and c_r >= 0):
            _fail(self.name, "rotational_coefficient", c_r, "None or a finite number >= 0")
        if (objective := self.horizontal_objective) not in HORIZONTAL_OBJECTIVES:
            allowed = ", ".join(map(repr, HORIZONTAL_OBJECTIVES))
            _fail(self.name, "horizontal_objective", objective, allowed)
        try:  # the options and the search are checked by their own classes
            ModelOptions(**dict(pairs))
            if isinstance(self.search, Mapping):
                object.__setattr__(self, "search", Search(**self.search))
        except (TypeError, ValueError) as error:
            raise ValueError(f"Reading {self.name!r}: {error}") from None
        if self.search is not None and not isinstance(self.search, Search):
            _fail(self.name, "search", self.search, "None, a Search or a mapping of its fields")

    @property
    def model_options(self) -> ModelOptions:
        """The model options of this reading (defaults elsewhere)."""
        return ModelOptions(**dict(self.options))

    def changes(self) -> dict[str, Any]:
        """What differs from the documented default, e.g. ``{"thrust_split": "body"}``."""
        default = ModelOptions()
        out = {k: v for k, v in self.options if getattr(default, k) != v}
        if (c_r := self.rotational_coefficient) is not None and c_r != DEFAULT_ROTATIONAL:
            out["rotational_coefficient"] = float(c_r)
        if self.horizontal_objective != "horizontal":
            out["horizontal_objective"] = self.horizontal_objective
        if self.search is not None:
            out["search"] = self.search.to_dict()
        return out

    @classmethod
    def from_changes(
        cls, name: str, description: str, changes: Mapping[str, Any], derived_from: tuple = ()
    ) -> Reading:
        """The reading whose :meth:`changes` are ``changes`` (the inverse of that method)."""
        options = dict(changes)
        own = {k: options.pop(k) for k in OWN_FIELDS if k in options}
        return cls(name, description, tuple(options.items()), **own, derived_from=derived_from)

    def env_kwargs(self) -> dict[str, Any]:
        """The env keywords of the options that differ from the defaults (so a reading that
        restates a default has the default's job keys)."""
        skip = ("horizontal_objective", "search")
        # every option has its env keyword (MODEL_OPTION_KWARGS); C_r is one by its own name
        return {_KWARG_OF.get(k, k): v for k, v in self.changes().items() if k not in skip}

    def objective(self, objective: str) -> str:
        """The accelerating objective a study's ``objective`` becomes under this reading."""
        return self.horizontal_objective if objective == "horizontal" else objective

    def conflicts(self, other: Reading) -> list[str]:
        """The options both readings set to different values (they cannot be combined)."""
        mine, theirs = self.changes(), other.changes()
        return sorted(k for k in mine.keys() & theirs.keys() if mine[k] != theirs[k])

    def describe_changes(self) -> str:
        """``thrust_split=body, power=elastic`` (``-`` for the default)."""
        changes = self.changes()
        if self.search is not None:
            changes["search"] = self.search.describe()
        short = lambda v: f"{v:.4g}" if isinstance(v, float) else str(v)  # noqa: E731
        return ", ".join(f"{k}={short(v)}" for k, v in changes.items()) or "-"


DEFAULT = Reading(
    "default",
    "the documented defaults (docs/model.md): sign thrust split, absolute power, pitch spin, "
    "C_r = π, coupled momentum inflow with C_hf = 1, F̄_h = max F̄_h s.t. F̄_v ≥ 0",
)


def combine(readings: tuple[Reading, ...] | list[Reading], name: str | None = None) -> Reading:
    """One reading with every change of ``readings``; raises ValueError if two conflict."""
    merged: dict[str, Any] = {}
    names = tuple(r.name for r in readings)
    for reading in readings:
        for key, value in reading.changes().items():
            if merged.setdefault(key, value) != value:
                raise ValueError(
                    f"readings {', '.join(names)} conflict on {key}: {merged[key]!r} vs {value!r}"
                )
    return Reading.from_changes(
        name or " + ".join(names),
        "combination of " + "; ".join(r.description for r in readings),
        merged,
        derived_from=names,
    )


def _paper_search(swarm: int, iterations: int) -> Reading:
    return Reading(
        f"pso-{swarm}x{iterations}",
        f"the paper's search unconverged (Sec. II.F names particle swarm optimization and no "
        f"swarm size, iterations or stopping rule; assumed): PSO, {swarm} particles × "
        f"{iterations} iterations = {swarm * iterations} evaluations per optimisation, no local "
        "polish, instead of the preset's method and budget",
        search=Search("pso", swarm_size=swarm, iterations=iterations, settings={"polish": "none"}),
    )


#: The paper-era search budgets (an assumption: swarms of 20-40 particles for 50-100 iterations,
#: the range usual in PSO studies of that time), smallest first; docs/efficiency.md.
PAPER_SEARCHES: tuple[Reading, ...] = tuple(
    _paper_search(swarm, iterations) for swarm, iterations in ((20, 50), (40, 50), (40, 100))
)
#: The middle of that range: 40 particles (the harness default) × 50 iterations.
PAPER_SEARCH: Reading = PAPER_SEARCHES[1]
