"""Model throughput: tandem-cycle evaluations per second, and where the time goes.

    python benchmarks/model_throughput.py [--repeats 5] [--seed 0]
    python benchmarks/model_throughput.py --backend torch [--device cuda] [--dtype float32]
        [--threads 1] [--batches 1 64 1024] [--gradient]
    python benchmarks/model_throughput.py --json results/throughput.json   # the numbers too

One evaluation is one wing-beat cycle of both wing pairs at the default resolution, per inflow
model ("coupled", "isolated", "none"); numbers are the best of ``--repeats`` calls after a
warm-up, the breakdown with CPU time too. ``--backend torch`` times the torch port per batch
and, on the CPU, numba on the same strokes (the ratio > 1: torch faster); ``--gradient`` adds
one autograd gradient against a batched central difference. ``--json PATH`` also writes the
numbers (``python -m eval numbers`` renders docs/model.md §12 from them).
"""

from __future__ import annotations

import argparse
import platform
from dataclasses import replace
from functools import partial
from itertools import product
from typing import Any

import numba
import numpy as np
from shared import PAPER, best_time, call_times, machine, parser_with_json, write_numbers

import tandem_env as te
from tandem_env.physics import model
from tandem_env.physics.stroke import DISCRETE, LOWER, UPPER


def main() -> None:
    parser = parser_with_json(__doc__)
    parser.add_argument("--repeats", type=int, default=5, help="timed calls per case (best kept)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--backend", choices=("numba", "torch"), default="numba")
    parser.add_argument("--device", default=None, help="torch device (default: the CPU)")
    parser.add_argument("--dtype", choices=("float64", "float32"), default="float64")
    parser.add_argument("--threads", type=int, default=None, help="torch CPU threads")
    parser.add_argument("--batches", type=int, nargs="+", default=None, help="batch sizes")
    parser.add_argument("--gradient", action="store_true", help="time gradients too")
    parser.add_argument("--compile", action="store_true", help="torch.compile the sweeps")
    parser.add_argument(
        "--induction", nargs="+", default=["coupled", "isolated", "none"], help="inflow models"
    )
    args = parser.parse_args()
    throughput = torch_throughput if args.backend == "torch" else numba_throughput
    write_numbers(args.json, throughput(args))


def numba_throughput(args: argparse.Namespace) -> dict[str, Any]:
    """Evaluations per second of the numba kernel per inflow model and batch, and where the
    time of one coupled batch of 1024 goes."""
    rng = np.random.default_rng(args.seed)
    strokes = te.normalised_to_physical(rng.uniform(-1, 1, (1024, 28)))
    speeds = rng.uniform(0.25, 2.0, 1024)
    print(machine())
    print(
        f"default resolution: n_time = {PAPER.n_time} samples per cycle, "
        f"n_blade = {PAPER.n_blade} blade elements per wing, inflow tolerance {PAPER.tolerance:g}\n"
    )
    numbers: dict[str, Any] = {"numba": numba.__version__, "numba_threads": numba.get_num_threads()}
    numbers |= {key: getattr(PAPER, key) for key in ("n_time", "n_blade", "tolerance")}
    numbers |= {"repeats": args.repeats, "rates": [], "breakdown": []}
    print(f"{'batch':>6} {'induction':>10} {'evals/s':>10} {'ms/call':>9} {'inflow sweeps*':>15}")
    for induction, batch in product(args.induction, args.batches or (1, 64, 1024)):
        opts = replace(PAPER, induction=induction)
        call = partial(te.evaluate, strokes[:batch], speeds[:batch], options=opts)
        seconds = best_time(call, args.repeats)
        sweeps = float(call().induction_evaluations.mean())
        rate, ms = batch / seconds, 1e3 * seconds
        print(f"{batch:>6} {induction:>10} {rate:>10.0f} {ms:>9.2f} {sweeps:>15.1f}")
        row = {"batch": batch, "induction": induction, "evaluations_per_s": rate}
        numbers["rates"].append(row | {"ms_per_call": ms, "inflow_sweeps": sweeps})
    print("* force sweeps over the cycle needed by a stroke's slowest annulus, mean over the batch")
    print("\nwhere the time goes at batch 1024 (coupled), ms per call (best wall, best CPU):")
    *kinematic, motion = model.parametric_kernel_inputs(strokes, PAPER.n_time)
    inputs = (*kinematic, speeds, np.zeros_like(speeds), te.DRAGONFLY)
    kinematics = partial(model.parametric_kernel_inputs, strokes, PAPER.n_time)
    no_inflow = partial(model.run_kernel, *inputs, replace(PAPER, induction="none"), motion=motion)
    parts = {
        "validate strokes": lambda: te.validate_physical(strokes),
        "kinematics (angles, analytic rates)": kinematics,
        "cycle without inflow (frames, forces, power, means)": no_inflow,
        "cycle with coupled inflow": partial(model.run_kernel, *inputs, PAPER, motion=motion),
        "whole evaluate()": lambda: te.evaluate(strokes, speeds, options=PAPER),
    }
    for name, call in parts.items():
        wall, cpu = map(min, call_times(call, args.repeats))
        print(f"  {name:<55} {1e3 * wall:8.2f} {1e3 * cpu:8.2f}")
        numbers["breakdown"].append({"part": name, "wall_ms": 1e3 * wall, "cpu_ms": 1e3 * cpu})
    return numbers


