"""Budget study: where does PSO's median best-so-far flatten?

PSO runs with a long budget at one level condition (η at 1.5 m/s) and one accelerating
condition (F̄_v at 60 W/kg), several seeds each. Because a constriction-PSO run with budget
B is exactly the first B evaluations of a longer run with the same seed (see
:class:`~eval.studies.presets.ConvergenceSpec`), each run's history gives the best reward
that every smaller budget would have reached. The table lists the median and IQR over seeds at
checkpoint budgets and the median as a fraction of the longest run's; the presets' budgets
are chosen from it (docs/reproduction.md): the paper preset uses the smallest checkpoint whose
median reaches 90 % of the longest run's median.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from agents.fileio import write_csv_atomic
from agents.records import Record
from eval import figures
from eval.studies.base import Plan, StudyOutput, write_tables
from eval.studies.presets import PRESETS
from eval.studies.runner import Job

NAME = "convergence"
TITLE = "PSO budget study (best-so-far over evaluations)"
CHECKPOINTS = (1_000, 2_000, 4_000, 6_000, 8_000, 12_000, 16_000, 20_000, 30_000, 40_000, 60_000)


def jobs(plan: Plan) -> list[Job]:
    spec = plan.preset.convergence
    return [
        *plan.jobs("level", [spec.speed], budget=spec.budget, seeds=spec.seeds),
        *plan.jobs(
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


def checkpoint_rows(label: str, grid: np.ndarray, values: np.ndarray) -> list[dict[str, Any]]:
    """Median, IQR and the median as a fraction of the longest run's median at each checkpoint.

    The fraction is of the value itself, not of the gain from the first batch, whose median
    is a penalised (infeasible) reward and would make every budget look converged.
    """
    final = np.median(values[:, -1])
    out = []
    for budget in [c for c in CHECKPOINTS if c <= grid[-1]] + [int(grid[-1])]:
        k = int(np.searchsorted(grid, budget, side="right") - 1)
        q25, med, q75 = np.percentile(values[:, k], [25.0, 50.0, 75.0])
        out.append(
            {
                "condition": label,
                "budget": int(budget),
                "median": float(med),
                "q25": float(q25),
                "q75": float(q75),
                "min": float(values[:, k].min()),
                "max": float(values[:, k].max()),
                "fraction_of_final_median": float(med / final) if final else float("nan"),
                "seeds": int(values.shape[0]),
            }
        )
    return list({row["budget"]: row for row in out}.values())


def analyse(plan: Plan, records: Mapping[Job, Record], out_dir: Path) -> StudyOutput:
    rows, files = write_tables(NAME, records, out_dir, ("objective_value",))
    spec = plan.preset.convergence
    method = plan.methods[0]
    labels = {
        "level": f"level, V = {spec.speed:g} m/s (η)",
        "accelerate": f"accelerating, {spec.power:g} W/kg (F̄_v)",
    }
    plotted, table = [], []
    for task, label in labels.items():
        grid, values = curves(records, task, method)
        budgets = [(p.name, p.budget(task)) for p in PRESETS.values()]
        plotted.append((f"{label}, {method}", grid, values, budgets))
        table += checkpoint_rows(label, grid, values)
    path = out_dir / NAME / "convergence_checkpoints.csv"
    write_csv_atomic(path, table)
    files.append(path)
    fig = figures.convergence_figure(plotted, out_dir / NAME / "convergence.png")
    return StudyOutput(NAME, TITLE, rows, [("PSO best-so-far over evaluations", fig)], [], files)
