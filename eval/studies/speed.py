"""Level-flight speed sweep (paper Figs. 4-6): optimise η at each speed, every seed.

Per speed and seed: thrust ratio T/W, mean angle of attack and stroke-plane angle (Fig. 4);
power per mass P/m, frequency f and weaving amplitude φ_m (Fig. 5); efficiency η (Fig. 6).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

from agents.run_record import Record
from eval import figures
from eval.studies import claims as C
from eval.studies.base import Plan, StudyOutput, series_label, write_tables
from eval.studies.runner import Job
from eval.studies.tables import by_condition

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
    "force, a gross quantity not bounded by energy, so optimised η exceeds the paper's; the "
    "reference implementation finds 18-45 % at 1.5 m/s."
)


def jobs(plan: Plan) -> list[Job]:
    return plan.jobs("level", plan.preset.speeds)


def analyse(plan: Plan, records: Mapping[Job, Record], out_dir: Path) -> StudyOutput:
    rows, files = write_tables(NAME, records, out_dir, QUANTITIES)
    where = {"task": "level", "planform": "tear-drop"}

    def series(quantity: str) -> list[figures.Series]:
        return [
            figures.Series(series_label(m), by_condition(rows, quantity, method=m, **where))
            for m in plan.methods
        ]

    study_dir = out_dir / NAME
    xlabel = "flight speed V [m/s]"
    figs = [
        (
            "Fig. 4: thrust ratio, mean angle of attack and stroke-plane angle in level flight",
            figures.sweep_figure(
                [
                    # The paper states these trends in words only, no numbers.
                    figures.Panel(
                        "thrust ratio T/W [-]",
                        series("thrust_ratio"),
                        paper_note="paper: falls with V",
                    ),
                    figures.Panel(
                        "mean angle of attack [deg]",
                        series("mean_angle_of_attack"),
                        paper_note="paper: falls with V",
                    ),
                    figures.Panel(
                        "stroke-plane angle β [deg]",
                        series("stroke_plane_angle"),
                        paper_note="paper: rises with V",
                    ),
                ],
                xlabel,
                "Fig. 4: level flight, optimised at each speed",
                study_dir / "fig4_thrust_aoa_stroke_plane.png",
            ),
        ),
        (
            "Fig. 5: power per mass, frequency and weaving amplitude in level flight",
            figures.sweep_figure(
                [
                    figures.Panel(
                        "power P/m [W/kg]",
                        series("power_per_mass"),
                        paper_at=[(PAPER_BEST_SPEED, "paper: minimum power")],
                    ),
                    figures.Panel(
                        "frequency f [Hz]",
                        series("frequency"),
                        paper_note="paper: follows the power",
                    ),
                    figures.Panel(
                        "weaving amplitude φ_m [deg]",
                        series("sweep_amplitude"),
                        paper_note="paper: follows the power",
                    ),
                ],
                xlabel,
                "Fig. 5: level flight, optimised at each speed",
                study_dir / "fig5_power_frequency_sweep.png",
            ),
        ),
        (
            "Fig. 6: level-flight efficiency",
            figures.sweep_figure(
                [
                    figures.Panel(
                        "efficiency η [%]",
                        series("efficiency_pct"),
                        paper=[(PAPER_BEST_SPEED, PAPER_PEAK_EFFICIENCY)],
                    )
                ],
                xlabel,
                f"Fig. 6: level-flight efficiency (thrust_split = {_thrust_split(records)})",
                study_dir / "fig6_efficiency.png",
            ),
        ),
    ]
    found = [c for i, m in enumerate(plan.methods) for c in _claims(rows, m, i)]
    return StudyOutput(NAME, TITLE, rows, figs, found, files)


def _thrust_split(records: Mapping[Job, Record]) -> str:
    splits = {r.config["env"]["options"]["thrust_split"] for r in records.values()}
    return ", ".join(sorted(splits))


def _claims(rows: list[dict], method: str, index: int) -> list[C.Claim]:
    where = {"method": method, "task": "level", "planform": "tear-drop"}
    get = lambda q: by_condition(rows, q, **where)  # noqa: E731
    out: list[C.Claim] = []

    for cid, quantity, direction, statement, _unit in (
        ("S1", "stroke_plane_angle", +1, "stroke-plane angle rises with V", ""),
        ("S2", "mean_angle_of_attack", -1, "mean angle of attack falls with V", ""),
        ("S3", "thrust_ratio", -1, "thrust ratio T/W falls with V", ""),
    ):
        r, r_best, ok, detail = C.trend(get(quantity), direction)
        out.append(
            C.Claim(
                id=C.claim_id(cid, index, method),
                study=NAME,
                figure="Fig. 4",
                statement=statement,
                paper="rises" if direction > 0 else "falls",
                rule="trend",
                median=r,
                best=r_best,
                unit="(ρ)",
                verdict=C.verdict(ok),
                detail=detail,
            )
        )

    at, at_best, ok = C.location(get("power_per_mass"), PAPER_BEST_SPEED, "min")
    out.append(
        C.Claim(
            id=C.claim_id("S4", index, method),
            study=NAME,
            figure="Fig. 5",
            statement="power P/m is lowest at V = 1.5 m/s",
            paper="1.5 m/s",
            rule="location",
            median=at,
            best=at_best,
            unit="m/s",
            verdict=C.verdict(ok),
            note="η, not P, is maximised: P/m at the η-optimum need not be the minimum power.",
        )
    )
    power = get("power_per_mass")
    for cid, quantity, statement in (
        ("S5", "frequency", "frequency f follows the power trend"),
        ("S6", "sweep_amplitude", "weaving amplitude φ_m follows the power trend"),
    ):
        other = get(quantity)
        common = [v for v in power if v in other]
        r = C.rho([power[v].median for v in common], [other[v].median for v in common])
        r_best = C.rho([power[v].best for v in common], [other[v].best for v in common])
        out.append(
            C.Claim(
                id=C.claim_id(cid, index, method),
                study=NAME,
                figure="Fig. 5",
                statement=statement,
                paper="follows P",
                rule="follows",
                median=r,
                best=r_best,
                unit="(ρ)",
                verdict=C.verdict(None if math.isnan(r) else r >= C.TREND_RHO),
            )
        )

    eff = get("efficiency_pct")
    finite = {v: s for v, s in eff.items() if not math.isnan(s.median)}
    if finite:
        peak_speed = max(finite, key=lambda v: finite[v].median)
        s = finite[peak_speed]
        best = max(x.best for x in finite.values())
        out.append(
            C.Claim(
                id=C.claim_id("S7", index, method),
                study=NAME,
                figure="Fig. 6",
                statement="peak level-flight efficiency (≈ 13 % flight-muscle efficiency)",
                paper=f"{PAPER_PEAK_EFFICIENCY} %",
                rule="number",
                median=s.median,
                q25=s.q25,
                q75=s.q75,
                best=best,
                unit="%",
                verdict=C.verdict(C.number(s, PAPER_PEAK_EFFICIENCY)),
                detail=f"at V = {peak_speed:g} m/s, {s.n_feasible}/{s.n} seeds feasible",
                note=SIGN_NOTE,
            )
        )
    else:
        out.append(
            C.Claim(
                id=C.claim_id("S7", index, method),
                study=NAME,
                figure="Fig. 6",
                statement="peak level-flight efficiency",
                paper=f"{PAPER_PEAK_EFFICIENCY} %",
                rule="number",
                detail="no feasible seed",
            )
        )
    at, at_best, ok = C.location(eff, PAPER_BEST_SPEED, "max")
    out.append(
        C.Claim(
            id=C.claim_id("S8", index, method),
            study=NAME,
            figure="Fig. 6",
            statement="efficiency peaks at V = 1.5 m/s",
            paper="1.5 m/s",
            rule="location",
            median=at,
            best=at_best,
            unit="m/s",
            verdict=C.verdict(ok),
        )
    )
    return out
