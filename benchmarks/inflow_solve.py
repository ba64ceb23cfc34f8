"""Cost of the coupled inflow solve: evaluations per second and force sweeps per annulus.

    python benchmarks/inflow_solve.py [--rounds 7] [--seed 0]

Evaluations per second of each inflow model at batch 1, 64 and 1024 with the target ratio
coupled / none at batch 1024, and of the convected slipstream
(``ModelOptions(slipstream="convected")``, docs/model.md §5.7) and the vortex reading
(``"vortex"``, §5.8) with the ratios convected / mean (target: at most 2 at batch 1024) and
vortex / mean (at most 3). The cases are timed in one process in interleaved rounds (every case
once per round), so a load that comes and goes hits all alike; each case reports its best and
median round, the ratios are medians of the per-round ratios of wall time and of CPU time (all
threads; steadier when other processes compete for the cores). Then force sweeps per annulus
from the solver itself (``induction.solve_annulus``) on the fore-wing annuli of random Table 4
strokes: the mean over the annuli that need a solve (F̄_n(0) > 0) is the solver's own cost.
``--json PATH`` also writes the numbers (``python -m eval numbers`` renders docs/model.md §12
from them).
"""

from __future__ import annotations

from dataclasses import replace
from functools import partial
from typing import Any

import numpy as np
from shared import PAPER, machine, parser_with_json, seconds_per_call, write_numbers

import tandem_env as te
from tandem_env.physics import blade, cycle, induction, model
from tandem_env.physics.kinematics import fill_angle_history, wing_params_radians

INDUCTION = ("coupled", "isolated", "none")
#: The phase-resolved readings, each timed against the mean one.
READINGS = ("convected", "vortex")
#: The cases timed: each inflow model, and the coupled inflow with each slipstream reading
#: (``ModelOptions.slipstream``, docs/model.md §5.7), against the coupled one (the mean reading).
CASES = {
    **{induction: replace(PAPER, induction=induction) for induction in INDUCTION},
    **{reading: te.ModelOptions(slipstream=reading) for reading in READINGS},
}
BATCHES = (1, 64, 1024)
SWEEP_STROKES = 200
"""Random strokes whose fore-wing annuli are solved one by one to count the sweeps."""
SWEEP_SPEEDS = (0.0, 1.0, 2.0)
"""Flight speeds [m/s] of that count."""


def throughput(strokes: np.ndarray, speeds: np.ndarray, rounds: int) -> dict[str, Any]:
    """Seconds per call of every case in ``rounds`` interleaved rounds (printed, and returned
    as per-case best and median rates and the per-round coupled / none ratios)."""
    cases = [(name, batch) for batch in BATCHES for name in CASES]
    calls = {
        case: partial(te.evaluate, strokes[: case[1]], speeds[: case[1]], options=CASES[case[0]])
        for case in cases
    }
    for call in calls.values():
        call()  # compile or load the cache
    # every case once per round: (wall, CPU) seconds per call, by round and case
    timed = [[seconds_per_call(calls[c], min_seconds=0.3) for c in cases] for _ in range(rounds)]
    wall, cpu = ({c: [r[i][k] for r in timed] for i, c in enumerate(cases)} for k in (0, 1))
    print(
        f"{'batch':>6} {'induction':>10} {'evals/s best':>13} {'evals/s median':>15} "
        f"{'CPU ms/call best':>17}"
    )
    numbers: dict[str, Any] = {"rounds": rounds, "rates": [], "ratios": [], "slipstream_ratios": []}
    for (name, batch), t in wall.items():
        best, median, best_cpu = batch / min(t), batch / np.median(t), min(cpu[name, batch])
        print(f"{batch:>6} {name:>10} {best:>13.0f} {median:>15.0f} {1e3 * best_cpu:>17.2f}")
        row = {"batch": batch, "induction": name, "best_per_s": best, "median_per_s": median}
        numbers["rates"].append(row | {"best_cpu_per_s": batch / best_cpu})
    print("\ncoupled / none (time per call; per-round ratios: median and range):")
    for batch in BATCHES:
        row = ratios(wall, cpu, ("coupled", batch), ("none", batch))
        best = min(wall["coupled", batch]) / min(wall["none", batch])
        print(f"  batch {batch:>4}: {row.pop('line')} (best/best {best:.3f})")
        numbers["ratios"].append({"batch": batch, **row})
    print("\nreading / mean slipstream, all coupled (per-round ratios: median and range):")
    for reading, batch in ((r, b) for r in READINGS for b in BATCHES):
        row = ratios(wall, cpu, (reading, batch), ("coupled", batch))
        print(f"  {reading:>9} batch {batch:>4}: {row.pop('line')}")
        numbers["slipstream_ratios"].append({"reading": reading, "batch": batch, **row})
    return numbers


