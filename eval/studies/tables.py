"""Records -> tidy rows (one per optimisation) -> per-condition statistics over seeds.

Statistics use the feasible seeds only; "best" is the value at the feasible seed with the best
objective, so every "best" column describes one and the same stroke."""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.jobs import Job
from agents.records import Record
from tandem_env import PARAMETER_NAMES, TABLE_4, TABLE_4_BOUNDS, StrokeBounds
from tandem_env.physics.stroke import UNBOUNDED, bound_sides, describe_bounds

#: Tidy rows, one per optimisation (:func:`tidy_rows`), and one row as read.
Rows = list[dict[str, Any]]
Row = Mapping[str, Any]
#: Columns that identify a series (one line in a figure).
SERIES_KEYS: tuple[str, ...] = ("method", "task", "objective", "planform")

#: Tidy-row quantities with units (as the figure labels give them).
QUANTITIES: dict[str, str] = {
    "objective_value": "the task's objective: η [-] or F̄ [-]",
    "efficiency": "η = T·V/P [-]",
    "efficiency_pct": "η [%]",
    "thrust_ratio": "T/W [-]",
    "lift_to_weight": "L/W [-]",
    "power_per_mass": "P/m [W/kg]",
    "excess_vertical": "F̄_v [-]",
    "excess_horizontal": "F̄_h [-]",
    "excess_total": "F̄_a of this stroke [-]",
    "mean_angle_of_attack": "mean angle of attack, both wings [deg]",
    "stroke_plane_angle": "β_m, mean of fore and hind [deg]",
    "frequency": "f, mean of fore and hind [Hz]",
    "sweep_amplitude": "φ_m, mean of fore and hind [deg]",
    "pitch_amplitude": "η_m, mean of fore and hind [deg]",
    "phase_difference": "Φ_φ,hind − Φ_φ,fore wrapped to (−180, 180]; > 0: hind leads [deg]",
    "phase_difference_abs": "|phase_difference| [deg]",
    **{
        f"{wing}_{p.name}": f"{p.symbol} of the {wing}-wing: {p.description} [{p.unit}]"
        for wing in ("fore", "hind")
        for p in TABLE_4
    },
}


#: Quantities that are angles on a circle: their statistics are circular (see
#: :func:`circular_median`); +170° and −170° are 20° apart, not 340°.
CIRCULAR: frozenset[str] = frozenset(
    {"phase_difference", *(n for n in PARAMETER_NAMES if n.endswith("_phase"))}
)

#: The stroke quantities of the rows that are the mean of the fore- and hind-wing's parameter.
WING_MEANS = ("stroke_plane_angle", "frequency", "sweep_amplitude", "pitch_amplitude")
#: The Table 4 parameter(s) behind each stroke quantity of the rows: a mean of both wings, or
#: one of the 28 parameters itself (the tidy rows carry all 28, in Table 4 units).
PARAMETERS_OF: dict[str, tuple[str, ...]] = {
    **{q: (f"fore_{q}", f"hind_{q}") for q in WING_MEANS},
    **{name: (name,) for name in PARAMETER_NAMES},
}
#: A parameter is *pinned* at a Table 4 bound at one condition when more than this share of the
#: feasible seeds sit at it (:func:`tandem_env.bound_sides`); a two-wing mean when both wings do.
PINNED_SHARE = 0.5


def table4_bounds(
    quantity: str, bounds: StrokeBounds = TABLE_4_BOUNDS
) -> tuple[float, float] | None:
    """The (low, high) of a stroke quantity's parameters in ``bounds`` when they share one
    range and can sit at a bound; else None."""
    names = PARAMETERS_OF.get(quantity, ())
    index = [PARAMETER_NAMES.index(n) for n in names]
    ranges = {(bounds.lower[i], bounds.upper[i]) for i in index if not UNBOUNDED[i]}
    return ranges.pop() if len(ranges) == 1 and len(index) == len(names) else None


def row_bounds(row: Mapping[str, Any]) -> StrokeBounds:
    """The stroke bounds of a row's insect: Table 4's with the row's ``stroke_bounds`` changes
    (a mapping or its JSON text)."""
    own = row.get("stroke_bounds")
    own = json.loads(own) if isinstance(own, str) and own else own
    return TABLE_4_BOUNDS.with_changes(own) if own else TABLE_4_BOUNDS


def pinned(rows: Sequence[Mapping[str, Any]], quantity: str) -> str:
    """``"lower"``, ``"upper"`` or ``""``: the bound the stroke quantity is pinned at over the
    feasible ``rows`` of one condition (:data:`PINNED_SHARE`)."""
    names = PARAMETERS_OF.get(quantity)
    feasible = [r for r in rows if r["feasible"]]
    if not names or not feasible:
        return ""
    sides = _sides(feasible)[:, [PARAMETER_NAMES.index(n) for n in names]]
    shares = {word: np.mean(sides == side, axis=0) for side, word in ((-1, "lower"), (1, "upper"))}
    return next((word for word, share in shares.items() if np.all(share > PINNED_SHARE)), "")


