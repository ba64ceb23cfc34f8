"""Reference optima and normalised scores: how good a stroke is, against the best one known.

The reference table (``python -m eval reference``, docs/reference.md) holds, per task,
objective and planform, the certified optimum at every condition of :data:`REFERENCE_GRID`
with the default model (a series applies to an env of the same :func:`problem_fingerprint`).
:func:`normalised_score` scores D4RL-style; every other grid point is held out.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tandem_env import physics
from tandem_env.envs.config import EXECUTION_KWARGS, FlightConfig
from tandem_env.envs.registration import ACCELERATE_ID, LEVEL_FLIGHT_ID, config_class
from tandem_env.io.files import to_jsonable
from tandem_env.physics.checks import is_real, real_array
from tandem_env.physics.insect import PLANFORMS
from tandem_env.physics.stroke import N_PARAMETERS

#: Identifies the reference table's format.
REFERENCE_FORMAT = "tandem_env.reference-optima/1"


def _grid(low: float, high: float, step: float) -> tuple[float, ...]:
    count = round((high - low) / step)
    return tuple(round(low + i * step, 9) for i in range(count + 1))


#: The conditions of the table, per env id: (objectives, conditions [the condition's unit]).
REFERENCE_GRID: Mapping[str, tuple[tuple[str, ...], tuple[float, ...]]] = {
    LEVEL_FLIGHT_ID: (("efficiency",), _grid(0.25, 2.0, 0.125)),
    ACCELERATE_ID: (("vertical", "horizontal", "resultant"), _grid(50.0, 90.0, 5.0)),
}


def held_out_conditions(env_id: str) -> tuple[float, ...]:
    """The grid's held-out conditions of ``env_id``: every other point, from the second; a
    policy is trained at the others (:func:`training_conditions`) and judged at these."""
    return REFERENCE_GRID[env_id][1][1::2]


def training_conditions(env_id: str) -> tuple[float, ...]:
    """The grid's training conditions of ``env_id``: those :func:`held_out_conditions` leaves."""
    return REFERENCE_GRID[env_id][1][0::2]


# Fields of a config that do not change the problem a reference solves: how the model is
# computed, how actions are read, how infeasible strokes are penalised (the reference is the
# best feasible objective, whatever the search's penalty), and the condition (per grid point).
_NOT_THE_PROBLEM = (*EXECUTION_KWARGS, "clip_actions", "penalty")


def problem_fingerprint(config: FlightConfig) -> str:
    """The hash of what decides a task's optimum at a given condition: the model options, the
    insect (its planform included) and the task's other settings (constraint tolerance, the
    accelerating flight's speed), not the condition, the objective or how the model runs."""
    return config_fingerprint(type(config), to_jsonable(config))


