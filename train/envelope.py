"""``python -m train.envelope``: one trained policy (ppo, sac or amortised) asked, through the
harness method ``policy:RUN_DIR``, for its stroke at every sweep condition, each recorded like
a PSO result; ``envelope.csv`` gathers them (docs/training.md, "One policy for the whole
envelope")::

    python -m train.envelope --run logs/sac/TandemWing-LevelFlight-v0_1 --out results/envelope-sac
"""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from train.entry import command, exit_on_bad_environment, option

# importing tandem_env checks numba's environment: a bad setting is one line and status 2
with exit_on_bad_environment("python -m train.envelope"):
    from tandem_env.io.command import command_line
from agents.tasks import available_tasks, get_task, task_of
from tandem_env.envs.registration import condition_keywords
from tandem_env.io.files import output_directory, write_csv_atomic

#: Columns of envelope.csv.
COLUMNS: tuple[str, ...] = tuple(
    "condition condition_value condition_unit objective_name objective reward feasible score "
    "efficiency lift_to_weight power_per_mass excess_vertical excess_horizontal "
    "constraint_violation trained_at evaluations training_timesteps model run_dir".split()
)
#: The columns that are a record's attributes.
RECORD_COLUMNS = COLUMNS[3:8]


def evaluate_envelope(
    run_dir: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    conditions: Sequence[float] | None = None,
    which: str = "best",
) -> list[dict[str, Any]]:
    """Record the run's policy at each condition (default the task's declared sweep),
    one job each, run and stored in turn by the runner (:func:`agents.runner.run_jobs`); a rerun
    replaces the records (the run may hold a newer model of the same name). Writes envelope.csv."""
    from agents.harness import prepare
    from agents.runner import run_jobs
    from train.trained_policy import TrainingMismatchWarning, load_policy

    policy = load_policy(run_dir, which)  # type: ignore[arg-type]
    task = task_of(policy.env_id)
    # The harness sets the condition itself; every other training option is kept.
    env_kwargs = {k: v for k, v in policy.env_kwargs.items() if k not in condition_keywords()}
    if conditions is None:
        declared = get_task(task).declaration.condition  # its env config's CONDITION
        if declared is None:
            raise ValueError(f"task {task!r} declares no sweep; give the conditions")
        conditions = declared.sweep
    values = tuple(conditions)
    out = Path(out_dir)
    with warnings.catch_warnings():
        # Said once, for every condition, by the trained_at column (and main's note).
        warnings.simplefilter("ignore", TrainingMismatchWarning)
        jobs = [
            prepare(
                f"policy:{run_dir}",
                task,
                float(value),
                budget=1,
                seeds=[0],
                env_kwargs=env_kwargs,
                method_config={"model": which},
            )[0]
            for value in values
        ]
        records = run_jobs(jobs, out, progress=False, rerun=True).records
    rows = []
    for value, job in zip(values, jobs, strict=True):
        record = records[job.job.key]
        condition = record.condition
        rows.append(
            {
                "condition": condition.name,
                "condition_value": condition.value,
                "condition_unit": condition.unit,
                **{k: getattr(record, k) for k in RECORD_COLUMNS},
                **{k: record.metrics[k] for k in COLUMNS if k in record.metrics},
                "trained_at": policy.trained_at(float(value)),
                "trained_over": policy.training_conditions,  # not a column: main's note
                "evaluations": record.evaluations,
                "training_timesteps": policy.num_timesteps,
                "model": policy.model_path.name,
                "task": task,  # not a column: main's note
                "run_dir": str(run_dir),
            }
        )
    write_csv_atomic(out / "envelope.csv", [{c: row.get(c) for c in COLUMNS} for row in rows])
    return rows


@dataclass(frozen=True)
class EnvelopeOptions:
    """Evaluate one trained policy at every sweep condition through the harness.

    Its output folder is checked when made, before any policy is loaded."""

    run: str = option("--run")
    """Run folder written by python -m train."""
    out: str = option("--out")
    """Output folder (envelope.csv, records/)."""
    conditions: tuple[float, ...] | None = option("--conditions", default=None)
    """Conditions to evaluate (default: the task's sweep, below)."""
    model: str = option("--model", default="best", choices=("best", "final"))
    """The run's model: best_model.zip, or the final one."""

    def __post_init__(self) -> None:
        output_directory(self.out, folders=("records",), files=("envelope.csv",))


@command_line
def main(argv: Sequence[str] | None = None) -> int:
    script = Path(sys.argv[0]).name == "tandem-envelope"
    sweeps = []
    for name in available_tasks():
        declared = get_task(name).declaration.condition
        if declared is not None:
            values = ", ".join(f"{v:g}" for v in declared.sweep)
            sweeps.append(f"{name}: {declared.keyword} {values} {declared.unit}")
    with command(
        EnvelopeOptions,
        argv,
        prog="tandem-envelope" if script else "python -m train.envelope",
        epilog=f"The tasks' sweeps (the default --conditions): {'; '.join(sweeps)}",
    ) as args:
        rows = evaluate_envelope(args.run, args.out, conditions=args.conditions, which=args.model)
    for row in rows:
        print(
            f"{row['condition']} = {row['condition_value']:g} {row['condition_unit']}: "
            f"{row['objective_name']} = {row['objective']:.4g}, feasible {row['feasible']}, "
            f"score {row['score']:.1f}, {row['evaluations']} evaluation(s)"
            + ("" if row["trained_at"] else " (outside training)")
        )
    outside = [row for row in rows if not row["trained_at"]]
    if outside:
        seen = outside[0]["trained_over"]
        declared = get_task(outside[0]["task"]).declaration.condition
        ranged = "a range" if declared is None else declared.range_keyword
        unit = outside[0]["condition_unit"]
        trained = f"({seen[0]:g}, {seen[1]:g})" if isinstance(seen, tuple) else f"{seen:g}"
        print(
            f"note: the policy was trained at {outside[0]['condition']} = {trained} {unit}; "
            f"{len(outside)} of {len(rows)} conditions lie outside that, where its strokes are "
            f"extrapolations (a policy for the whole envelope is trained with {ranged}, "
            "docs/training.md)"
        )
    print(f"wrote {Path(args.out) / 'envelope.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
