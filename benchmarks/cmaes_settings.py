"""Which CMA-ES settings? Runs settings side by side on the convergence study's two conditions.

Per setting and seed, one harness run at level flight 1.5 m/s and one at accelerating flight
60 W/kg (each history gives every smaller budget); prints per task, setting and checkpoint the
median over seeds, the spread and the restarts, and writes every value to ``--out`` (CSV). Tune
on seeds other than those you report. Usage::

    python benchmarks/cmaes_settings.py --settings "popsize=13" "popsize=40" \\
        --seeds 100 101 102 103 --level-budget 30000 --accelerate-budget 12000
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from agents.harness import run
from tandem_env.io.files import write_csv_atomic
from tandem_env.io.keyvalue import parse_pairs

TASKS = {"level": (1.5, None), "accelerate": (60.0, "vertical")}


def best_at(history: tuple[tuple[int, float], ...], budget: int) -> float:
    """Best reward so far after ``budget`` evaluations (the step function of the history)."""
    values = [b for e, b in history if e <= budget]
    return values[-1] if values else -np.inf


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--settings", nargs="+", required=True, metavar='"K=V K=V"')
    parser.add_argument("--seeds", nargs="+", type=int, default=[100, 101, 102, 103])
    parser.add_argument("--level-budget", type=int, default=30_000)
    parser.add_argument("--accelerate-budget", type=int, default=12_000)
    parser.add_argument("--checkpoints", nargs="+", type=int, default=[4_000, 12_000, 30_000])
    parser.add_argument("--tasks", nargs="+", choices=tuple(TASKS), default=list(TASKS))
    parser.add_argument("--method", default="cmaes")
    parser.add_argument("--out", default="results/cmaes_settings.csv")
    args = parser.parse_args(argv)
    rows = []
    for setting in args.settings:
        config = parse_pairs(setting.split(), "--settings")
        for task in args.tasks:
            condition, objective = TASKS[task]
            budget = args.level_budget if task == "level" else args.accelerate_budget
            start = time.perf_counter()
            options = {"objective": objective, "method_config": config, "progress": False}
            records = run(args.method, task, condition, budget, args.seeds, **options)
            seconds = time.perf_counter() - start
            restarts = [len(r.config["method"].get("runs", [None])) - 1 for r in records]
            for checkpoint in [c for c in args.checkpoints if c <= budget]:
                values = np.array([best_at(r.history, checkpoint) for r in records])
                median = float(np.median(values))
                spread = float((values.max() - values.min()) / median) if median else np.nan
                case = {"method": args.method, "setting": setting, "task": task}
                rows += [
                    case
                    | {"budget": checkpoint, "seed": r.seed, "best_reward": float(v), "restarts": k}
                    for r, v, k in zip(records, values, restarts, strict=True)
                ]
                print(
                    f"{args.method} [{setting}] {task:<10} {checkpoint:>6}: median {median:.4f}, "
                    f"spread {spread:6.1%}, per seed "
                    + " ".join(f"{v:.4f}" for v in values)
                    + f"; restarts {restarts}; {seconds:.0f} s",
                    flush=True,
                )
    write_csv_atomic(Path(args.out), rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