def config_fingerprint(config_type: type[FlightConfig], data: Mapping[str, Any]) -> str:
    """:func:`problem_fingerprint` of a config as JSON (``to_jsonable(config)``, what a harness
    record keeps as its ``env``)."""
    condition = config_type.CONDITION
    assert condition is not None, config_type
    dropped = {*_NOT_THE_PROBLEM, "description", "objective", *condition.keywords}
    kept = {k: v for k, v in data.items() if k not in dropped}
    text = json.dumps({"task": config_type.name, **kept}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def default_fingerprint(env_id: str, planform: str) -> str:
    """:func:`problem_fingerprint` of ``env_id``'s default config with ``planform``'s wings."""
    return problem_fingerprint(config_class(env_id).from_kwargs(planform=planform))


@dataclass(frozen=True)
class ReferenceSeries:
    """The reference optima of one task, objective and planform over its grid."""

    env_id: str
    objective: str
    planform: str
    fingerprint: str
    """:func:`problem_fingerprint` of the configs the optima were found with."""
    conditions: tuple[float, ...]
    """The grid [the condition's unit], increasing."""
    objectives: tuple[float, ...]
    """The best feasible objective at each condition [the objective's unit]."""
    points: tuple[Mapping[str, Any], ...]
    """Per condition: the stroke (normalised), every seed's objective and the certificate."""

    def at(self, condition: ArrayLike) -> NDArray[np.float64]:
        """The reference objective at ``condition`` (linear between grid points; NaN outside)."""
        value = np.asarray(condition, dtype=float)
        inside = (value >= self.conditions[0]) & (value <= self.conditions[-1])
        return np.where(inside, np.interp(value, self.conditions, self.objectives), np.nan)


@dataclass(frozen=True)
class ReferenceTable:
    """The whole table: every series and how it was made."""

    series: tuple[ReferenceSeries, ...]
    provenance: Mapping[str, Any]
    """The command, package versions, date, budgets and seeds it was made with."""

    @property
    def model(self) -> int | None:
        """The model revision that made it (:data:`~tandem_env.physics.MODEL_REVISION`; None:
        a table from before tables held it)."""
        versions = self.provenance.get("versions")
        return versions.get("model") if isinstance(versions, Mapping) else None

    def get(self, env_id: str, objective: str, planform: str) -> ReferenceSeries:
        """The series of ``env_id``, ``objective`` and ``planform``; ValueError naming what the
        table holds otherwise."""
        for series in self.series:
            if (series.env_id, series.objective, series.planform) == (env_id, objective, planform):
                return series
        held = sorted({(s.env_id, s.objective) for s in self.series})
        raise ValueError(
            f"no reference for {env_id} objective {objective!r} planform {planform!r}; allowed: "
            + "; ".join(f"{e} {o!r}" for e, o in held)
            + f", planform one of {', '.join(map(repr, PLANFORMS))}"
        )

    def find(self, env_id: str, objective: str, fingerprint: str) -> ReferenceSeries | None:
        """The series of ``env_id`` and ``objective`` made with the problem ``fingerprint``
        (:func:`problem_fingerprint`; it tells the planforms apart), or None."""
        key = (env_id, objective, fingerprint)
        return next((s for s in self.series if (s.env_id, s.objective, s.fingerprint) == key), None)

    @classmethod
    def from_dict(cls, data: Any, *, complete: bool = False) -> ReferenceTable:
        """The table in ``data`` (the file's JSON), checked once here (ValueError naming what
        is wrong); ``complete``: every series of :data:`REFERENCE_GRID` over its whole grid,
        every point feasible (the packaged table)."""
        if not isinstance(data, Mapping) or data.get("format") != REFERENCE_FORMAT:
            raise ValueError(f"not a reference table of format {REFERENCE_FORMAT!r}")
        try:
            series = tuple(_series(entry) for entry in data["series"])
            provenance = dict(data["provenance"])
        except (KeyError, TypeError, ValueError) as error:
            what = f"no {error}" if isinstance(error, KeyError) else str(error)
            raise ValueError(f"{what}; allowed: a table python -m eval reference writes") from None
        names = [(s.env_id, s.objective, s.planform) for s in series]
        tasks = REFERENCE_GRID.items()
        wanted = {(e, o, p) for e, (objectives, _) in tasks for o in objectives for p in PLANFORMS}
        missing = sorted(wanted - set(names)) if complete else []
        if len(set(names)) != len(names) or missing:
            raise ValueError(
                f"series {', '.join(map(' '.join, missing)) or 'repeated'}: missing or repeated; "
                "allowed: one series per task, objective and planform"
                + (", all of them" if complete else "")
            )
        for entry in series if complete else ():
            grid = REFERENCE_GRID[entry.env_id][1]
            if entry.conditions != grid or not all(p["feasible"] is True for p in entry.points):
                raise ValueError(
                    f"{entry.env_id} {entry.objective} {entry.planform}: conditions "
                    f"{list(entry.conditions)}, not a feasible optimum at every point of the "
                    f"grid {list(grid)}"
                )
        return cls(series, provenance)


def _series(entry: Any) -> ReferenceSeries:
    """One series of the table's JSON, checked (:meth:`ReferenceTable.from_dict`)."""
    env_id, objective, planform = entry["env_id"], entry["objective"], entry["planform"]
    name = f"{env_id} {objective} {planform}"
    if env_id not in REFERENCE_GRID or objective not in REFERENCE_GRID[env_id][0]:
        raise ValueError(f"series {name}: not a task and objective of the grid")
    if planform not in PLANFORMS or not isinstance(entry["fingerprint"], str):
        raise ValueError(f"series {name}: planform or fingerprint {entry['fingerprint']!r}")
    points = tuple(entry["points"])
    grid = REFERENCE_GRID[env_id][1]
    conditions = tuple(p["condition"] for p in points)
    on_grid = all(is_real(c) and any(abs(c - g) < 1e-9 for g in grid) for c in conditions)
    if not (points and on_grid and np.all(np.diff(conditions) > 0)):
        raise ValueError(
            f"series {name}: conditions {list(conditions)}; allowed: increasing points of the "
            f"grid {list(grid)}"
        )
    for point in points:
        where = f"series {name} at {point['condition']:g}"
        feasible, value = point["feasible"], point["objective"]
        good = is_real(value) and math.isfinite(value) and value > 0
        if not isinstance(feasible, bool) or (feasible and not good):
            raise ValueError(
                f"{where}: objective {value!r}, feasible {feasible!r}; allowed: feasible true or "
                "false, and a finite objective above 0 where feasible"
            )
        stroke = real_array(point["normalised_stroke"], f"{where}: normalised_stroke", "numbers")
        if stroke.shape != (N_PARAMETERS,) or not np.all(np.abs(stroke) <= 1.0):
            raise ValueError(
                f"{where}: normalised_stroke of shape {stroke.shape}; allowed: 28 finite numbers "
                "in [-1, 1]"
            )
    objectives = tuple(float(p["objective"]) if p["feasible"] else math.nan for p in points)
    conditions = tuple(float(c) for c in conditions)
    return ReferenceSeries(
        env_id, objective, planform, entry["fingerprint"], conditions, objectives, points
    )


def reference_path() -> Any:
    """The packaged reference table (a :mod:`importlib.resources` traversable)."""
    return resources.files("tandem_env").joinpath("data", "reference_optima.json")


@functools.cache
def load_reference_table() -> ReferenceTable:
    """The packaged reference table, read once (plain JSON) and checked once
    (:meth:`ReferenceTable.from_dict`, ``complete``); ValueError naming the file for one that
    is not UTF-8 JSON or not a complete table (FileNotFoundError if there is none), a warning
    for one made by another model revision."""
    path = reference_path()
    try:  # FileNotFoundError passes: the callers say how to make the table
        data = json.loads(path.read_text(encoding="utf-8"))
        table = ReferenceTable.from_dict(data, complete=True)
    except (ValueError, RecursionError) as error:  # RecursionError: JSON nested too deeply
        reason = str(error) if isinstance(error, ValueError) else "JSON nested too deeply"
        raise ValueError(
            f"{path}: not a readable reference table ({reason}); allowed: the table python -m "
            "eval reference writes (or the packaged one, reinstalled)"
        ) from None
    if table.model not in (None, physics.MODEL_REVISION):  # None: made before tables held it
        warnings.warn(
            f"{path} was made by model revision {table.model}, not this model's "
            f"{physics.MODEL_REVISION} (tandem_env.physics.MODEL_REVISION): its optima and the "
            "scores against them are the earlier model's; remake it: python -m eval reference",
            stacklevel=2,
        )
    return table


def reference_series(
    env_id: str, *, objective: str | None = None, planform: str = "tear-drop"
) -> ReferenceSeries:
    """The table's series for ``env_id`` (``objective`` None: the env's default objective)."""
    if env_id not in REFERENCE_GRID:
        raise ValueError(
            f"no reference for {env_id!r}; allowed: {', '.join(map(repr, REFERENCE_GRID))}"
        )
    if objective is None:  # every task of the grid declares its objectives
        objective = config_class(env_id).OBJECTIVES.default
    return load_reference_table().get(env_id, objective, planform)


def reference(
    env_id: str, condition: ArrayLike, *, objective: str | None = None, planform: str = "tear-drop"
) -> float | NDArray[np.float64]:
    """The reference objective at ``condition`` [the task's condition unit] of the default
    model: linear between the grid's points; ValueError naming the grid outside it.

    ``objective`` None is the env's default objective (level flight: η; accelerating flight:
    F̄_v, ``"vertical"``).
    """
    series = reference_series(env_id, objective=objective, planform=planform)
    given = real_array(condition, "condition", "finite real numbers [the condition's unit]")
    values = series.at(given)
    if np.isnan(values).any():
        low, high = series.conditions[0], series.conditions[-1]
        raise ValueError(
            f"condition = {condition!r} is not finite or outside the reference grid of {env_id} "
            f"({low:g} to {high:g}); allowed: a value in [{low:g}, {high:g}]"
        )
    return float(values) if values.ndim == 0 else values


def normalised_score(
    reference_objective: ArrayLike, objective: ArrayLike, feasible: ArrayLike, violation: ArrayLike
) -> NDArray[np.float64]:
    """The normalised score (B,) of strokes [100 = the reference]: ``100 · objective /
    reference`` where feasible, else ``-100 · min(1, violation)``; NaN where the reference is
    NaN or not positive. ValueError for what no stroke can be: ``feasible`` not booleans, an
    infinite reference, a negative or NaN violation, a feasible stroke's non-finite objective."""
    ref = real_array(reference_objective, "reference", "real numbers (NaN: none)")
    obj = real_array(objective, "objective", "real numbers [the objective's unit]")
    given = np.asarray(feasible)
    if given.dtype != np.bool_:
        raise ValueError(f"feasible = {feasible!r}; allowed: booleans (True or False)")
    excess = real_array(violation, "violation", "real numbers >= 0")
    flies = np.broadcast_to(given, np.broadcast_shapes(given.shape, obj.shape, excess.shape))
    problems = (  # what a score reads: the objective where feasible, the violation where not
        ("reference", ref, np.isinf(ref), "finite or NaN (none)"),
        ("violation", excess, (excess < 0) | (~flies & np.isnan(excess)), "numbers >= 0"),
        ("objective", obj, flies & ~np.isfinite(obj), "finite where the stroke is feasible"),
    )
    for name, values, bad, allowed in problems:
        if np.any(bad):
            shown = np.broadcast_to(values, bad.shape)[bad][0]
            raise ValueError(f"{name} = {float(shown)!r}; allowed: {allowed}")
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = 100.0 * obj / ref
    score = np.where(flies, ratio, -100.0 * np.minimum(1.0, excess))
    return np.where(ref > 0, score, np.nan)


def _applicable(config_type: type[FlightConfig], data: Mapping[str, Any]) -> ReferenceSeries | None:
    """The table's series for a config given as JSON, or None (no table, another problem)."""
    env_id = next((e for e in REFERENCE_GRID if config_class(e) is config_type), None)
    objectives = config_type.OBJECTIVES
    if env_id is None or objectives is None:
        return None
    objective = objectives.default if objectives.keyword is None else data.get(objectives.keyword)
    try:
        table = load_reference_table()
    except FileNotFoundError:
        return None
    return table.find(env_id, str(objective), config_fingerprint(config_type, data))


def table_strokes(
    env_id: str, env_kwargs: Mapping[str, Any], condition: float
) -> tuple[tuple[float, ...], ...]:
    """The table's normalised strokes for the problem of ``env_id`` made with ``env_kwargs`` at
    ``condition``: the point's optimum, then its grid neighbours' (the feasible ones; what a
    warm start polishes). ValueError saying why there are none: no series of this problem (its
    :func:`problem_fingerprint`), or ``condition`` not a feasible point of the grid."""
    config = config_class(env_id).from_kwargs(**env_kwargs)
    series = ConfigReference(config).series
    if series is None:
        raise ValueError(
            f"the reference table has no {env_id} series of this problem (fingerprint "
            f"{problem_fingerprint(config)}: other model options, insect or settings than the "
            "table's, or no table); allowed: the default model"
        )
    i = next((i for i, c in enumerate(series.conditions) if abs(c - condition) < 1e-9), None)
    if i is None or not series.points[i]["feasible"]:
        raise ValueError(
            f"condition {condition:g} is not a feasible point of the reference table's grid "
            f"{list(series.conditions)}"
        )
    near = [j for j in (i, i - 1, i + 1) if 0 <= j < len(series.points)]
    points = [series.points[j] for j in near if series.points[j]["feasible"]]
    return tuple(dict.fromkeys(tuple(map(float, p["normalised_stroke"])) for p in points))


def record_score(
    env_id: str,
    env: Mapping[str, Any],
    condition: float,
    objective: float,
    feasible: bool,
    violation: float,
) -> float:
    """The normalised score of a stroke flown by the env of ``env_id`` configured as ``env``
    (``to_jsonable(config)``, a harness record's ``env``) at ``condition``; NaN where the
    table does not apply."""
    series = _applicable(config_class(env_id), env) if env_id in REFERENCE_GRID else None
    if series is None:
        return float("nan")
    return float(normalised_score(series.at(condition), objective, feasible, violation))


class ConfigReference:
    """The reference of one env config, or none: what its vector env scores its steps against.

    The table's series applies when the config's :func:`problem_fingerprint` is the series';
    otherwise (other model options, insect or tolerances, or no table) there is no score.
    """

    def __init__(self, config: FlightConfig) -> None:
        self.series = _applicable(type(config), to_jsonable(config))

    def score(
        self, condition: ArrayLike, objective: ArrayLike, feasible: ArrayLike, violation: ArrayLike
    ) -> NDArray[np.float64] | None:
        """The normalised scores (B,) of strokes flown at ``condition`` (B,); None where the
        table does not apply (no ``score`` then, not a NaN that makes equal steps unequal)."""
        if self.series is None:
            return None
        return normalised_score(self.series.at(condition), objective, feasible, violation)


def score_strokes(problem: Any, strokes: ArrayLike, conditions: ArrayLike) -> NDArray[np.float64]:
    """The normalised scores (B,) of normalised strokes (B, 28) flown at ``conditions`` (B,) by
    an env's problem view (``env.unwrapped.problem()``); NaN where the table does not apply."""
    values = np.asarray(conditions, dtype=np.float64)
    found = problem.evaluate(np.asarray(strokes, dtype=np.float64), values)
    violation = problem.declaration.score(found.result, problem.config).total
    reference = ConfigReference(problem.config)
    score = reference.score(values, found.objective, found.feasible, violation)
    return np.full(values.shape, np.nan) if score is None else score
