"""Accelerating-flight power sweep (paper Figs. 7-8): per power and seed one optimisation of F̄_v
(F̄_h ≥ 0) and one of F̄_h (F̄_v ≥ 0), combined as F̄_a = sqrt(F̄_v² + F̄_h²) (Eq. 27) per seed and,
the paper's reading, over the best seeds."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from agents.jobs import Job
from eval import figures
from eval.studies import claims as C
from eval.studies.base import Analysis, Drawn, Records, StudyPlan
from eval.studies.tables import Rows, Sweep, by_condition, select, spread

NAME = "power"
TITLE = "Accelerating flight: power sweep (Figs. 7-8)"
QUANTITIES = tuple(
    "objective_value excess_vertical excess_horizontal power_per_mass frequency "
    "pitch_amplitude phase_difference".split()
)
#: The paper's numbers (Figs. 7, 8): {power [W/kg]: value [-]}.
PAPER_VERTICAL = {50.0: 2.7, 90.0: 4.4}
PAPER_HORIZONTAL = {50.0: 2.4, 90.0: 3.5}
PAPER_ATTAINABLE = {50.0: 3.6, 90.0: 5.6}
PAPER_RATIO = (10.0, 20.0)  # % by which F̄_v exceeds F̄_h
#: F̄'s unit in every figure: an excess force over the body weight (docs/model.md §7.6).
EXCESS_UNIT = "[-]"


def excess_label(name: str) -> str:
    """The axis label of an excess force ``name``, e.g. ``"attainable F̄_a = F/W [-]"``."""
    return f"{name} = F/W {EXCESS_UNIT}"


def jobs(plan: StudyPlan) -> list[Job]:
    return series_jobs(plan, plan.preset.powers, "tear-drop")


def series_jobs(plan: StudyPlan, powers: tuple[float, ...], planform: str) -> list[Job]:
    return [
        job
        for objective in ("vertical", "horizontal")
        for job in plan.jobs("accelerate", powers, objective=objective, planform=planform)
    ]


def excess(
    rows: Rows, method: str, planform: str, axis: str, horizontal: str = "horizontal"
) -> Sweep:
    """F̄_v (axis "vertical") or F̄_h ("horizontal": the reading's objective ``horizontal``) per
    power [-], the objective value of its own optimisation."""
    objective = horizontal if axis == "horizontal" else axis
    where = dict(method=method, task="accelerate", objective=objective, planform=planform)
    return by_condition(rows, "objective_value", **where)


def attainable(rows: Rows, method: str, planform: str, horizontal: str = "horizontal") -> Sweep:
    """F̄_a per power from each seed's feasible vertical and horizontal optima."""
    out: Sweep = {}
    vertical = excess(rows, method, planform, "vertical")
    horizontal_series = excess(rows, method, planform, "horizontal", horizontal)
    for power in sorted(set(vertical) & set(horizontal_series)):
        pick = dict(method=method, task="accelerate", planform=planform, condition=power)
        v, h = (
            {r["seed"]: r for r in select(rows, objective=o, **pick)}
            for o in ("vertical", horizontal)
        )
        both = sorted(s for s in v.keys() & h.keys() if v[s]["feasible"] and h[s]["feasible"])
        fa = {s: math.hypot(v[s]["objective_value"], h[s]["objective_value"]) for s in both}
        pairs = [dict(seed=s, feasible=True, objective_value=f, F_a=f) for s, f in fa.items()]
        best = math.hypot(vertical[power].best, horizontal_series[power].best)
        out[power] = replace(spread(pairs, "F_a"), best=best, best_seed=None, n=len(v))
    return out


def draw(plan: StudyPlan, rows: Rows, records: Records, study_dir: Path) -> Drawn:
    """Figs. 7-8: F̄_v and F̄_h, and F̄_a, over powers, one series per method."""
    h_obj = plan.reading.horizontal_objective
    # F̄_v and F̄_h of each method side by side (F̄_h its variant 1: figures.series_style)
    label = figures.method_label
    forces = [
        figures.Series(
            f"{n}, {label(m)}", excess(rows, m, "tear-drop", a, h_obj), method=m, variant=k
        )
        for m in plan.methods
        for k, (n, a) in enumerate((("F̄_v", "vertical"), ("F̄_h", "horizontal")))
    ]
    fa = plan.series(lambda m: attainable(rows, m, "tear-drop", h_obj))
    attained = list(PAPER_ATTAINABLE.items())  # the paper's F̄_a (Fig. 8)
    paper = [
        (p, v, f"paper {name}")
        for name, d in (("F̄_v", PAPER_VERTICAL), ("F̄_h", PAPER_HORIZONTAL))
        for p, v in d.items()
    ]
    specs = (
        (
            "Fig. 7: vertical and horizontal specific excess forces against available power",
            "fig7_excess_forces",
            "Fig. 7: F̄_v (max F̄_v s.t. F̄_h ≥ 0) and F̄_h (max F̄_h s.t. F̄_v ≥ 0), V = 0",
            [figures.Panel(excess_label("specific excess force F̄"), forces, paper=paper)],
        ),
        (
            "Fig. 8: attainable specific excess force against available power",
            "fig8_attainable",
            "Fig. 8: F̄_a = sqrt(F̄_v² + F̄_h²) (Eq. 27), V = 0",
            [figures.Panel(excess_label("attainable F̄_a"), fa, paper=attained)],
        ),
    )
    return plan.sweep_figures(study_dir, "available power P/m [W/kg]", specs)


def view(plan: StudyPlan, rows: Rows, method: str) -> dict[str, Sweep]:
    """What the claims judge: ``method``'s F̄_v, F̄_h and F̄_a over powers (tear-drop)."""
    h_obj = plan.reading.horizontal_objective
    return {
        "vertical": excess(rows, method, "tear-drop", "vertical"),
        "horizontal": excess(rows, method, "tear-drop", "horizontal", h_obj),
        "attainable": attainable(rows, method, "tear-drop", h_obj),
    }


def at(force: str, power: float) -> C.Measure:
    """``number``: the ``force`` (a :func:`view` key) at ``power`` [W/kg] over seeds."""

    def measure(series: Mapping[str, Sweep], _: float) -> C.Stats:
        s = series[force].get(power)
        return {"detail": f"{power:g} W/kg not in this preset"} if s is None else C.spread_stats(s)

    return measure


def rises(force: str) -> C.Measure:
    """``trend``: ρ(power, the medians of ``force``)."""
    return lambda series, sign: C.trend_stats(series[force], sign)


def ratio(series: Mapping[str, Sweep], _: Any) -> C.Stats:
    """By how much F̄_v exceeds F̄_h [%] over the powers (none when no power has both)."""
    vertical, horizontal = series["vertical"], series["horizontal"]
    common = sorted(set(vertical) & set(horizontal))
    ratios = [100.0 * (vertical[p].median / horizontal[p].median - 1.0) for p in common]
    best_ratios = [100.0 * (vertical[p].best / horizontal[p].best - 1.0) for p in common]
    ratios = [r for r in ratios if math.isfinite(r)]
    best_ratios = [r for r in best_ratios if math.isfinite(r)]
    if not ratios:
        return None
    q25, med, q75 = np.percentile(ratios, [25.0, 50.0, 75.0])
    best = float(np.median(best_ratios)) if best_ratios else math.nan
    return {"median": float(med), "q25": float(q25), "q75": float(q75), "best": best, "unit": "%"}


def _at_powers(cid: str, what: str, fig: str, force: str, paper: Mapping[float, float]):
    """``number`` claims ``cid`` a, b, …: ``what`` at each of the paper's powers."""
    return tuple(
        C.ClaimSpec(
            f"{cid}{'ab'[k]}", fig, f"{what} at {p:g} W/kg", f"≈ {v:g}", "number", v, at(force, p)
        )
        for k, (p, v) in enumerate(paper.items())
    )


GEOMETRY = (
    "with the same total force |F|, F̄_v = |F|/W − 1 but F̄_h = sqrt((|F|/W)² − 1) (see "
    "Understood differences)"
)
UP = "increases"
EXCEEDS = "F̄_v exceeds F̄_h by 10-20 % (median over powers; IQR over powers)"
CLAIMS: tuple[C.ClaimSpec, ...] = (
    *_at_powers("P1", "F̄_v", "Fig. 7", "vertical", PAPER_VERTICAL),
    *_at_powers("P2", "F̄_h", "Fig. 7", "horizontal", PAPER_HORIZONTAL),
    C.ClaimSpec("P3", "Fig. 7", EXCEEDS, "10-20 %", "range", PAPER_RATIO, ratio, GEOMETRY),
    *(
        C.ClaimSpec(cid, "Fig. 7", f"{name} {UP} with available power", UP, "trend", +1, rises(f))
        for cid, name, f in (("P4", "F̄_v", "vertical"), ("P5", "F̄_h", "horizontal"))
    ),
    *_at_powers("P6", "attainable F̄_a", "Fig. 8", "attainable", PAPER_ATTAINABLE),
)

analyse = Analysis(NAME, TITLE, QUANTITIES, draw, CLAIMS, view)