def torch_throughput(args: argparse.Namespace) -> dict[str, Any]:
    """Evaluations per second of the torch port per batch size (and numba's, on the CPU)."""
    import torch

    from tandem_env.physics import torch_model

    if args.threads is not None:
        torch.set_num_threads(args.threads)
    device = torch_model.resolve_device(args.device)
    dtype = getattr(torch, args.dtype)
    on_cpu = device.type == "cpu"
    batches = args.batches or ([1, 64, 1024] if on_cpu else [1, 1024, 16384, 65536, 262144])
    rng = np.random.default_rng(args.seed)
    strokes = te.normalised_to_physical(rng.uniform(-1, 1, (max(batches), 28)))
    speeds = rng.uniform(0.25, 2.0, max(batches))
    name = torch.cuda.get_device_name(device) if device.type == "cuda" else platform.processor()
    print(
        f"torch {torch.__version__} on {device} ({name or platform.machine()}), {args.dtype}, "
        f"{'compiled' if args.compile else 'eager'}, {torch.get_num_threads()} CPU threads; "
        + machine()
    )
    x_all, v_all = (torch.tensor(a, dtype=dtype, device=device) for a in (strokes, speeds))
    numbers: dict[str, Any] = {
        "torch": torch.__version__,
        "device": str(device),
        "device_name": name or platform.machine(),
        "dtype": args.dtype,
        "compiled": args.compile,
        "torch_threads": torch.get_num_threads(),
        "numba": numba.__version__,
        "numba_threads": numba.get_num_threads(),
        "repeats": args.repeats,
        "rates": [],
    }

    def run_torch(batch: int, opts: te.ModelOptions) -> None:
        with torch.no_grad():
            result = torch_model.evaluate_torch(
                x_all[:batch], v_all[:batch], options=opts, compiled=args.compile
            )
            float(result.power.sum())  # waits for the device

    header = f"{'batch':>7} {'induction':>10} {'torch evals/s':>14} {'ms/call':>9}"
    print(header + (f" {'numba evals/s':>14} {'torch/numba':>12}" if on_cpu else ""))
    for induction, batch in product(args.induction, batches):
        opts = replace(PAPER, induction=induction)
        seconds = best_time(partial(run_torch, batch, opts), args.repeats)
        line = f"{batch:>7} {induction:>10} {batch / seconds:>14.0f} {1e3 * seconds:>9.2f}"
        row = {"batch": batch, "induction": induction, "evaluations_per_s": batch / seconds}
        if on_cpu:
            evaluate = partial(te.evaluate, strokes[:batch], speeds[:batch], options=opts)
            numba_s = best_time(evaluate, args.repeats)
            line += f" {batch / numba_s:>14.0f} {numba_s / seconds:>12.3f}"
            row |= {
                "numba_evaluations_per_s": batch / numba_s,
                "torch_over_numba": numba_s / seconds,
            }
        print(line)
        numbers["rates"].append(row)
    numbers["accuracy"] = accuracy(args, torch_model, x_all, v_all, strokes, speeds)
    if args.gradient:
        numbers["gradient"] = gradient_cost(args, torch_model, x_all, strokes, speeds)
    return numbers


def accuracy(args, torch_model, x_all, v_all, strokes, speeds) -> dict[str, Any]:
    """The torch results against numba's on up to 256 strokes: the largest relative
    difference of any field and, per headline metric, relative to its largest magnitude."""
    import torch

    n = min(256, strokes.shape[0])
    want = te.evaluate(strokes[:n], speeds[:n])
    with torch.no_grad():
        got = torch_model.evaluate_torch(x_all[:n], v_all[:n], compiled=args.compile).to_numpy()
    relative = {}
    for name, value in want.as_dict().items():
        a, b = value.astype(float), getattr(got, name).astype(float)
        relative[name] = float(np.max(np.abs(b - a) / np.maximum(np.abs(a), 1e-6)))
    worst_name, worst = max(relative.items(), key=lambda item: item[1])
    print(
        f"\nagainst numba on {n} strokes (coupled): largest relative difference {worst:.2g} "
        f"({worst_name})"
    )
    scaled = {}
    for name in ("lift_to_weight", "thrust", "drag", "power", "efficiency", "fore_inflow"):
        a, b = getattr(want, name), getattr(got, name)
        scaled[name] = float(np.max(np.abs(b - a)) / np.max(np.abs(a)))
    print(
        "  largest difference / largest magnitude: "
        + ", ".join(f"{name} {value:.1g}" for name, value in scaled.items())
    )
    return {"strokes": n, "largest_relative": worst, "field": worst_name, "scaled": scaled}


def gradient_cost(args, torch_model, x_all, strokes, speeds) -> dict[str, Any]:
    """One autograd gradient against one batched central difference of the numba model."""
    columns = np.flatnonzero(~DISCRETE)
    step = 1e-6 * (UPPER - LOWER)[columns]
    probes = np.repeat(strokes[:1], 1 + 2 * columns.size, axis=0)
    probes[1::2, columns] += np.diag(step)
    probes[2::2, columns] -= np.diag(step)
    central_difference = partial(te.evaluate, probes, speeds[0], options=PAPER)
    central = best_time(central_difference, args.repeats)
    print(
        f"\ngradient of power with respect to the 28 parameters, per stroke: central difference "
        f"of numba ({probes.shape[0]} strokes in one call) {1e3 * central:.1f} ms"
    )
    numbers: dict[str, Any] = {"central_difference_ms": 1e3 * central, "probes": probes.shape[0]}
    for batch in (1, 64):
        gradient = partial(torch_model.value_and_grad, x_all[:batch], "power", speeds[0])
        seconds = best_time(partial(gradient, compiled=args.compile), args.repeats)
        print(
            f"  autograd at batch {batch:>3}: {1e3 * seconds / batch:8.1f} ms per stroke "
            f"({central * batch / seconds:.2f}x the central difference's rate)"
        )
        numbers[f"autograd_ms_per_stroke_batch_{batch}"] = 1e3 * seconds / batch
    return numbers


if __name__ == "__main__":
    main()
