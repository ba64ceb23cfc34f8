"""Level-flight speed sweep (paper Figs. 4-6): η optimised at each speed, every seed; T/W, mean
angle of attack and stroke-plane angle (Fig. 4), P/m, f and φ_m (Fig. 5), η (Fig. 6)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from agents.jobs import Job
from eval import figures
from eval.studies import claims as C
from eval.studies.base import Analysis, Drawn, Records, StudyPlan
from eval.studies.tables import Rows, by_condition, select, table4_bounds

NAME = "speed"
TITLE = "Level flight: speed sweep (Figs. 4-6)"
QUANTITIES = tuple(
    "objective_value efficiency_pct thrust_ratio mean_angle_of_attack stroke_plane_angle "
    "power_per_mass frequency sweep_amplitude lift_to_weight".split()
)
PAPER_PEAK_EFFICIENCY = 12.7  # % at 1.5 m/s (Fig. 6)
PAPER_BEST_SPEED = 1.5  # m/s: minimum power and maximum efficiency (Figs. 5, 6)

SIGN_NOTE = (
    "thrust_split='sign' (docs/model.md §7): T is the cycle mean of the forward part of the wing "
    "force, a gross quantity not bounded by energy, so optimised η exceeds the paper's "
    "(docs/efficiency.md: median 46.2 % at 1.5 m/s, 8 seeds of CMA-ES with 16 000 "
    "evaluations and the polish)."
)


def jobs(plan: StudyPlan) -> list[Job]:
    return plan.jobs("level", plan.preset.speeds)


def draw(plan: StudyPlan, rows: Rows, records: Records, study_dir: Path) -> Drawn:
    """Figs. 4-6: each quantity over speeds, one series per method."""

    def panel(ylabel: str, quantity: str, **paper: Any) -> figures.Panel:
        """``quantity`` over speeds, one series per method, within its Table 4 bounds if any."""
        where = dict(task="level", planform="tear-drop")
        series = plan.series(lambda m: by_condition(rows, quantity, method=m, **where))
        bounds = table4_bounds(quantity, plan.insect.stroke_bounds)
        return figures.Panel(ylabel, series, bounds=bounds, **paper)

    # The paper states these trends in words only, no numbers.
    falls = {"paper_note": "paper: falls with V"}
    rises = {"paper_note": "paper: rises with V"}
    follows = {"paper_note": "paper: follows the power"}
    level = "level flight, optimised at each speed"
    pair_mean = figures.pair_mean
    least = [(PAPER_BEST_SPEED, "paper: minimum power")]
    peak = [(PAPER_BEST_SPEED, PAPER_PEAK_EFFICIENCY)]
    specs = (
        (
            "Fig. 4: thrust ratio, mean angle of attack and stroke-plane angle in level flight",
            "fig4_thrust_aoa_stroke_plane",
            f"Fig. 4: {level}",
            [
                panel("thrust ratio T/W [-]", "thrust_ratio", **falls),
                panel(pair_mean("mean angle of attack [deg]"), "mean_angle_of_attack", **falls),
                panel(pair_mean("stroke-plane angle β [deg]"), "stroke_plane_angle", **rises),
            ],
        ),
        (
            "Fig. 5: power per mass, frequency and weaving amplitude in level flight",
            "fig5_power_frequency_sweep",
            f"Fig. 5: {level}",
            [
                panel("power P/m [W/kg]", "power_per_mass", paper_at=least),
                panel(pair_mean("frequency f [Hz]"), "frequency", **follows),
                panel(pair_mean("weaving amplitude φ_m [deg]"), "sweep_amplitude", **follows),
            ],
        ),
        (
            "Fig. 6: level-flight efficiency",
            "fig6_efficiency",
            f"Fig. 6: level-flight efficiency (thrust_split = {plan.model_options.thrust_split})",
            [panel("efficiency η [%]", "efficiency_pct", paper=peak)],
        ),
    )
    return plan.sweep_figures(study_dir, "flight speed V [m/s]", specs)


def view(plan: StudyPlan, rows: Rows, method: str) -> list[Mapping[str, Any]]:
    """What the claims judge: ``method``'s level-flight rows (tear-drop)."""
    return select(rows, method=method, task="level", planform="tear-drop")


