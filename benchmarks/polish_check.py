"""Independent check of reported optima: how much a fresh local polish still gains from each.

    python benchmarks/polish_check.py results/acc60 [results/level15 ...]

For every harness record in the stores: an SLSQP of its own (sharing no code with
``agents/polish.py``, whose work it checks) from the record's stroke under the task's margins.
Prints per record the objective, the fresh polish's gain [%] and its final violation, then per
condition how many seeds gain < 0.5 %, the best of each half of the seeds and the median.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from collections import defaultdict

import gymnasium as gym
import numpy as np
from scipy.optimize import minimize

import tandem_env  # noqa: F401 (registers the envs)
from agents.records import Record
from agents.store import read_record_files
from agents.tasks import get_task
from tandem_env.physics.stroke import DISCRETE

STEP = 1e-5
GAIN_LIMIT = 0.5  # [%]


def fresh_polish(record: Record) -> tuple[float, float, float, int]:
    """(objective before, after, worst constraint violation after, iterations)."""
    value = record.condition.value
    keyword = get_task(record.task).declared_condition.keyword
    kwargs = {**dict(record.job.env_kwargs), keyword: value}
    env = gym.make(record.env_id, disable_env_checker=True, **kwargs)
    problem = env.unwrapped.problem()
    env.close()
    x0 = np.array(record.normalised_stroke)
    free = np.flatnonzero(~DISCRETE)

    def batch(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.repeat(x0[None, :], z.shape[0], axis=0)
        x[:, free] = np.clip(z, -1.0, 1.0)
        evaluation = problem.evaluate(x, value)
        return evaluation.objective, evaluation.margins

    def derivatives(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k, eye = z.size, np.eye(z.size, dtype=bool)
        hi, lo = np.minimum(z + STEP, 1.0), np.maximum(z - STEP, -1.0)
        f, c = batch(np.concatenate([np.where(eye, hi, z), np.where(eye, lo, z)]))  # ± each in turn
        width = hi - lo
        return (f[:k] - f[k:]) / width, ((c[:k] - c[k:]) / width[:, None]).T

    def margins(z: np.ndarray) -> np.ndarray:
        return derivatives(z)[1]

    z0 = x0[free]
    f0 = float(batch(z0[None, :])[0][0])
    res = minimize(
        lambda z: -float(batch(z[None, :])[0][0]),
        z0,
        jac=lambda z: -derivatives(z)[0],
        method="SLSQP",
        bounds=[(-1.0, 1.0)] * z0.size,
        constraints=[{"type": "ineq", "fun": lambda z: batch(z[None, :])[1][0], "jac": margins}],
        options={"ftol": 1e-10, "maxiter": 500},
    )
    f1, c1 = batch(np.asarray(res.x)[None, :])
    return f0, float(f1[0]), float(max(0.0, -c1[0].min())), int(res.nit)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("stores", nargs="+")
    args = parser.parse_args()
    groups: dict[tuple, list[tuple[Record, float]]] = defaultdict(list)
    for record in sorted(read_record_files(args.stores), key=lambda r: r.seed):
        before, after, violation, iterations = fresh_polish(record)
        gain = 100.0 * (after / before - 1.0)
        print(
            f"{record.label()}: {record.objective_name} = {record.objective:.5f} "
            f"(feasible {record.feasible}, {record.evaluations} evaluations); fresh polish "
            f"{gain:+.3f} % in {iterations} iterations, violation after {violation:.1e}",
            flush=True,
        )
        key = (record.task, record.objective_name, record.condition.value, record.budget)
        groups[key].append((record, gain))
    for key, rows in groups.items():
        half = len(rows) // 2
        first = max(r.objective for r, _ in rows[:half]) if half else float("nan")
        second = max(r.objective for r, _ in rows[half:]) if half else float("nan")
        small = sum(g < GAIN_LIMIT for _, g in rows)
        print(
            f"{key}: seeds {rows[0][0].seed}-{rows[-1][0].seed} ({len(rows)}): all feasible "
            f"{all(r.feasible for r, _ in rows)}, within budget "
            f"{all(r.evaluations <= r.budget for r, _ in rows)}; fresh polish gain < "
            f"{GAIN_LIMIT} % on {small}/{len(rows)}; best of first half {first:.5f}, second "
            f"{second:.5f}, apart {100 * abs(first - second) / max(first, second):.2f} %; "
            f"median {statistics.median(r.objective for r, _ in rows):.5f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