def ratios(wall: dict, cpu: dict, case: tuple, base: tuple) -> dict[str, Any]:
    """The per-round ratios case / base of wall and CPU time: median and range of each, and
    their printed ``line``."""
    row: dict[str, Any] = {}
    parts = []
    for kind, times, label in (("wall", wall, "wall"), ("cpu", cpu, "CPU")):
        ratio = np.array(times[case]) / np.array(times[base])
        row[f"{kind}_median"] = float(np.median(ratio))
        row[f"{kind}_range"] = [float(ratio.min()), float(ratio.max())]
        parts.append(f"{label} {np.median(ratio):.3f} ({ratio.min():.3f}-{ratio.max():.3f})")
    return row | {"line": "; ".join(parts)}


def sweeps_per_annulus(strokes: np.ndarray, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """Force sweeps of every fore-wing annulus of ``strokes`` (own inflow), and F̄_n(0) > 0."""
    options, insect = PAPER, te.DRAGONFLY
    rho = insect.air_density
    nodes, consts = model.wing_tables(insect.fore, options.n_blade, rho)
    settings = model.kernel_settings(insect, options, options.n_time)
    counts, solved = [], []
    for stroke in strokes:
        params = wing_params_radians(stroke[:14])
        angles = np.empty((options.n_time, 9))
        weight = np.empty(options.n_time)
        fill_angle_history(params, options.n_time, angles, weight)
        coef = np.empty((options.n_time, blade.N_COEF))
        blade.fill_frame_coefficients(angles, weight, params[13], False, 1, coef)
        v_t, v_n = speed * np.cos(params[13]), speed * np.sin(params[13])
        for j in range(options.n_blade):
            section = cycle.section_at(nodes, j, consts, rho)
            _, evals, _ = induction.solve_annulus(coef, section, v_t, v_n, params[1], settings)
            counts.append(evals)
            solved.append(induction.mean_normal_force(coef, section, v_t, v_n) > 0.0)
    return np.array(counts), np.array(solved)


def main() -> None:
    parser = parser_with_json(__doc__)
    parser.add_argument("--rounds", type=int, default=7, help="interleaved timing rounds")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    strokes = te.normalised_to_physical(rng.uniform(-1, 1, (1024, 28)))
    speeds = rng.uniform(0.25, 2.0, 1024)
    print(
        f"{machine()}; n_time = {PAPER.n_time}, n_blade = {PAPER.n_blade}, "
        f"tolerance {PAPER.tolerance:g}"
    )
    print(f"\nforce sweeps per fore-wing annulus (own inflow, {SWEEP_STROKES} random strokes):")
    sweeps = []
    for speed in SWEEP_SPEEDS:
        counts, solved = sweeps_per_annulus(strokes[:SWEEP_STROKES], speed)
        hist = {int(k): int(n) for k, n in enumerate(np.bincount(counts[solved])) if n}
        share, mean, most = float(solved.mean()), float(counts[solved].mean()), int(counts.max())
        print(
            f"  V = {speed:.0f} m/s: {share:.0%} of annuli solved, mean {mean:.2f} sweeps (max "
            f"{most}), histogram {hist}"
        )
        row = {"speed": speed, "solved_share": share, "mean_sweeps": mean, "max_sweeps": most}
        sweeps.append(row)
    print()
    numbers = throughput(strokes, speeds, args.rounds)
    write_numbers(args.json, {"seed": args.seed, "sweeps": sweeps, **numbers})


if __name__ == "__main__":
    main()