def trend(quantity: str, against: str | None = None) -> C.Measure:
    """``trend``: ρ(V, the medians of ``quantity``); ``follows`` (``against`` another quantity):
    ρ between its and ``quantity``'s medians (and best seeds) over speeds; 0 where a Table 4
    bound holds ``quantity``."""
    return lambda rows, sign: C.trend_stats(
        by_condition(rows, quantity),
        sign,
        None if against is None else by_condition(rows, against),
        **C.held_at_bound(rows, quantity),
    )


def extremum(quantity: str, kind: str) -> C.Measure:
    """``location``: the speed of the lowest (``min``) or highest medians of ``quantity``."""
    return lambda rows, _: C.location_stats(by_condition(rows, quantity), kind)


def peak_efficiency(rows: list[Mapping[str, Any]], _: float) -> C.Stats:
    """The highest median η over speeds against the paper's 12.7 % (Fig. 6)."""
    by_speed = by_condition(rows, "efficiency_pct")
    finite = {v: s for v, s in by_speed.items() if not math.isnan(s.median)}
    if not finite:
        return dict(statement="peak level-flight efficiency", detail="no feasible seed", note="")
    peak_speed = max(finite, key=lambda v: finite[v].median)
    s = finite[peak_speed]
    best, detail = max(x.best for x in finite.values()), f"at V = {peak_speed:g} m/s"
    return C.spread_stats(s, best=best, unit="%", detail=f"{detail}, {C.seeds_feasible(s)}")


def at_best_speed(cid: str, fig: str, what: str, measure: C.Measure, note: str = "") -> C.ClaimSpec:
    """A ``location`` claim ``what``: at the paper's best speed, 1.5 m/s."""
    return C.ClaimSpec(cid, fig, what, "1.5 m/s", "location", PAPER_BEST_SPEED, measure, note)


FOLLOWS, P = "follows the power trend", "power_per_mass"
LOWEST = "power P/m is lowest at V = 1.5 m/s"
PEAK = "peak level-flight efficiency (≈ 13 % flight-muscle efficiency)"
PEAKS = "efficiency peaks at V = 1.5 m/s"
PAPER_ETA = f"{PAPER_PEAK_EFFICIENCY} %"  # its text in the claims
NOT_P = "η, not P, is maximised: P/m at the η-optimum need not be the minimum power."
CLAIMS: tuple[C.ClaimSpec, ...] = (
    *(
        C.ClaimSpec(cid, "Fig. 4", f"{what} {word} with V", word, "trend", sign, trend(quantity))
        for cid, what, word, sign, quantity in (
            ("S1", "stroke-plane angle", "rises", +1, "stroke_plane_angle"),
            ("S2", "mean angle of attack", "falls", -1, "mean_angle_of_attack"),
            ("S3", "thrust ratio T/W", "falls", -1, "thrust_ratio"),
        )
    ),
    at_best_speed("S4", "Fig. 5", LOWEST, extremum(P, "min"), NOT_P),
    *(
        C.ClaimSpec(cid, "Fig. 5", f"{what} {FOLLOWS}", "follows P", "follows", +1, trend(q, P))
        for cid, what, q in (
            ("S5", "frequency f", "frequency"),
            ("S6", "weaving amplitude φ_m", "sweep_amplitude"),
        )
    ),
    C.ClaimSpec(
        "S7", "Fig. 6", PEAK, PAPER_ETA, "number", PAPER_PEAK_EFFICIENCY, peak_efficiency, SIGN_NOTE
    ),
    at_best_speed("S8", "Fig. 6", PEAKS, extremum("efficiency_pct", "max")),
)

analyse = Analysis(NAME, TITLE, QUANTITIES, draw, CLAIMS, view)
