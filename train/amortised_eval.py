"""``python -m train.amortised_eval``: an amortised policy judged at the held-out conditions
(what it measures and how: docs/training.md, "Amortised policy")::

    python -m train.amortised_eval --run logs/amortised/TandemWing-LevelFlight-v0_1 \\
        --polish 500 --records results/reference/records --out held_out.json
"""

from __future__ import annotations

import statistics
import sys
import time
import timeit
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from train.entry import command, exit_on_bad_environment, option

with exit_on_bad_environment("python -m train.amortised_eval"):
    from tandem_env.io.command import command_line

import numpy as np

from agents.records import Record
from agents.selection import best_index
from agents.tasks import get_task, task_of
from tandem_env.envs.declaration import refusal
from tandem_env.envs.reference import held_out_conditions, normalised_score
from tandem_env.io.files import output_directory, write_json_atomic
from tandem_env.physics.checks import is_integer

#: The most evaluations the warm-started polish may spend per condition [-].
MAX_POLISH = 500


def record_times(
    records: Sequence[Record], env_id: str, metric: str, planform: str, condition: float
) -> tuple[float, float, int] | None:
    """(wall time of the best record by the selection rule [s], sum over the records [s], count)
    of the harness ``records`` (the table's seeds and rounds) at ``condition``; None if none."""
    found = [
        record
        for record in records
        if record.results.get("env_id") == env_id
        and record.objective_name == metric
        and record.job.env("planform", "tear-drop") == planform
        and abs(record.job.condition - condition) < 1e-9
    ]
    if not found:
        return None
    best = found[best_index([r.feasible for r in found], [r.objective for r in found])]
    return best.wall_time, sum(r.wall_time for r in found), len(found)


def evaluate_held_out(
    run_dir: str | Path,
    *,
    polish_budget: int = 0,
    records: str | Path | None = None,
    cmaes_budget: int = 0,
    conditions: Sequence[float] | None = None,
    repeats: int = 20,
) -> dict[str, Any]:
    """The held-out evaluation of an amortised run (module docstring): ``{"rows": [...],
    "summary": {...}}``. ValueError for a bad budget, before any work."""
    from train.amortised import check_env_kwargs, make_problem
    from train.amortised_policy import load_policy

    if not is_integer(polish_budget) or not 0 <= polish_budget <= MAX_POLISH:
        raise refusal("polish", polish_budget, f"an integer from 0 (none) to {MAX_POLISH}")
    if not is_integer(cmaes_budget) or not 0 <= cmaes_budget <= 10**6:
        raise ValueError(f"cmaes budget = {cmaes_budget!r}; allowed: an integer from 0 (none)")
    policy = load_policy(run_dir)
    env_id, env_kwargs = policy.env_id, dict(policy.env_kwargs)
    series = check_env_kwargs(env_id, env_kwargs)
    values = np.asarray(
        held_out_conditions(env_id) if conditions is None else conditions, dtype=np.float64
    )
    problem = make_problem(env_id, env_kwargs)

    def scored(strokes: np.ndarray, at: Any) -> tuple[Any, Any, Any, np.ndarray]:
        """The evaluation, violations, reference optima and scores of ``strokes`` at ``at``."""
        found = problem.evaluate(strokes, at)
        reference = series.at(at)
        total = problem.declaration.score(found.result, problem.config).total
        score = normalised_score(reference, found.objective, found.feasible, total)
        return found, total, reference, score

    strokes = policy.strokes(values)
    found, violation, reference, score = scored(strokes, values)
    # the time to a stroke: one forward pass (observation, network, assembly) per condition
    single, batched = (
        timeit.repeat(lambda batch=batch: policy.strokes(batch), number=1, repeat=repeats)
        for batch in (values[:1], values)
    )
    keys = ("condition", "reference", "objective", "feasible", "violation", "score", "gap")
    columns = (values, reference, found.objective, found.feasible, violation, score, 100.0 - score)
    rows = [
        dict(zip(keys, row, strict=True))
        for row in zip(*(np.asarray(c).tolist() for c in columns), strict=True)
    ]
    if records is not None:
        from agents.store import read_record_files

        stored = read_record_files([records])  # once for every condition
        for row in rows:
            at = row["condition"]
            times = record_times(stored, env_id, problem.objective_metric, series.planform, at)
            if times is not None:
                row["optimiser_wall_time"], row["optimiser_wall_time_seeds"], row["seeds"] = times
    gaps = [r["gap"] for r in rows]
    summary: dict[str, Any] = {
        "feasible": sum(r["feasible"] for r in rows),
        "count": len(rows),
        "median_gap": statistics.median(gaps),
        "worst_gap": max(gaps),
        "run_dir": str(policy.run_dir),
        "env_id": env_id,
        "env_kwargs": env_kwargs,
        "objective": series.objective,
        "planform": series.planform,
        "conditions": "held-out" if conditions is None else "given",
        "stroke_seconds": statistics.median(single),
        "batch_seconds": statistics.median(batched),
        "batch": int(values.size),
    }
    if polish_budget:
        from agents.polish import AutogradGradient, PolishConfig, polish, task_problem

        task = get_task(task_of(env_id))
        for row, start in zip(rows, strokes, strict=True):
            began = time.perf_counter()
            view = task_problem(task, task.condition(row["condition"]), env_kwargs)
            result = polish(
                view,
                np.clip(start, -1.0, 1.0),
                polish_budget,
                PolishConfig(),
                AutogradGradient(view),
                infeasible_start=True,
            )
            seconds = time.perf_counter() - began
            after, _, _, polished = scored(result.stroke[None, :], row["condition"])
            row.update(
                polished_objective=float(after.objective[0]),
                polished_feasible=bool(after.feasible[0]),
                polished_score=float(polished[0]),
                polished_gap=100.0 - float(polished[0]),
                polish_evaluations=int(result.certificate.evaluations or 0),
                polish_seconds=seconds,
            )
        polished_gaps = [r["polished_gap"] for r in rows]
        summary.update(
            polish_budget=polish_budget,
            polished_feasible=sum(r["polished_feasible"] for r in rows),
            polished_median_gap=statistics.median(polished_gaps),
            polished_worst_gap=max(polished_gaps),
            polish_seconds_median=statistics.median(r["polish_seconds"] for r in rows),
        )
    timed = [r for r in rows if "optimiser_wall_time" in r]
    if timed:
        for seeds in ("", "_seeds"):
            recorded = [r[f"optimiser_wall_time{seeds}"] for r in timed]
            summary[f"optimiser_seconds{seeds}_median"] = statistics.median(recorded)
    if cmaes_budget:
        # a CMA-ES run (the harness's, its default polish included) at the first condition
        from agents.harness import run

        condition = float(values[0])
        start = time.perf_counter()
        [record] = run(
            "cmaes",
            task_of(env_id),
            condition,
            cmaes_budget,
            [0],
            progress=False,
            env_kwargs=env_kwargs,
        )
        gap = 100.0 - 100.0 * float(record.objective) / float(series.at(condition))
        summary.update(
            cmaes_condition=condition,
            cmaes_budget=cmaes_budget,
            cmaes_seconds=time.perf_counter() - start,
            cmaes_feasible=bool(record.feasible),
            cmaes_gap=gap if record.feasible else None,
        )
    return {"rows": rows, "summary": summary}


