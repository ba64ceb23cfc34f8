"""Study presets: which conditions, seeds, method and budgets a study run uses (frozen, validated).

``quick`` takes minutes on 2 cores, ``paper`` is the full study, ``tiny`` is for the tests only.
Method and budgets come from the convergence study (docs/reproduction.md, "Method and budget:
the convergence study")."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, NoReturn

from agents.tasks import get_task
from tandem_env.envs import AccelerateConfig, LevelFlightConfig, TaskCondition
from tandem_env.envs.reference import table_strokes

#: The accelerating objectives the studies run (the paper's Figs. 7-8), of the declared choices.
STUDIED_OBJECTIVES: tuple[str, ...] = ("vertical", "horizontal")
assert set(STUDIED_OBJECTIVES) <= set(AccelerateConfig.OBJECTIVES.choices)  # type: ignore[union-attr]

_SPEED, _POWER = LevelFlightConfig.CONDITION, AccelerateConfig.CONDITION
#: Level-flight speeds of the paper's sweep (Figs. 4-6, 15) [m/s]: the env's declared sweep.
PAPER_SPEEDS: tuple[float, ...] = _SPEED.sweep
#: Available powers of the paper's sweep (Figs. 7-8, 16) [W/kg]: 30-60 % flight muscle.
PAPER_POWERS: tuple[float, ...] = _POWER.sweep
#: Env keywords a preset may not set: each job sets the condition and the objective.
_PER_JOB_KWARGS: frozenset[str] = frozenset(
    {_SPEED.keyword, _POWER.keyword, str(AccelerateConfig.OBJECTIVES.keyword)}
)


#: Warm starts of a search (``Preset.warm_start``, ``eval optimize --warm-start``): none (a cold
#: start), or the reference table's optimum at the job's condition and its grid neighbours'.
WARM_STARTS: tuple[str, ...] = ("none", "table")
#: The share of a warm-started run's budget its table strokes are polished on (together); the
#: search and its polish get the rest (docs/reference.md, "Warm starts").
WARM_SHARE = 0.25


def warm_start(task: str, condition: float, env_kwargs: Mapping[str, Any]) -> dict[str, Any]:
    """The method settings of a warm start from the reference table: its strokes at
    ``condition`` (:func:`~tandem_env.envs.reference.table_strokes`) as the polish's
    ``initial`` strokes on :data:`WARM_SHARE` of the budget; ValueError saying why the table
    has none for this problem and condition."""
    strokes = table_strokes(get_task(task).env_id, env_kwargs, condition)
    return {"initial": [list(s) for s in strokes], "initial_share": WARM_SHARE}


#: The field of :class:`Preset` that budgets each task the studies run (the paper's two).
BUDGET_FIELDS: dict[str, str] = {"level": "level_budget", "accelerate": "accelerate_budget"}


def is_int(value: Any, low: int) -> bool:
    """Whether ``value`` is an integer (not a bool) >= ``low``."""
    return isinstance(value, int) and not isinstance(value, bool) and value >= low


def is_number(value: Any) -> bool:
    """Whether ``value`` is a finite int or float (not a bool)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def is_name(value: Any) -> bool:
    """Whether ``value`` is a non-empty text without outer spaces (a method name or spec)."""
    return isinstance(value, str) and bool(value) and value == value.strip()


def distinct(values: Any, item: Callable[[Any], bool]) -> bool:
    """Whether ``values`` is a non-empty tuple of distinct items that each pass ``item``."""
    ok = isinstance(values, tuple) and len(values) > 0 and all(map(item, values))
    return ok and len(set(values)) == len(values)


def fail(name: str, value: Any, allowed: str, owner: str = "Preset") -> NoReturn:
    """Raise the ValueError of a refused field: ``Preset.seeds = (); allowed: ...``."""
    raise ValueError(f"{owner}.{name} = {value!r}; allowed: {allowed}")


def _check_values(name: str, values: Any, condition: TaskCondition) -> None:
    """``values`` must be distinct, increasing and inside the env's default envelope."""
    low, high = condition.envelope
    inside = lambda v: is_number(v) and low <= v <= high  # noqa: E731
    if not distinct(values, inside) or list(values) != sorted(values):
        allowed = f"a non-empty, increasing tuple of distinct numbers from {low:g} to {high:g}"
        fail(name, values, f"{allowed} {condition.unit}")


