"""Kinematics of the optimised strokes (paper Figs. 9-13).

The strokes of level flight at 1.25 m/s and accelerating flight at 60 W/kg (the paper's choices,
the sweeps' own jobs), and level flight at 2 m/s for the paper's largest phase difference; every
seed thin, the best bold: tip paths (Figs. 9-10), φ and η over the cycle (Figs. 11-12), angle of
attack and relative speed at 0.75 R (Fig. 13). The fore/hind phase difference ΔΦ = Φ_φ,hind −
Φ_φ,fore is wrapped to (−180°, 180°] (> 0: the hind-wing leads); its statistics are circular.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from agents.jobs import Job
from agents.records import Record
from agents.tasks import get_task
from eval import figures
from eval import kinematics_figures as kf
from eval.studies import claims as C
from eval.studies.base import Analysis, Drawn, Records, StudyPlan
from eval.studies.tables import Rows, Spread, circular_median, select, spread, table4_bounds
from tandem_env import PARAMETER_NAMES, bound_sides, stroke_history
from tandem_env.envs import registration

NAME = "kinematics"
TITLE = "Kinematics of the optimised strokes (Figs. 9-13)"
QUANTITIES = tuple(
    "objective_value phase_difference phase_difference_abs pitch_amplitude "
    "sweep_amplitude frequency stroke_plane_angle".split()
)
PAPER_PHASE_LEAD = 30.0  # deg: hind-wing leads at 2 m/s (Fig. 11)
PAPER_IN_PHASE = 0.0  # deg: "the wings flap in-phase" in accelerating flight (Fig. 11b)
HISTORY_SAMPLES = 120
#: The quantities of a wing's history each trace carries (``kinematics_figures.Trace``).
TRACED = ("tip_path", "sweep", "pitch", "angle_of_attack", "relative_speed")


def triangle_note(rows: Rows) -> str:
    """Fig. 13's legend line naming the seeds' wings whose weaving is a triangle wave (shape K
    at its upper bound 1, docs/model.md §3.4): their φ̇ reverses at once, so their relative
    speed steps at each reversal (the kinematics, not the plot); "" where none is."""
    shape = {w: PARAMETER_NAMES.index(f"{w}_sweep_shape") for w in ("fore", "hind")}
    found = []
    for row in sorted(rows, key=lambda r: r["seed"]):
        sides = bound_sides([float(row[name]) for name in PARAMETER_NAMES])
        if wings := [w for w, k in shape.items() if sides[k] == 1]:
            found.append(f"{' and '.join(wings)}-wing of seed {row['seed']}")
    if not found:
        return ""
    return (
        f"K = 1, a triangle-wave φ: {'; '.join(found)}.\nIts φ̇ reverses at once, so its "
        "speed steps at each reversal"
    )


def jobs(plan: StudyPlan) -> list[Job]:
    p = plan.preset
    return [
        *plan.jobs("level", sorted({p.kinematics_speed, p.phase_speed})),
        *plan.jobs("accelerate", [p.kinematics_power], objective=p.kinematics_objective),
    ]


def flight_of(job: Job) -> tuple[Any, float, float]:
    """The env config of ``job`` and its flight speed [m/s] and available power [W/kg]."""
    task = get_task(job.task)
    kwargs = {**dict(job.env_kwargs), task.declared_condition.keyword: job.condition}
    cfg = registration.config_class(task.env_id).from_kwargs(**kwargs)
    # The task's condition sets one model input; its config fixes the other (task core).
    core = registration.core_class(task.env_id)(cfg)
    speeds, powers = core.flight_conditions(np.array([cfg.fixed_condition]))
    return cfg, float(speeds[0]), float(powers[0])


def record_history(record: Record, n_samples: int = HISTORY_SAMPLES):
    """The record's best stroke over one cycle, with the env's own insect and model options."""
    cfg, speed, power = flight_of(record.job)
    stroke = np.array([float(record.stroke[name]) for name in PARAMETER_NAMES])
    return stroke_history(
        stroke, speed, power, insect=cfg.insect, options=cfg.options, n_samples=n_samples
    )


def traces(records: Records, rows: Rows, **where: Any) -> list[kf.Trace]:
    """One trace per seed of the series ``where`` picks; the best feasible seed is bold."""
    chosen = select(rows, **where)
    best_seed = spread(chosen, "objective_value").best_seed
    by_key = {job.key: record for job, record in records.items()}
    out = []
    for row in sorted(chosen, key=lambda r: r["seed"]):
        h = record_history(by_key[row["key"]])
        fore, hind = ({name: getattr(wing, name) for name in TRACED} for wing in (h.fore, h.hind))
        best = row["seed"] == best_seed
        suffix = " (best)" if best else ("" if row["feasible"] else " (infeasible)")
        out.append(kf.Trace(f"seed {row['seed']}{suffix}", best, h.fore.cycle_fraction, fore, hind))
    return out


def draw(plan: StudyPlan, rows: Rows, records: Records, study_dir: Path) -> Drawn:
    """Figs. 9-13 of the first method's strokes, each seed's."""
    p, method = plan.preset, plan.methods[0]
    level, accel = _series(plan, method)
    lv = traces(records, rows, condition=p.kinematics_speed, **level)
    ac = traces(records, rows, condition=p.kinematics_power, **accel)
    level_name = f"level flight, V = {p.kinematics_speed:g} m/s"
    accel_name = f"accelerating ({p.kinematics_objective}), {p.kinematics_power:g} W/kg"
    judged = view(plan, rows, method)
    level_at, accel_at = f"level {p.kinematics_speed:g} m/s", f"accel. {p.kinematics_power:g} W/kg"
    lead_at = f"level {p.phase_speed:g} m/s"

    def panel(title: str, groups: dict[str, Spread], ylabel: str, **marks: Any) -> kf.GroupPanel:
        """The feasible seeds' values of each group, as the claims take them, and its best."""
        values = {k: list(s.values) for k, s in groups.items()}
        best = {k: s.best for k, s in groups.items()}
        return kf.GroupPanel(title, values, ylabel, best=best, **marks)

    # Each panel shows the statistic its claim judges; not judged where K1-K3 are not
    # identifiable (claims.IDENTIFIABILITY_RULE).
    resolved = plan.model_options.phase_resolved()
    said = "judged" if resolved else "not judged: the model does not depend on ΔΦ"
    tol = C.ANGLE_TOLERANCE
    phase_panels = (
        panel(
            "(c) |ΔΦ| (K1, K3; feasible seeds)",
            {level_at: judged["level |ΔΦ|"], accel_at: judged["accel |ΔΦ|"]},
            "|ΔΦ| [deg]",
            statistic_label=f"median |ΔΦ| ({said})",
            paper={accel_at: PAPER_IN_PHASE},
            paper_label="paper: in phase (ΔΦ = 0°)",
            band=(0.0, C.IN_PHASE, f"in phase: |ΔΦ| < {C.IN_PHASE:g}°"),
            ylim=(-8.0, 185.0),  # room for the paper's 0° cross
        ),
        panel(
            f"(d) ΔΦ at {p.phase_speed:g} m/s (K2; > 0: hind leads)",
            {lead_at: judged["ΔΦ"]},
            "ΔΦ = Φ_hind − Φ_fore [deg]",
            statistic=circular_median,
            statistic_label=f"circular median ({said})",
            paper={lead_at: PAPER_PHASE_LEAD},
            paper_label=f"paper: hind leads by ≈ {PAPER_PHASE_LEAD:g}°",
            band=(PAPER_PHASE_LEAD - tol, PAPER_PHASE_LEAD + tol, f"paper ± {tol:g}° (rule)"),
            ylim=(-180.0, 180.0),
        ),
    )
    pitch_panel = panel(
        "(c) pitch amplitude η_m (K4; feasible seeds)",
        {"level": judged["level η_m"], "accelerating": judged["accel η_m"]},
        figures.pair_mean("η_m [deg]"),
        statistic_label="median (judged)",
        paper_note="paper: larger in accelerating flight",
        bounds=table4_bounds("pitch_amplitude", plan.insect.stroke_bounds),
    )
    label = figures.method_label(method)
    tips = (
        (9, "level flight", lv, level_name, "fig9_tip_paths_level"),
        (10, "accelerating flight", ac, accel_name, "fig10_tip_paths_accelerating"),
    )
    phase = "(c) |ΔΦ|, (d) ΔΦ at the paper's largest phase difference"
    cycles = (
        (11, "weaving angle φ", phase, "sweep", "weaving", phase_panels),
        (12, "pitch angle η", "(c) pitch amplitudes", "pitch", "pitch", (pitch_panel,)),
    )
    out = []
    for n, flight, t, name, stem in tips:
        path = plan.figure(study_dir, stem)
        figure = kf.tip_path_figure(t, f"Fig. {n}: tip paths, {name} ({label})", path)
        out.append((f"Fig. {n}: wing-tip paths relative to the wing base, {flight}", figure))
    both = [(f"(a) {level_name}", lv), (f"(b) {accel_name}", ac)]
    for n, angle, panels, key, stem, extras in cycles:
        title = f"Fig. {n}: {angle.rsplit(' ', 1)[0]} over the cycle"
        path = plan.figure(study_dir, f"fig{n}_{stem}")
        figure = kf.cycle_figure(both, key, f"{angle} [deg]", title, path, extras=extras)
        out.append((f"Fig. {n}: {angle} of fore- and hind-wing; {panels}", figure))
    note = triangle_note(select(rows, condition=p.kinematics_speed, **level))
    path = plan.figure(study_dir, "fig13_flow_level")
    figure = kf.flow_figure(lv, f"Fig. 13: flow at the wing, {level_name}", path, note)
    caption = (
        "Fig. 13: angle of attack and relative speed over the cycle, level flight (a wing "
        "whose weaving shape K sits at its bound 1 sweeps at a constant rate between "
        "reversals: its speed steps at each reversal; the legend names it)"
    )
    return [*out, (caption, figure)]


