"""What the polish's float32 margin costs in objective, to first order, at stored optima.

    python benchmarks/float32_margin.py results/study [more stores ...]

The polish holds one float32 step of every coordinate inside each constraint. At each record's
stroke: the multipliers λ of the active constraints (non-negative least squares) and the
margins m; prints the first-order cost Σ λ_i m_i per record, then its median and largest
relative to the objective.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from scipy.optimize import nnls

from agents.harness import prepare_job
from agents.polish import CentralDifferences, float32_margin, task_problem
from agents.store import RecordStore

ACTIVE = 1e-6


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("stores", nargs="+", metavar="DIR", help="record stores (--out folders)")
    args = parser.parse_args(argv)
    costs = []
    for store in args.stores:
        for record in (r for r in RecordStore(store).records() if r.feasible):
            prepared = prepare_job(record.job)
            problem = task_problem(prepared.task, prepared.condition, prepared.env_kwargs)
            stroke = np.asarray(record.normalised_stroke)
            grad = CentralDifferences(problem, 1e-5)(stroke)
            margin = float32_margin(grad.jacobian, 0.0)
            active = grad.margins <= ACTIVE
            x = stroke[list(problem.free)]
            eye = np.eye(x.size)
            bounds = [-eye[:, x >= 1 - ACTIVE], eye[:, x <= -1 + ACTIVE]]
            a = np.concatenate([grad.jacobian[active].T, *bounds], axis=1)
            multipliers = np.zeros(margin.size)
            if active.any():
                solution, _ = nnls(a, -grad.objective_gradient)
                multipliers[active] = solution[: int(active.sum())]
            cost = float(np.sum(multipliers * margin))
            relative = cost / abs(record.objective) if record.objective else 0.0
            costs.append(relative)
            names = [n for n, on in zip(grad.names, active, strict=True) if on]
            print(
                f"{record.label()}: objective {record.objective:.6g}, active {names or 'none'}, "
                f"margin {', '.join(f'{m:.2g}' for m in margin)}, cost {cost:.2g} "
                f"({relative:.2g} relative)"
            )
    if not costs:
        print("no feasible records", file=sys.stderr)
        return 1
    print(
        f"{len(costs)} records: first-order cost relative to the objective: median "
        f"{np.median(costs):.2g}, largest {np.max(costs):.2g}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
