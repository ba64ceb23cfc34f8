"""Model throughput: tandem-cycle evaluations per second, and where the time goes.

    python benchmarks/model_throughput.py [--repeats 5] [--seed 0]

One evaluation is one full wing-beat cycle of both wing pairs at the default (converged)
resolution; "coupled" solves each pair's momentum inflow and the fore-wing's slipstream on the
hind-wing, "isolated" each pair's inflow alone, "none" no inflow at all. Numbers are the best of
``--repeats`` timed calls after a warm-up call (which compiles or loads the numba cache); the
breakdown also gives CPU time (all threads), steadier than wall time on a loaded machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numba
import numpy as np

import tandem_env as te
from tandem_env.physics import model


def best_times(call, repeats: int) -> tuple[float, float]:
    """Best wall and best CPU (all threads) seconds of ``repeats`` calls after a warm-up."""
    call()
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        call()
        wall.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    return min(wall), min(cpu)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--repeats", type=int, default=5, help="timed calls per case (best is kept)"
    )
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    options = te.ModelOptions()
    rng = np.random.default_rng(args.seed)
    strokes = te.normalised_to_physical(rng.uniform(-1, 1, (1024, 28)))
    speeds = rng.uniform(0.25, 2.0, 1024)
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"numba {numba.__version__} with {numba.get_num_threads()} threads"
    )
    print(
        f"default resolution: n_time = {options.n_time} samples per cycle, "
        f"n_blade = {options.n_blade} blade elements per wing, inflow tolerance {options.tolerance:g}"
    )
    print()
    print(f"{'batch':>6} {'induction':>10} {'evals/s':>10} {'ms/call':>9} {'inflow sweeps*':>15}")
    for induction in ("coupled", "isolated", "none"):
        opts = te.ModelOptions(induction=induction)
        for batch in (1, 64, 1024):
            x, v = strokes[:batch], speeds[:batch]
            seconds, _ = best_times(
                lambda x=x, v=v, opts=opts: te.evaluate(x, v, options=opts), args.repeats
            )
            sweeps = te.evaluate(x, v, options=opts).induction_evaluations.mean()
            print(
                f"{batch:>6} {induction:>10} {batch / seconds:>10.0f} {1e3 * seconds:>9.2f} {sweeps:>15.1f}"
            )
    print("* force sweeps over the cycle needed by a stroke's slowest annulus, mean over the batch")
    print()
    print("where the time goes at batch 1024 (coupled), ms per call (best wall, best CPU):")
    angles, weights, frequency, beta, sweep = model._parametric_inputs(strokes, options.n_time)
    parts = {
        "validate strokes": lambda: te.validate_physical(strokes),
        "kinematics (angles, analytic rates)": lambda: model._parametric_inputs(
            strokes, options.n_time
        ),
        "cycle without inflow (frames, forces, power, means)": lambda: model.run_kernel(
            angles,
            weights,
            frequency,
            beta,
            sweep,
            speeds,
            np.zeros_like(speeds),
            te.DRAGONFLY,
            te.ModelOptions(induction="none"),
        ),
        "cycle with coupled inflow": lambda: model.run_kernel(
            angles,
            weights,
            frequency,
            beta,
            sweep,
            speeds,
            np.zeros_like(speeds),
            te.DRAGONFLY,
            options,
        ),
        "whole evaluate()": lambda: te.evaluate(strokes, speeds),
    }
    for name, call in parts.items():
        wall, cpu = best_times(call, args.repeats)
        print(f"  {name:<55} {1e3 * wall:8.2f} {1e3 * cpu:8.2f}")


if __name__ == "__main__":
    main()
