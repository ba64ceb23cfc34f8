"""Budget study: best-so-far against evaluations, PSO and CMA-ES side by side.

Each method of the preset's :class:`~eval.studies.presets.ConvergenceSpec` (PSO and CMA-ES
with their default settings), plus any method the study is run with, runs with a long budget
at one level condition (η at 1.5 m/s) and one accelerating condition (F̄_v at 60 W/kg), several
seeds each. Both methods have the prefix property (a run with budget B is exactly the first B
evaluations of a longer run with the same seed), so each run's history gives the best reward
that every smaller budget would have reached. The table lists, per condition, method and
checkpoint budget, the median over seeds, the IQR, min and max, the spread (max − min) /
median and the median as a fraction of the longest run's median; the presets' methods and
budgets are chosen from it (docs/reproduction.md).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from agents.records import Record
from eval import figures
from eval.studies.base import StudyOutput, StudyPlan, write_tables
from eval.studies.presets import PRESETS
from eval.studies.runner import Job
from tandem_env.io.files import write_csv_atomic, write_text_atomic

NAME = "convergence"
TITLE = "Budget study: PSO and CMA-ES best-so-far over evaluations"
CHECKPOINTS = (1_000, 2_000, 4_000, 6_000, 8_000, 12_000, 16_000, 20_000, 30_000, 40_000, 60_000)


def methods(plan: StudyPlan) -> tuple[str, ...]:
    """The spec's methods, then those the study is run with."""
    return tuple(dict.fromkeys((*plan.preset.convergence.methods, *plan.methods)))


def jobs(plan: StudyPlan) -> list[Job]:
    spec = plan.preset.convergence
    side_by_side = StudyPlan(plan.preset, methods(plan), execution=plan.execution)
    return [
        *side_by_side.jobs("level", [spec.speed], budget=spec.budget, seeds=spec.seeds),
        *side_by_side.jobs(
            "accelerate", [spec.power], objective="vertical", budget=spec.budget, seeds=spec.seeds
        ),
    ]


def curves(records: Mapping[Job, Record], task: str, method: str) -> tuple[np.ndarray, np.ndarray]:
    """(evaluations (n,), best reward so far (seeds, n)) on a common evaluation grid."""
    chosen = sorted(
        (r for j, r in records.items() if j.task == task and j.method == method),
        key=lambda r: r.seed,
    )
    grid = np.array(sorted({e for r in chosen for e, _ in r.history}), dtype=float)
    values = np.empty((len(chosen), grid.size))
    for i, record in enumerate(chosen):
        e, b = (np.array(v, dtype=float) for v in zip(*record.history, strict=True))
        # Best-so-far is a step function of evaluations: hold the last value.
        idx = np.searchsorted(e, grid, side="right") - 1
        values[i] = np.where(idx >= 0, b[np.clip(idx, 0, None)], -np.inf)
    return grid, values


def checkpoint_rows(
    label: str, method: str, grid: np.ndarray, values: np.ndarray
) -> list[dict[str, Any]]:
    """Median, IQR, min, max, spread and fraction of the longest run's median per checkpoint.

    spread = (max − min) / median over seeds. The fraction is of the value itself, not of the
    gain from the first batch, whose median is a penalised (infeasible) reward and would make
    every budget look converged.
    """
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


def markdown_table(rows: list[dict[str, Any]]) -> str:
    """The checkpoint table as Markdown (what docs/reproduction.md shows)."""
    lines = [
        "| condition | method | budget | median | IQR | min - max | spread | median / final |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        budget = f"{r['budget']:,}".replace(",", " ")
        lines.append(
            f"| {r['condition']} | {r['method']} | {budget} | {r['median']:.3f} | "
            f"{r['q25']:.3f} - {r['q75']:.3f} | {r['min']:.3f} - {r['max']:.3f} | "
            f"{100 * r['spread']:.1f} % | {100 * r['fraction_of_final_median']:.0f} % |"
        )
    return "\n".join(lines) + "\n"


def analyse(plan: StudyPlan, records: Mapping[Job, Record], out_dir: Path) -> StudyOutput:
    rows, files = write_tables(NAME, records, out_dir, ("objective_value",))
    spec = plan.preset.convergence
    labels = {
        "level": f"level, V = {spec.speed:g} m/s (η)",
        "accelerate": f"accelerating, {spec.power:g} W/kg (F̄_v)",
    }
    panels, table = [], []
    for task, label in labels.items():
        series = []
        for method in methods(plan):
            grid, values = curves(records, task, method)
            series.append((method, grid, values))
            table += checkpoint_rows(label, method, grid, values)
        budgets = [(p.name, p.budget(task)) for p in PRESETS.values()]
        panels.append((label, series, budgets))
    path = out_dir / NAME / "convergence_checkpoints.csv"
    write_csv_atomic(path, table)
    markdown = out_dir / NAME / "convergence_checkpoints.md"
    write_text_atomic(markdown, markdown_table(table))
    files += [path, markdown]
    fig = figures.convergence_figure(panels, plan.figure(out_dir / NAME, "convergence"))
    caption = f"{' and '.join(methods(plan))} best-so-far over evaluations"
    return StudyOutput(NAME, TITLE, rows, [(caption, fig)], [], files)
