"""How much of a PSO run is the PSO itself? (target: < 5 % at a swarm of 40).

Runs the harness's PSO on level flight exactly as ``agents.harness`` does (ask, one
vector-env step of the whole swarm, tell) and times separately

* the model call (``tandem_env.evaluate`` inside the env),
* the vector-env step (reset with the condition + step: the model call plus the env's own
  work, building rewards and infos),
* ask + tell (the PSO's arithmetic) and the remaining loop/bookkeeping.

The PSO's overhead is everything but the env step, as a share of the run time. Usage::

    python benchmarks/pso_overhead.py [--swarm-size 40] [--iterations 300] [--repeats 3]
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from dataclasses import dataclass

import numpy as np

from agents.evaluator import VectorEnvEvaluator
from agents.pso import PSOConfig
from agents.tasks import LEVEL

TARGET = 0.05


@dataclass
class Timing:
    total: float = 0.0
    env_step: float = 0.0
    model: float = 0.0
    ask_tell: float = 0.0
    evaluations: int = 0

    @property
    def overhead(self) -> float:
        """Share of the run spent outside the vector-env step."""
        return (self.total - self.env_step) / self.total


def time_run(swarm_size: int, iterations: int, seed: int, speed: float) -> Timing:
    task_module = importlib.import_module("tandem_env.envs.task")
    real = task_module.evaluate
    timing = Timing()

    def timed_evaluate(*args, **kwargs):
        start = time.perf_counter()
        try:
            return real(*args, **kwargs)
        finally:
            timing.model += time.perf_counter() - start

    task_module.evaluate = timed_evaluate
    try:
        budget = swarm_size * iterations
        config = PSOConfig(swarm_size=swarm_size, max_evaluations=budget)
        condition = LEVEL.condition(speed)
        start = time.perf_counter()
        with VectorEnvEvaluator(LEVEL, condition, {"speed": speed}, seed, budget) as evaluator:
            optimiser = config.build(28, seed)
            while not optimiser.done:
                t0 = time.perf_counter()
                X = optimiser.ask()
                t1 = time.perf_counter()
                rewards = evaluator(X)
                t2 = time.perf_counter()
                optimiser.tell(X, rewards)
                timing.ask_tell += (t1 - t0) + (time.perf_counter() - t2)
            timing.total = time.perf_counter() - start
            timing.env_step = evaluator.step_time
            timing.evaluations = evaluator.evaluations
    finally:
        task_module.evaluate = real
    return timing


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--swarm-size", type=int, default=40)
    parser.add_argument("--iterations", type=int, default=300)
    parser.add_argument("--repeats", type=int, default=3, help="runs (seeds 0..repeats-1)")
    parser.add_argument("--speed", type=float, default=1.5, help="flight speed [m/s]")
    args = parser.parse_args(argv)

    time_run(args.swarm_size, 3, 0, args.speed)  # warm-up: numba cache load, env construction
    timings = [
        time_run(args.swarm_size, args.iterations, seed, args.speed) for seed in range(args.repeats)
    ]
    print(
        f"PSO on {LEVEL.env_id} at V = {args.speed} m/s: swarm {args.swarm_size}, "
        f"{args.iterations} iterations ({args.swarm_size * args.iterations} evaluations), "
        f"{args.repeats} runs"
    )
    print(
        f"{'run':>4} {'total [s]':>10} {'model [s]':>10} {'env step [s]':>13} "
        f"{'ask+tell [s]':>13} {'evals/s':>9} {'PSO overhead':>13}"
    )
    for k, t in enumerate(timings):
        print(
            f"{k:>4} {t.total:>10.3f} {t.model:>10.3f} {t.env_step:>13.3f} {t.ask_tell:>13.4f} "
            f"{t.evaluations / t.total:>9.0f} {t.overhead:>12.2%}"
        )
    total = sum(t.total for t in timings)
    env_step = sum(t.env_step for t in timings)
    model = sum(t.model for t in timings)
    ask_tell = sum(t.ask_tell for t in timings)
    overhead = (total - env_step) / total
    print(
        f"all  vector-env step {env_step:.3f} s ({env_step / total:.1%} of the run; of which "
        f"the model call {model:.3f} s, the env's own work {env_step - model:.3f} s)"
    )
    print(
        f"all  PSO overhead (everything but the env step) {total - env_step:.3f} s = "
        f"{overhead:.2%} of {total:.3f} s (ask+tell {ask_tell:.3f} s = "
        f"{ask_tell / total:.2%}); target < {TARGET:.0%}: "
        f"{'met' if overhead < TARGET else 'NOT met'}"
    )
    per_iter = np.array([t.ask_tell for t in timings]) / args.iterations
    print(f"     ask+tell per iteration: {per_iter.mean() * 1e6:.0f} µs")
    return 0 if overhead < TARGET else 1


if __name__ == "__main__":
    sys.exit(main())