def _sides(rows: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """(len(rows), 28) :func:`tandem_env.bound_sides` of each row's stroke, at its own bounds."""
    return np.array(
        [bound_sides([float(r[n]) for n in PARAMETER_NAMES], row_bounds(r)) for r in rows]
    )


def _wrap(angles: np.ndarray) -> np.ndarray:
    """``angles`` wrapped to (−180, 180] [deg]."""
    wrapped = (np.asarray(angles, float) + 180.0) % 360.0 - 180.0
    return np.where(wrapped == -180.0, 180.0, wrapped)


def circular_median(angles: Sequence[float]) -> float:
    """The circular median of angles [deg] in (−180, 180] (NaN for none): the direction of
    least summed angular distance (Fisher 1993, §2.3.2) among the angles and their neighbours'
    midpoints, ties averaged on the circle; for +136° and −170° it is 163°, not −17°."""
    values = _wrap(np.asarray(angles, float))
    if values.size == 0:
        return math.nan
    ordered = np.sort(values)
    gaps = _wrap(np.roll(ordered, -1) - ordered)
    candidates = np.concatenate(
        [ordered, _wrap(ordered + 0.5 * np.where(gaps < 0, gaps + 360.0, gaps))]
    )
    cost = np.abs(_wrap(values[None, :] - candidates[:, None])).sum(axis=1)
    tied = candidates[cost <= cost.min() + 1e-9]
    radians = np.deg2rad(tied)
    sin, cos = float(np.sin(radians).mean()), float(np.cos(radians).mean())
    if math.hypot(sin, cos) < 1e-9:  # spread evenly round the circle: no direction stands out
        return float(tied[0])
    return float(_wrap(math.degrees(math.atan2(sin, cos))))


def circular_quartiles(angles: Sequence[float], median: float) -> tuple[float, float]:
    """The quartiles [deg] of the angles' wrapped deviations from ``median``, added to it
    (q25 <= median <= q75, possibly beyond ±180°)."""
    deviations = _wrap(np.asarray(angles, float) - median)
    q25, q75 = np.percentile(deviations, [25.0, 75.0])
    return median + float(q25), median + float(q75)


def record_row(job: Job, record: Record) -> dict[str, Any]:
    """The tidy row of one optimisation: identity, feasibility, metrics, stroke summary, the 28
    stroke parameters (Table 4 units) and ``at_bounds`` (:func:`tandem_env.describe_bounds`)."""
    m, s, insect = record.metrics, record.stroke, record.config["env"]["insect"]
    phase_difference = float(_wrap(float(s["hind_sweep_phase"]) - float(s["fore_sweep_phase"])))
    weight = float(insect["body_mass"]) * float(insect["gravity"])
    stroke = [float(s[name]) for name in PARAMETER_NAMES]  # Table 4 units
    own = insect.get("stroke_bounds")  # only where not Table 4's: what pinned() measures against
    bounds = TABLE_4_BOUNDS if own is None else StrokeBounds(**own)
    metrics = ("lift_to_weight", "power_per_mass", "excess_vertical", "excess_horizontal")
    return {
        "method": job.method,
        "task": job.task,
        "objective": job.env("objective", "efficiency"),
        "planform": job.env("planform", "tear-drop"),
        "condition": record.condition.value,
        "condition_name": record.condition.name,
        "condition_unit": record.condition.unit,
        **{k: getattr(record, k) for k in ("seed", "budget", "evaluations")},
        "feasible": bool(record.feasible),
        "objective_value": float(record.objective),
        "reward": float(record.reward),
        "efficiency": float(m["efficiency"]),
        "efficiency_pct": 100.0 * float(m["efficiency"]),
        "thrust_ratio": float(m["thrust"]) / weight,
        **{k: float(m[k]) for k in (*metrics, "excess_total", "mean_angle_of_attack")},
        **{q: 0.5 * (float(s[f"fore_{q}"]) + float(s[f"hind_{q}"])) for q in WING_MEANS},
        "phase_difference": phase_difference,
        "phase_difference_abs": abs(phase_difference),
        "induction_converged": bool(m.get("induction_converged", True)),
        "wall_time_s": float(record.wall_time),
        "key": job.key,
        **dict(zip(PARAMETER_NAMES, stroke, strict=True)),
        "at_bounds": describe_bounds(stroke, bounds),
        **({} if own is None else {"stroke_bounds": bounds.changes()}),
    }


def tidy_rows(records: Mapping[Job, Record]) -> Rows:
    """One row per record, sorted by series, condition and seed."""
    rows = [record_row(job, record) for job, record in records.items()]
    rows.sort(key=lambda r: (*(str(r[k]) for k in SERIES_KEYS), r["condition"], r["seed"]))
    return rows


@dataclass(frozen=True)
class Spread:
    """One quantity at one condition of one series, over seeds."""

    values: tuple[float, ...]
    """Values of the feasible seeds, in seed order."""
    seeds: tuple[int, ...]
    median: float
    q25: float
    q75: float
    best: float
    """Value at the feasible seed with the best objective (NaN if none is feasible)."""
    best_seed: int | None
    n: int
    """Seeds run."""
    n_feasible: int

    def describe(self) -> str:
        """``median [q25, q75]`` to 3 significant digits (NaN-safe)."""
        if math.isnan(self.median):
            return "no feasible seed"
        return f"{self.median:.3g} [{self.q25:.3g}, {self.q75:.3g}]"


#: One quantity of one series over its conditions: {condition: its spread over seeds}.
Sweep = dict[float, Spread]


def spread(rows: Sequence[Mapping[str, Any]], quantity: str) -> Spread:
    """Median, IQR and best of ``quantity`` over the feasible rows (one per seed); circular
    statistics for the angles of :data:`CIRCULAR`."""
    feasible = [r for r in rows if r["feasible"]]
    values = np.array([float(r[quantity]) for r in feasible])
    if values.size == 0:
        return Spread((), (), *(math.nan,) * 4, None, len(rows), 0)
    if quantity in CIRCULAR:
        median = circular_median(values)
        q25, q75 = circular_quartiles(values, median)
    else:
        q25, median, q75 = np.percentile(values, [25.0, 50.0, 75.0])
    top = max(feasible, key=lambda r: (float(r["objective_value"]), -int(r["seed"])))
    seeds = tuple(int(r["seed"]) for r in feasible)
    stats = (float(median), float(q25), float(q75), float(top[quantity]), int(top["seed"]))
    return Spread(tuple(float(v) for v in values), seeds, *stats, len(rows), len(feasible))


def select(rows: Iterable[Mapping[str, Any]], **where: Any) -> list[Mapping[str, Any]]:
    """Rows whose columns equal every ``where`` value."""
    return [r for r in rows if all(r[k] == v for k, v in where.items())]


def by_condition(rows: Iterable[Row], quantity: str, **where: Any) -> Sweep:
    """{condition: Spread} of one series (``where`` picks it), conditions ascending."""
    chosen = select(rows, **where)
    conditions = sorted({float(r["condition"]) for r in chosen})
    return {c: spread(select(chosen, condition=c), quantity) for c in conditions}


def series_conditions(rows: Iterable[Row]) -> list[tuple[tuple[Any, ...], list[Row]]]:
    """The rows grouped by series (:data:`SERIES_KEYS`, as text) and condition, in that order:
    ((method, task, objective, planform, condition), rows) each."""
    groups: dict[tuple[Any, ...], list[Mapping[str, Any]]] = {}
    for r in rows:
        groups.setdefault((*(str(r[k]) for k in SERIES_KEYS), float(r["condition"])), []).append(r)
    return sorted(groups.items())


#: The :class:`Spread` fields of a summary row, in its column order.
SUMMARY_FIELDS = ("n", "n_feasible", "median", "q25", "q75", "best", "best_seed")


def spread_summary_rows(rows: Sequence[Mapping[str, Any]], quantities: Sequence[str]) -> Rows:
    """Per series, condition and quantity: its :class:`Spread` and ``pinned`` (:func:`pinned`)."""
    out = []
    for key, members in series_conditions(rows):
        for quantity in quantities:
            s = spread(members, quantity)
            row = dict(zip((*SERIES_KEYS, "condition"), key, strict=True))
            row |= {"quantity": quantity, "meaning": QUANTITIES.get(quantity, "")}
            row |= {k: getattr(s, k) for k in SUMMARY_FIELDS}
            out.append({**row, "pinned": pinned(members, quantity)})
    return out


def pinned_parameters(rows: Sequence[Mapping[str, Any]]) -> Rows:
    """Every stroke parameter pinned at a Table 4 bound (:func:`pinned`) per series and
    condition: its ``bound``, ``value`` and ``share`` of the feasible seeds there; a record in
    two studies counts once."""
    out = []
    for key, members in series_conditions(list({r["key"]: r for r in rows}.values())):
        feasible = [r for r in members if r["feasible"]]
        if not feasible:  # nothing is pinned (:func:`pinned`)
            continue
        at, bounds = _sides(feasible), row_bounds(feasible[0])  # a series flies one insect
        for index, name in enumerate(PARAMETER_NAMES):
            if not (side := pinned(members, name)):
                continue
            sign = -1 if side == "lower" else 1
            row = dict(zip((*SERIES_KEYS, "condition"), key, strict=True))
            row |= {"condition_unit": members[0]["condition_unit"], "parameter": name}
            value = (bounds.lower if sign < 0 else bounds.upper)[index]
            share = float(np.mean(at[:, index] == sign))
            out.append({**row, "bound": side, "value": value, "share": share})
    return out