@dataclass(frozen=True)
class ConvergenceSpec:
    """The budget study: each method at one level and one accelerating condition, long runs.

    Every method compared has the prefix property (a run with budget B is the first B
    evaluations of any longer run with the same seed: agents/cmaes_search.py, agents/pso.py),
    so one long run per seed gives the best-so-far at every smaller budget."""

    budget: int
    """Model evaluations per run [-]."""
    seeds: tuple[int, ...]
    """Independent runs per method and condition."""
    speed: float = 1.5
    """Level-flight condition [m/s] (the paper's best-efficiency speed)."""
    power: float = 60.0
    """Accelerating condition [W/kg], objective ``vertical``."""
    methods: tuple[str, ...] = ("pso", "cmaes")
    """Harness methods compared side by side, besides any the study is run with; their long
    runs have no polish (it would end the prefix property)."""
    polish_shares: tuple[float, ...] = (0.0, 0.25, 0.4)
    """The budget splits compared at the preset's own budgets: the share of the preset's
    method's budget kept for the local polish (``polish_share``; 0: no polish)."""

    def __post_init__(self) -> None:
        owner = "ConvergenceSpec"
        if not is_int(self.budget, 2):
            fail("budget", self.budget, "an integer >= 2", owner)
        if not distinct(self.seeds, lambda s: is_int(s, 0)):
            fail("seeds", self.seeds, "distinct integers >= 0", owner)
        if not distinct(self.methods, is_name):
            fail("methods", self.methods, "distinct method names such as ('pso', 'cmaes')", owner)
        share = lambda v: is_number(v) and (v == 0 or 0.01 <= v <= 0.9)  # noqa: E731
        if not distinct(self.polish_shares, share):
            allowed = "distinct numbers, each 0 (no polish) or in [0.01, 0.9]"
            fail("polish_shares", self.polish_shares, allowed, owner)
        _check_values("convergence speed", (self.speed,), _SPEED)
        _check_values("convergence power", (self.power,), _POWER)


@dataclass(frozen=True)
class Preset:
    """Everything that decides which optimisations a study runs (not how many workers)."""

    name: str
    """Preset name; part of every job's configuration hash."""
    description: str
    """One line for ``--help`` and the report."""
    seeds: tuple[int, ...]
    """Independent optimisations per condition; statistics are over these seeds."""
    level_budget: int
    """Model evaluations per level-flight optimisation [-]."""
    accelerate_budget: int
    """Model evaluations per accelerating-flight optimisation [-]."""
    speeds: tuple[float, ...]
    """Speed sweep (Figs. 4-6) [m/s]."""
    powers: tuple[float, ...]
    """Power sweep (Figs. 7-8) [W/kg], a vertical and a horizontal optimisation each."""
    shape_speeds: tuple[float, ...]
    """Speeds of the wing-shape study (Fig. 15) [m/s]; the tear-drop side reuses the sweep."""
    shape_powers: tuple[float, ...]
    """Powers of the wing-shape study (Fig. 16) [W/kg]."""
    convergence: ConvergenceSpec
    """The budget study behind ``level_budget`` and ``accelerate_budget``."""
    kinematics_speed: float = 1.25
    """Level condition of Figs. 9, 11, 12, 13 [m/s] (the paper's choice)."""
    kinematics_power: float = 60.0
    """Accelerating condition of Figs. 10-12 [W/kg] (the paper's choice)."""
    kinematics_objective: str = "vertical"
    """Which accelerating optimisation's stroke Figs. 10-12 show (the paper does not say)."""
    phase_speed: float = 2.0
    """Speed of the paper's largest fore/hind phase difference (hind leads by ~30°) [m/s]."""
    method: str = "cmaes"
    """The studies' default method (``--method`` overrides), chosen by the convergence study."""
    swarm_size: int = 40
    """PSO particles (the harness default); also the random-search batch."""
    env_kwargs: tuple[tuple[str, Any], ...] = field(default=())
    """Extra env keywords for every job, e.g. ``(("n_time", 32),)`` in the test preset."""
    warm_start: str = "table"
    """How each search at the preset's budgets starts (:data:`WARM_STARTS`): ``table`` polishes
    the reference table's strokes first where it has the job's problem and condition (the
    report says where it has not), ``none`` starts cold."""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            fail("name", self.name, "an identifier such as 'quick'")
        if not distinct(self.seeds, lambda s: is_int(s, 0)):
            fail("seeds", self.seeds, "a non-empty tuple of distinct integers >= 0")
        if not is_int(self.swarm_size, 2):
            fail("swarm_size", self.swarm_size, "an integer >= 2")
        for name in BUDGET_FIELDS.values():
            value = getattr(self, name)
            if not is_int(value, self.swarm_size):
                fail(name, value, f"an integer >= swarm_size ({self.swarm_size}) evaluations")
        for name in ("speeds", "shape_speeds", "powers", "shape_powers"):
            _check_values(name, getattr(self, name), _SPEED if "speed" in name else _POWER)
        speeds = tuple(sorted({self.kinematics_speed, self.phase_speed}))
        _check_values("kinematics_speed/phase_speed", speeds, _SPEED)
        _check_values("kinematics_power", (self.kinematics_power,), _POWER)
        if self.kinematics_objective not in STUDIED_OBJECTIVES:
            allowed = " or ".join(map(repr, STUDIED_OBJECTIVES))
            fail("kinematics_objective", self.kinematics_objective, allowed)
        if not is_name(self.method):
            fail("method", self.method, "a harness method name such as 'cmaes' or 'pso'")
        if self.warm_start not in WARM_STARTS:
            fail("warm_start", self.warm_start, " or ".join(map(repr, WARM_STARTS)))
        if not isinstance(self.convergence, ConvergenceSpec):
            fail("convergence", self.convergence, "a ConvergenceSpec")
        keys = [k for k, _ in self.env_kwargs]
        if len(set(keys)) != len(keys) or any(k in _PER_JOB_KWARGS for k in keys):
            allowed = "distinct (name, value) pairs; the condition and objective are set per job"
            fail("env_kwargs", self.env_kwargs, allowed)

    @property
    def budgets(self) -> dict[str, int]:
        """Evaluations per optimisation, per task (:data:`BUDGET_FIELDS`)."""
        return {task: getattr(self, name) for task, name in BUDGET_FIELDS.items()}

    def budget(self, task: str) -> int:
        """Evaluations per optimisation of ``task``; ValueError for a task the preset does not
        budget."""
        if task not in BUDGET_FIELDS:
            raise ValueError(
                f"Preset {self.name!r} has no budget for task {task!r}; allowed: "
                f"{', '.join(map(repr, BUDGET_FIELDS))}"
            )
        return getattr(self, BUDGET_FIELDS[task])


