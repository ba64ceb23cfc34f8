"""Budget study: best-so-far against evaluations, PSO and CMA-ES side by side.

Each method of the preset's :class:`~eval.studies.presets.ConvergenceSpec` (and any the study is
run with) runs long, without a polish, at one level and one accelerating (F̄_v) condition; by
the prefix property each run's history gives every smaller budget's best (:func:`checkpoint_rows`).
The budget splits between search and polish run at the preset's own budgets (:func:`split_rows`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from agents.jobs import Job
from agents.polish import split_settings as polish_settings
from agents.records import Record
from eval import figures
from eval.studies.base import Records, StudyOutput, StudyPlan, write_tables
from eval.studies.presets import STUDY_PRESETS
from eval.studies.report import Column, markdown_table
from eval.studies.tables import Rows
from tandem_env.io.files import write_csv_atomic, write_text_atomic

NAME = "convergence"
TITLE = "Budget study: PSO and CMA-ES best-so-far over evaluations"
CHECKPOINTS = (1_000, 2_000, 4_000, 6_000, 8_000, 12_000, 16_000, 20_000, 30_000, 40_000, 60_000)


def methods(plan: StudyPlan) -> tuple[str, ...]:
    """The spec's methods, then those the study is run with."""
    return tuple(dict.fromkeys((*plan.preset.convergence.methods, *plan.methods)))


def _with(job: Job, settings: tuple[tuple[str, object], ...]) -> Job:
    return replace(job, method_config=(*job.method_config, *settings))


def _spec_jobs(plan: StudyPlan, **given: Any) -> list[Job]:
    """``plan``'s jobs at the spec's level and accelerating (F̄_v) conditions, the spec's seeds,
    started cold (the budget study compares the methods' own searches)."""
    spec = plan.preset.convergence
    given |= {"seeds": spec.seeds, "warm": False}
    return [
        *plan.jobs("level", [spec.speed], **given),
        *plan.jobs("accelerate", [spec.power], objective="vertical", **given),
    ]


def long_jobs(plan: StudyPlan) -> list[Job]:
    """The long runs, one per method, condition and seed, without a polish."""
    side_by_side = StudyPlan(plan.preset, methods(plan), execution=plan.execution)
    budget = plan.preset.convergence.budget
    return [_with(job, (("polish", "none"),)) for job in _spec_jobs(side_by_side, budget=budget)]


def split_jobs(plan: StudyPlan) -> dict[float, list[Job]]:
    """Per polish share: the preset's method at its budgets, both conditions, the spec's seeds."""
    one = StudyPlan(plan.preset, (plan.preset.method,))
    return {
        float(share): [
            _with(job, polish_share_settings(plan.preset.method, float(share)))
            for job in _spec_jobs(one)
        ]
        for share in plan.preset.convergence.polish_shares
    }


def polish_share_settings(method: str, share: float) -> tuple[tuple[str, object], ...]:
    """The method settings of a polish share: none for the method's default (the other studies'
    jobs), else the share."""
    default = polish_settings(method, {})[0]
    if share == 0:
        return (("polish", "none"),) if default.enabled else ()
    if default.enabled:
        return () if share == default.share else (("polish_share", share),)
    return (("polish", "slsqp"), ("polish_share", share))


def jobs(plan: StudyPlan) -> list[Job]:
    splits = [job for group in split_jobs(plan).values() for job in group]
    return list(dict.fromkeys([*long_jobs(plan), *splits]))


def curves(runs: Sequence[Record]) -> tuple[np.ndarray, np.ndarray]:
    """(evaluations (n,), best reward so far (seeds, n)) of one method's and condition's long
    ``runs`` on a common evaluation grid."""
    chosen = sorted(runs, key=lambda r: r.seed)
    grid = np.array(sorted({e for r in chosen for e, _ in r.history}), dtype=float)
    values = np.empty((len(chosen), grid.size))
    for i, record in enumerate(chosen):
        e, b = (np.array(v, dtype=float) for v in zip(*record.history, strict=True))
        # Best-so-far is a step function of evaluations: hold the last value.
        idx = np.searchsorted(e, grid, side="right") - 1
        values[i] = np.where(idx >= 0, b[np.clip(idx, 0, None)], -np.inf)
    return grid, values


def split_rows(label: str, share: float, runs: Sequence[Record]) -> dict[str, Any]:
    """Reproducibility of one budget split from the records' feasible objectives:
    ``halves_apart`` = |best(first half) − best(second half)| / the larger [-], over the seeds."""
    runs = sorted(runs, key=lambda r: r.seed)
    values = np.array([r.objective if r.feasible else np.nan for r in runs], dtype=float)
    half = len(runs) // 2

    def stat(reduce: Any, part: np.ndarray) -> float:
        """``reduce`` of the finite values of ``part`` (NaN for none)."""
        finite = part[np.isfinite(part)]
        return float(reduce(finite)) if finite.size else math.nan

    first, second = (
        (stat(np.max, values[:half]), stat(np.max, values[half:])) if half else (math.nan,) * 2
    )
    known = [g for g in (r.certificate.get("gain") for r in runs) if g is not None]
    apart = abs(first - second) / max(first, second) if max(first, second) > 0 else math.nan
    return {
        "condition": label,
        "polish_share": share,
        "budget": runs[0].budget if runs else 0,
        "seeds": len(runs),
        "feasible": int(np.isfinite(values).sum()),
        "median": stat(np.median, values),
        "min": stat(np.min, values),
        "max": stat(np.max, values),
        "best_first_half": first,
        "best_second_half": second,
        "halves_apart": apart,
        "polish_gain_median": float(np.median(known)) if known else math.nan,
        "polish_converged": sum(bool(r.certificate.get("converged")) for r in runs),
    }


