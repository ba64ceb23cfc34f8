"""Level-flight speed sweep (paper Figs. 4-6): η optimised at each speed, every seed; T/W, mean
angle of attack and stroke-plane angle (Fig. 4), P/m, f and φ_m (Fig. 5), η (Fig. 6)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from agents.jobs import Job
from agents.records import Record
from eval import figures
from eval.studies import claims as C
from eval.studies.base import StudyOutput, StudyPlan, write_tables
from eval.studies.tables import Spread, by_condition, select, table4_bounds

NAME = "speed"
TITLE = "Level flight: speed sweep (Figs. 4-6)"
QUANTITIES = (
    "objective_value",
    "efficiency_pct",
    "thrust_ratio",
    "mean_angle_of_attack",
    "stroke_plane_angle",
    "power_per_mass",
    "frequency",
    "sweep_amplitude",
    "lift_to_weight",
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


def analyse(plan: StudyPlan, records: Mapping[Job, Record], out_dir: Path) -> StudyOutput:
    rows, files = write_tables(NAME, records, out_dir, QUANTITIES)

    def panel(ylabel: str, quantity: str, **paper: Any) -> figures.Panel:
        """``quantity`` over speeds, one series per method, within its Table 4 bounds if any."""
        series = [
            figures.Series(
                figures.method_label(m),
                by_condition(rows, quantity, method=m, task="level", planform="tear-drop"),
                method=m,
            )
            for m in plan.methods
        ]
        return figures.Panel(
            ylabel, series, bounds=table4_bounds(quantity, plan.insect.stroke_bounds), **paper
        )

    # The paper states these trends in words only, no numbers.
    falls, follows = "paper: falls with V", "paper: follows the power"
    level = "level flight, optimised at each speed"
    specs = (
        (
            "Fig. 4: thrust ratio, mean angle of attack and stroke-plane angle in level flight",
            "fig4_thrust_aoa_stroke_plane",
            f"Fig. 4: {level}",
            [
                panel("thrust ratio T/W [-]", "thrust_ratio", paper_note=falls),
                panel(
                    figures.pair_mean("mean angle of attack [deg]"),
                    "mean_angle_of_attack",
                    paper_note=falls,
                ),
                panel(
                    figures.pair_mean("stroke-plane angle β [deg]"),
                    "stroke_plane_angle",
                    paper_note="paper: rises with V",
                ),
            ],
        ),
        (
            "Fig. 5: power per mass, frequency and weaving amplitude in level flight",
            "fig5_power_frequency_sweep",
            f"Fig. 5: {level}",
            [
                panel(
                    "power P/m [W/kg]",
                    "power_per_mass",
                    paper_at=[(PAPER_BEST_SPEED, "paper: minimum power")],
                ),
                panel(figures.pair_mean("frequency f [Hz]"), "frequency", paper_note=follows),
                panel(
                    figures.pair_mean("weaving amplitude φ_m [deg]"),
                    "sweep_amplitude",
                    paper_note=follows,
                ),
            ],
        ),
        (
            "Fig. 6: level-flight efficiency",
            "fig6_efficiency",
            f"Fig. 6: level-flight efficiency (thrust_split = {plan.model_options.thrust_split})",
            [
                panel(
                    "efficiency η [%]",
                    "efficiency_pct",
                    paper=[(PAPER_BEST_SPEED, PAPER_PEAK_EFFICIENCY)],
                )
            ],
        ),
    )
    figs = [
        (
            caption,
            figures.sweep_figure(
                panels, "flight speed V [m/s]", title, plan.figure(out_dir / NAME, stem)
            ),
        )
        for caption, stem, title, panels in specs
    ]
    found = C.study_claims(rows, plan.methods, _claims, options=plan.model_options)
    return StudyOutput(NAME, TITLE, rows, figs, found, files)


def _claims(rows: list[dict], method: str, index: int) -> list[C.Claim]:
    series = select(rows, method=method, task="level", planform="tear-drop")
    get = lambda q: by_condition(series, q)  # noqa: E731
    held = lambda q: C.held_at_bound(series, q)  # noqa: E731 (a parameter at a bound: ρ = 0)
    make = C.ClaimBuilder(NAME, method, index)
    power, eff = get("power_per_mass"), get("efficiency_pct")
    trends = [
        make.claim(
            cid,
            "Fig. 4",
            statement,
            "rises" if sign > 0 else "falls",
            **C.trend_row(get(quantity), sign, **held(quantity)),
        )
        for cid, quantity, sign, statement in (
            ("S1", "stroke_plane_angle", +1, "stroke-plane angle rises with V"),
            ("S2", "mean_angle_of_attack", -1, "mean angle of attack falls with V"),
            ("S3", "thrust_ratio", -1, "thrust ratio T/W falls with V"),
        )
    ]
    not_minimised = "η, not P, is maximised: P/m at the η-optimum need not be the minimum power."
    return [
        *trends,
        make.claim(
            "S4",
            "Fig. 5",
            "power P/m is lowest at V = 1.5 m/s",
            "1.5 m/s",
            **C.location_row(power, PAPER_BEST_SPEED, "min", note=not_minimised),
        ),
        *(
            _follows(make, cid, label, power, get(quantity), held(quantity))
            for cid, label, quantity in (
                ("S5", "frequency f", "frequency"),
                ("S6", "weaving amplitude φ_m", "sweep_amplitude"),
            )
        ),
        _peak_efficiency(make, eff),
        make.claim(
            "S8",
            "Fig. 6",
            "efficiency peaks at V = 1.5 m/s",
            "1.5 m/s",
            **C.location_row(eff, PAPER_BEST_SPEED, "max"),
        ),
    ]


def _follows(
    make: C.ClaimBuilder,
    cid: str,
    label: str,
    power: Mapping[float, Spread],
    other: Mapping[float, Spread],
    held: Mapping[str, Any],
) -> C.Claim:
    """``follows``: ρ between the power's and ``other``'s medians (and best seeds) over speeds;
    0 where a Table 4 bound holds ``other`` (``held``: :func:`claims.held_at_bound`)."""
    common = [v for v in power if v in other]
    r = C.rho([power[v].median for v in common], [other[v].median for v in common])
    r_best = C.rho([power[v].best for v in common], [other[v].best for v in common])
    statement = f"{label} follows the power trend"
    return make.claim(
        cid,
        "Fig. 5",
        statement,
        "follows P",
        rule="follows",
        test=C.trend_test(+1),
        **{"median": r, "best": r_best, "unit": "(ρ)", **held},
    )


def _peak_efficiency(make: C.ClaimBuilder, eff: Mapping[float, Spread]) -> C.Claim:
    """The highest median η over speeds against the paper's 12.7 % (Fig. 6)."""
    paper = f"{PAPER_PEAK_EFFICIENCY} %"
    finite = {v: s for v, s in eff.items() if not math.isnan(s.median)}
    if not finite:
        statement = "peak level-flight efficiency"
        return make.claim(
            "S7", "Fig. 6", statement, paper, rule="number", detail="no feasible seed"
        )
    peak_speed = max(finite, key=lambda v: finite[v].median)
    s = finite[peak_speed]
    return make.claim(
        "S7",
        "Fig. 6",
        "peak level-flight efficiency (≈ 13 % flight-muscle efficiency)",
        paper,
        **C.number_row(
            s,
            PAPER_PEAK_EFFICIENCY,
            best=max(x.best for x in finite.values()),
            unit="%",
            detail=f"at V = {peak_speed:g} m/s, {C.seeds_feasible(s)}",
            note=SIGN_NOTE,
        ),
    )
