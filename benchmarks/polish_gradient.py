"""Wall cost of one polish gradient: autograd (torch backend) vs batched central differences (numba).

    python benchmarks/polish_gradient.py [--repeats 7] [--device cpu]

The polish's ``CentralDifferences`` (53 strokes in ONE numba call) against ``AutogradGradient``
(one torch stroke) on level flight at 1.5 m/s and accelerating flight at 60 W/kg, after a
warm-up: the median and fastest call [ms], their ratio, and the torch forward pass alone.
"""

from __future__ import annotations

import argparse
import statistics

import numpy as np
from shared import call_times, machine

from agents.polish import AutogradGradient, CentralDifferences, task_problem
from agents.tasks import ACCELERATE_TASK, LEVEL_TASK


def _times(function, repeats: int) -> list[float]:
    return [1e3 * seconds for seconds in call_times(function, repeats)[0]]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--device", default="cpu", help="torch device (default cpu)")
    args = parser.parse_args()
    import torch

    print(
        f"{machine()}; torch {torch.__version__} ({torch.get_num_threads()} threads), "
        f"device {args.device}"
    )
    rng = np.random.default_rng(0)
    cases = ((LEVEL_TASK, 1.5, {}), (ACCELERATE_TASK, 60.0, {"objective": "vertical"}))
    for task, value, kwargs in cases:
        condition = task.condition(value)
        numba = CentralDifferences(task_problem(task, condition, kwargs))
        torch_kwargs = {**kwargs, "backend": "torch", "device": args.device}
        problem = task_problem(task, condition, torch_kwargs)
        autograd = AutogradGradient(problem)
        x = rng.uniform(-0.9, 0.9, 28)
        cd = _times(lambda: numba(x), args.repeats)  # noqa: B023 (called here, in the loop)
        ag = _times(lambda: autograd(x), args.repeats)  # noqa: B023
        forward = _times(lambda: problem.evaluate(x[None, :]), args.repeats)  # noqa: B023
        cd_med, ag_med = statistics.median(cd), statistics.median(ag)
        print(
            f"{task.name:>10}: central differences ({numba.cost} strokes, numba) "
            f"{cd_med:7.1f} ms (fastest {min(cd):.1f}); autograd (1 stroke, torch) "
            f"{ag_med:7.1f} ms (fastest {min(ag):.1f}); autograd / differences "
            f"{ag_med / cd_med:.1f}; torch forward alone {statistics.median(forward):.1f} ms"
        )


if __name__ == "__main__":
    main()