def checkpoint_rows(label: str, method: str, grid: np.ndarray, values: np.ndarray) -> Rows:
    """Median, IQR, min, max, spread ((max − min) / median) and fraction of the longest run's
    median (of the value, not the gain from a penalised first batch) per checkpoint."""
    final = np.median(values[:, -1])
    out = []
    for budget in [c for c in CHECKPOINTS if c <= grid[-1]] + [int(grid[-1])]:
        k = int(np.searchsorted(grid, budget, side="right") - 1)
        at = values[:, k]
        q25, med, q75 = np.percentile(at, [25.0, 50.0, 75.0])
        out.append(
            {
                "condition": label,
                "method": method,
                "budget": int(budget),
                "median": float(med),
                "q25": float(q25),
                "q75": float(q75),
                "min": float(at.min()),
                "max": float(at.max()),
                "spread": float((at.max() - at.min()) / med) if med > 0 else float("nan"),
                "fraction_of_final_median": float(med / final) if final else float("nan"),
                "seeds": int(values.shape[0]),
            }
        )
    return list({row["budget"]: row for row in out}.values())


#: The splits table's columns (Markdown; :func:`split_rows` gives its rows).
SPLIT_COLUMNS: tuple[Column, ...] = (
    ("condition", "{condition}".format_map),
    ("polish share", "{polish_share:g}".format_map),
    ("budget", "{budget}".format_map),
    ("seeds", "{seeds}".format_map),
    ("feasible", "{feasible}".format_map),
    ("median", "{median:.4f}".format_map),
    ("min - max", "{min:.4f} - {max:.4f}".format_map),
    ("best of halves", "{best_first_half:.4f} / {best_second_half:.4f}".format_map),
    ("apart", lambda row: f"{100 * row['halves_apart']:.2f} %"),
    (
        "median polish gain",
        lambda row: "–" if math.isnan(g := row["polish_gain_median"]) else f"{100 * g:+.2f} %",
    ),
    ("polish converged", "{polish_converged}".format_map),
)
#: The checkpoint table's columns (what docs/reproduction.md shows; :func:`checkpoint_rows`).
CHECKPOINT_COLUMNS: tuple[Column, ...] = (
    ("condition", "{condition}".format_map),
    ("method", "{method}".format_map),
    ("budget", lambda row: f"{row['budget']:,}".replace(",", " ")),
    ("median", "{median:.3f}".format_map),
    ("IQR", "{q25:.3f} - {q75:.3f}".format_map),
    ("min - max", "{min:.3f} - {max:.3f}".format_map),
    ("spread", lambda row: f"{100 * row['spread']:.1f} %"),
    ("median / final", lambda row: f"{100 * row['fraction_of_final_median']:.0f} %"),
)


def analyse(plan: StudyPlan, records: Records, out_dir: Path) -> StudyOutput:
    rows, files = write_tables(NAME, records, out_dir, ("objective_value",))
    spec = plan.preset.convergence
    labels = {
        "level": f"level, V = {spec.speed:g} m/s (η)",
        "accelerate": f"accelerating, {spec.power:g} W/kg (F̄_v)",
    }
    panels, table = [], []
    long = long_jobs(plan)
    for task, label in labels.items():
        series = []
        for method in methods(plan):
            own = [j for j in long if j.task == task and j.method == method and j in records]
            grid, values = curves([records[j] for j in own])
            series.append((method, grid, values))
            table += checkpoint_rows(label, method, grid, values)
        budgets = [(p.name, p.budget(task)) for p in STUDY_PRESETS.values()]
        panels.append((label, series, budgets))
    splits = []
    for share, group in split_jobs(plan).items():
        for task, label in labels.items():
            runs = [records[j] for j in group if j.task == task and j in records]
            if runs:
                splits.append(split_rows(label, share, runs))
    for stem, entries, columns in (
        ("convergence_splits", splits, SPLIT_COLUMNS),
        ("convergence_checkpoints", table, CHECKPOINT_COLUMNS),
    ):
        csv_path, md_path = (out_dir / NAME / f"{stem}.{ext}" for ext in ("csv", "md"))
        write_csv_atomic(csv_path, entries)
        write_text_atomic(md_path, "\n".join(markdown_table(columns, entries)) + "\n")
        files += [csv_path, md_path]
    fig = figures.convergence_figure(panels, plan.figure(out_dir / NAME, "convergence"))
    caption = f"{' and '.join(methods(plan))} best-so-far over evaluations"
    return StudyOutput(NAME, TITLE, rows, [(caption, fig)], [], files)