def format_report(report: Mapping[str, Any]) -> str:
    """The evaluation as lines of text."""
    s = report["summary"]
    lines = []
    for row in report["rows"]:
        text = (
            f"  {row['condition']:g}: objective {row['objective']:.4g} (optimum "
            f"{row['reference']:.4g}), feasible {row['feasible']}, gap {row['gap']:.2f} %"
        )
        if "polished_gap" in row:
            text += (
                f"; polished ({row['polish_evaluations']} evaluations, "
                f"{row['polish_seconds']:.1f} s): gap {row['polished_gap']:.2f} %, feasible "
                f"{row['polished_feasible']}"
            )
        if "optimiser_wall_time" in row:
            text += (
                f"; optimiser {row['optimiser_wall_time']:.1f} s (best seed), "
                f"{row['optimiser_wall_time_seeds']:.1f} s ({row['seeds']} records)"
            )
        lines.append(text)
    lines.append(
        f"{s['env_id']} {s['objective']} {s['planform']}, {s['count']} {s['conditions']} "
        f"conditions: feasible {s['feasible']}/{s['count']}, gap to the optimum median "
        f"{s['median_gap']:.2f} %, worst {s['worst_gap']:.2f} %"
    )
    if "polished_median_gap" in s:
        lines.append(
            f"after a warm-started polish of <= {s['polish_budget']} evaluations: feasible "
            f"{s['polished_feasible']}/{s['count']}, gap median {s['polished_median_gap']:.2f} "
            f"%, worst {s['polished_worst_gap']:.2f} % ({s['polish_seconds_median']:.1f} s "
            "median per condition)"
        )
    timing = (
        f"time to a stroke: {1e3 * s['stroke_seconds']:.2f} ms (one forward pass), "
        f"{1e3 * s['batch_seconds']:.2f} ms for all {s['batch']}"
    )
    if "optimiser_seconds_median" in s:
        timing += (
            f"; the optimiser's records: {s['optimiser_seconds_median']:.1f} s (best seed, "
            f"median), {s['optimiser_seconds_seeds_median']:.1f} s over all its records (median)"
        )
    lines.append(timing)
    if "cmaes_seconds" in s:
        gap = s["cmaes_gap"]
        lines.append(
            f"a fresh CMA-ES run of {s['cmaes_budget']} evaluations at {s['cmaes_condition']:g}: "
            f"{s['cmaes_seconds']:.1f} s, gap " + ("infeasible" if gap is None else f"{gap:.2f} %")
        )
    return "\n".join(lines)


@dataclass(frozen=True)
class HeldOutOptions:
    """Judge an amortised policy at the reference grid's held-out conditions.

    Its files are checked when made, before any evaluation."""

    run: str = option("--run")
    """Run folder of python -m train --algo amortised."""
    polish: int = option("--polish", default=0, metavar="N")
    """Warm-started polish of at most N evaluations per condition (at most MAX_POLISH, 500)."""
    records: str | None = option("--records", default=None)
    """Harness records of the reference run (wall times)."""
    cmaes_budget: int = option("--cmaes-budget", default=0, metavar="N")
    """Time a fresh CMA-ES run of N evaluations at the first held-out condition."""
    out: str | None = option("--out", default=None)
    """Write the report as JSON to this file."""

    def __post_init__(self) -> None:
        if self.records is not None and not Path(self.records).is_dir():
            raise ValueError(
                f"--records {self.records} is not a folder; allowed: the records folder of "
                "python -m eval reference --out DIR (DIR/records), or no --records (the "
                "optimiser's times are then left out)"
            )
        if self.out is not None:
            if self.out and Path(self.out).is_dir():
                raise ValueError(f"--out {self.out!r} is a folder; allowed: a file name")
            output_directory(self.out and Path(self.out).parent, "--out")


@command_line
def main(argv: Sequence[str] | None = None) -> int:
    with command(HeldOutOptions, argv) as args:
        report = evaluate_held_out(
            args.run,
            polish_budget=args.polish,
            records=args.records,
            cmaes_budget=args.cmaes_budget,
        )
    print(format_report(report))
    if args.out is not None:
        write_json_atomic(args.out, report)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