@functools.cache
def phase_dependences(plan: StudyPlan) -> dict[str, tuple[C.Dependence, ...]]:
    """What K1-K3 are about: the fore/hind phase at their optimisations' flight speeds (once
    per plan: every bootstrap resample asks)."""
    p = plan.preset
    jobs = plan.jobs("level", [p.kinematics_speed, p.phase_speed], seeds=p.seeds[:1])[:2]
    jobs += plan.jobs("accelerate", [p.kinematics_power], objective=p.kinematics_objective)[:1]
    speeds = [flight_of(job)[1] for job in jobs]
    ids = ("K1", "K2", "K3")
    return {cid: (C.Dependence(C.PHASE, speed),) for cid, speed in zip(ids, speeds, strict=True)}


def view(plan: StudyPlan, rows: Rows, method: str) -> dict[str, Any]:
    """What K1-K4 judge and Figs. 11c-d and 12c show: |ΔΦ| level and accelerating, ΔΦ at
    ``phase_speed``, η_m level and accelerating (spreads over seeds); and what K1-K3 are about
    (``phase``: :func:`phase_dependences`)."""
    p = plan.preset
    level, accel = _series(plan, method)
    picks = {
        "level |ΔΦ|": (level, p.kinematics_speed, "phase_difference_abs"),
        "accel |ΔΦ|": (accel, p.kinematics_power, "phase_difference_abs"),
        "ΔΦ": (level, p.phase_speed, "phase_difference"),
        "level η_m": (level, p.kinematics_speed, "pitch_amplitude"),
        "accel η_m": (accel, p.kinematics_power, "pitch_amplitude"),
    }
    return {
        **{k: spread(select(rows, condition=c, **where), q) for k, (where, c, q) in picks.items()},
        "phase": phase_dependences(plan),
    }