QUICK = Preset(
    name="quick",
    description=(
        "CMA-ES, 3 seeds, 8 000 (level) / 4 000 (accelerating) evaluations per optimisation, "
        "5 speeds, 3 powers, both planforms at 3 speeds and 2 powers; measured wall times "
        "in docs/reproduction.md; warm-started from the reference table"
    ),
    seeds=(0, 1, 2),
    method="cmaes",
    level_budget=8_000,
    accelerate_budget=4_000,
    speeds=(0.5, 1.0, 1.25, 1.5, 2.0),
    powers=(50.0, 60.0, 90.0),
    shape_speeds=(1.0, 1.5, 2.0),
    shape_powers=(50.0, 90.0),
    convergence=ConvergenceSpec(budget=24_000, seeds=(0, 1, 2, 3)),
)

PAPER = Preset(
    name="paper",
    description=(
        "CMA-ES, 8 seeds, 16 000 (level) / 12 000 (accelerating) evaluations per optimisation, "
        "all 8 speeds and 5 powers, both planforms everywhere; measured wall times in "
        "docs/reproduction.md; warm-started from the reference table"
    ),
    seeds=(0, 1, 2, 3, 4, 5, 6, 7),
    method="cmaes",
    level_budget=16_000,
    accelerate_budget=12_000,
    speeds=PAPER_SPEEDS,
    powers=PAPER_POWERS,
    shape_speeds=PAPER_SPEEDS,
    shape_powers=PAPER_POWERS,
    convergence=ConvergenceSpec(budget=60_000, seeds=(0, 1, 2, 3, 4, 5, 6, 7)),
)

#: The presets offered on the command line.
STUDY_PRESETS: dict[str, Preset] = {p.name: p for p in (QUICK, PAPER)}

#: For the tests only: seconds, not minutes (coarse model resolution, 8 particles, 2 seeds).
TINY = Preset(
    name="tiny",
    description="test preset: 2 seeds, 16 evaluations, coarse model",
    seeds=(0, 1),
    level_budget=16,
    accelerate_budget=16,
    speeds=(1.25, 2.0),
    powers=(50.0, 90.0),
    shape_speeds=(2.0,),
    shape_powers=(90.0,),
    convergence=ConvergenceSpec(budget=64, seeds=(0, 1), speed=2.0, power=90.0),
    kinematics_power=90.0,
    method="pso",  # its budgets are below one CMA-ES population (52)
    swarm_size=8,
    env_kwargs=(("n_blade", 6), ("n_time", 32)),
)


#: The preset fields each ``python -m eval study`` option sets: the sweeps of a condition (the
#: wing-shape study's too), the seeds (the convergence study's too), every task's budget.
OVERRIDES: dict[str, tuple[str, ...]] = {
    "speeds": ("speeds", "shape_speeds"),
    "powers": ("powers", "shape_powers"),
    "seeds": ("seeds", "convergence.seeds"),
    "budget": tuple(BUDGET_FIELDS.values()),
}


def overridden(preset: Preset, **given: Any) -> Preset:
    """``preset`` with the command line's values ``given`` (keys of :data:`OVERRIDES`; None:
    the preset's), checked by the preset; ValueError naming the option. Its description says
    what was changed."""
    changed = []
    for option, value in given.items():
        if value is None:
            continue
        listed = isinstance(value, list)
        shown = " ".join(f"{v:g}" for v in value) if listed else f"{value}"
        values = dict.fromkeys(OVERRIDES[option], tuple(value) if listed else value)
        try:
            if (seeds := values.pop("convergence.seeds", None)) is not None:
                values["convergence"] = replace(preset.convergence, seeds=seeds)
            preset = replace(preset, **values)
        except ValueError as error:
            raise ValueError(f"--{option}: {error}") from None
        changed.append(f"--{option} {shown}")
    changes = f"{preset.description}; changed on the command line: {', '.join(changed)}"
    return replace(preset, description=changes) if changed else preset


def get_preset(name: str) -> Preset:
    """The named command-line preset."""
    try:
        return STUDY_PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown preset {name!r}; allowed: {', '.join(STUDY_PRESETS)}") from None