def _series(plan: StudyPlan, method: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """What picks ``method``'s level and accelerating series (:func:`tables.select`)."""
    level = dict(method=method, task="level", planform="tear-drop")
    objective = plan.reading.objective(plan.preset.kinematics_objective)
    return level, dict(level, task="accelerate", objective=objective)


def lag(key: str, cid: str) -> C.Measure:
    """``phase`` or ``angle``: the spread of ``key`` (a :func:`view` key) [deg], about the
    fore/hind phase of claim ``cid``'s optimisations."""
    return lambda by, _: C.spread_stats(by[key], unit="deg", depends_on=by["phase"][cid])


def pitch_gain(by: Mapping[str, Any], _: Any) -> C.Stats:
    """``compare``: η_m accelerating − level [deg] of the medians (and of the best seeds)."""
    level, accel = by["level η_m"], by["accel η_m"]
    return {
        "median": accel.median - level.median,
        "best": accel.best - level.best,
        "unit": "deg",
        "detail": f"η_m level {level.describe()}°, accelerating {accel.describe()}°",
    }


NOISY = (
    "Φ_φ of each wing is a free parameter over ±180°; with a wide seed spread the median phase "
    "is noisy."
)
PITCH = "pitch amplitude η_m is larger in accelerating than in level flight (ours: accelerating − level)"
LEVEL = "level flight ({kinematics_speed:g} m/s): fore- and hind-wing flap out of phase (|ΔΦ|)"
LEADS = "at {phase_speed:g} m/s the hind-wing leads by about 30° (ΔΦ)"
ACCEL = "accelerating flight ({kinematics_power:g} W/kg): the wings flap in phase (|ΔΦ|)"
CLAIMS: tuple[C.ClaimSpec, ...] = (
    C.ClaimSpec("K1", "Fig. 11a", LEVEL, "out of phase", "phase", False, lag("level |ΔΦ|", "K1")),
    C.ClaimSpec("K2", "Fig. 11", LEADS, "+30°", "angle", PAPER_PHASE_LEAD, lag("ΔΦ", "K2"), NOISY),
    C.ClaimSpec("K3", "Fig. 11b", ACCEL, "in phase", "phase", True, lag("accel |ΔΦ|", "K3")),
    C.ClaimSpec("K4", "Fig. 12c", PITCH, "η_m,acc > η_m,level", "compare", (">", 0), pitch_gain),
)

analyse = Analysis(NAME, TITLE, QUANTITIES, draw, CLAIMS, view)
