"""Benchmarks of the model, the inflow solve, the torch port and the envs, and the kernel
against the CPU's limit and against commit 8e3cf19's kernel (docs/model.md §12): documented
commands run with ``--json`` (timings: shown, never compared).

Also what two documented commands cost, each run into an empty folder and timed as a whole
process: the quick preset (README "Reproduce the paper", docs/reproduction.md "Presets and what
they cost": the one figure the documents give for its time; every other mention points here)
and the README's first training command ("Train PPO and SAC stroke policies")."""

from __future__ import annotations

import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from agents.store import RecordStore
from eval.numbers import framework

MODEL_THROUGHPUT = framework.Benchmark(("benchmarks/model_throughput.py",))
INFLOW_SOLVE = framework.Benchmark(("benchmarks/inflow_solve.py",))
ENV_THROUGHPUT = framework.Benchmark(("benchmarks/env_throughput.py",))
ROOFLINE = framework.Benchmark(("benchmarks/roofline.py",))
_TORCH = "benchmarks/model_throughput.py --backend torch --threads 1 --repeats 3".split()
_ONE_THREAD = (("OMP_NUM_THREADS", "1"),)
TORCH_EAGER = framework.Benchmark(
    (*_TORCH, "--batches", "1", "64", "1024", "--induction", "coupled", "none", "--gradient"),
    _ONE_THREAD,
)
TORCH_COMPILED = framework.Benchmark(
    (*_TORCH, "--compile", "--batches", "64", "1024", "--induction", "coupled"), _ONE_THREAD
)
INDUCTIONS: tuple[str, ...] = ("coupled", "isolated", "none")
QUICK_PRESET_COMMAND: tuple[str, ...] = ("python", "-m", "eval", "study", "all")
"""The documented command (quick preset, CMA-ES, serially); ``--out`` and ``--quiet`` are
added, and ``--no-cache`` so that no stored job from an earlier run shortens it."""
TRAINING_COMMAND: tuple[str, ...] = tuple(
    "python -m train --algo ppo --env TandemWing/LevelFlight-v0 --timesteps 200000 --seed 0 "
    "--env-kwargs speed=1.5".split()
)
"""The README's command; ``-f`` (an empty log folder) is added."""


def by_case(rows: Iterable[dict[str, Any]]) -> dict[tuple[int, str], dict[str, Any]]:
    return {(r["batch"], r["induction"]): r for r in rows}


def render_model_throughput(data: dict[str, Any]) -> str:
    rates = by_case(data["rates"])
    batches = sorted({batch for batch, _ in rates})
    inductions = [i for i in INDUCTIONS if any((b, i) in rates for b in batches)]

    def cell(r: dict[str, Any]) -> str:
        return f"{framework.spaced(r['evaluations_per_s'])} ({r['ms_per_call']:.2f} ms, {r['inflow_sweeps']:.1f})"

    heads = [f"`{i}`: evaluations/s (ms per call, sweeps)" for i in inductions]
    rows = ([batch, *(cell(rates[batch, i]) for i in inductions)] for batch in batches)
    lines = framework.table(["batch", *heads], rows)
    lines += [
        "",
        "Best of "
        f"{data['repeats']} calls after a warm-up, wall clock, numba {data['numba']} with "
        f"{data['numba_threads']} threads, n_time = {data['n_time']}, n_blade = {data['n_blade']}; "
        "sweeps: force sweeps over the cycle needed by a stroke's slowest annulus, mean over the "
        "batch.",
        "",
        *framework.table(
            ["one coupled `evaluate` at batch 1024", "wall [ms]", "CPU, all threads [ms]"],
            ([b["part"], f"{b['wall_ms']:.1f}", f"{b['cpu_ms']:.1f}"] for b in data["breakdown"]),
        ),
        *framework.footer(data, "model-throughput", data["command"]),
    ]
    return "\n".join(lines) + "\n"


def render_inflow_cost(data: dict[str, Any]) -> str:
    rates = by_case(data["rates"])
    ratios = {r["batch"]: r for r in data["ratios"]}

    def cells(batch: int) -> list[Any]:
        per_s = (rates[batch, i] for i in INDUCTIONS)
        spaced = framework.spaced
        return [
            batch,
            *(f"{spaced(r['best_per_s'])} / {spaced(r['median_per_s'])}" for r in per_s),
            *(framework.median_range(ratios[batch], k) for k in ("wall", "cpu")),
        ]

    heads = [f"`{i}`: evaluations/s, best / median round" for i in INDUCTIONS]
    heads += [f"coupled / none, {k}: median (range)" for k in ("wall", "CPU")]
    lines = framework.table(["batch", *heads], map(cells, sorted(ratios)))
    sweeps = "; ".join(
        f"V = {s['speed']:g} m/s: {100 * s['solved_share']:.0f} % of the annuli need a solve, "
        f"{s['mean_sweeps']:.2f} sweeps on average (at most {s['max_sweeps']})"
        for s in data["sweeps"]
    )
    for reading, where in (("convected", "§5.7"), ("vortex", "§5.8")):
        slipstream = "; ".join(
            f"batch {r['batch']}: {framework.median_range(r, 'cpu', unit='× CPU')}, "
            f"{framework.median_range(r, 'wall', unit='× wall')}"
            for r in data.get("slipstream_ratios", [])
            if r.get("reading", "convected") == reading
        )
        if slipstream:
            lines += [
                "",
                f'The {reading} reading (`ModelOptions(slipstream="{reading}")`, {where}) against '
                f"the mean one, all coupled, median (range) of the per-round ratios: {slipstream}.",
            ]
    lines += [
        "",
        f"{data['rounds']} interleaved rounds (every case once per round, back-to-back calls for "
        "0.3 s each), so a load that comes and goes hits all cases alike; the ratios are the "
        "medians of the per-round ratios of time per call.",
        "Force sweeps per fore-wing annulus (own inflow, 200 random strokes, the solver called "
        f"directly): {sweeps}.",
        *framework.footer(data, "inflow-cost", data["command"]),
    ]
    return "\n".join(lines) + "\n"


def render_env_throughput(data: dict[str, Any]) -> str:
    rows, n = data["rows"], data["num_envs"]
    lines = [f"| | strokes/s | vs `{data['reference']}` |", "|---|---|---|"]
    lines += [
        f"| {r['case']} | {framework.spaced(r['strokes_per_s'])} | {100 * r['of_reference']:.1f} % |"
        for r in rows
    ]
    # The benchmark's order: evaluate at B = 1, at B = n, the single env (one stroke per call,
    # against B = 1), then the vector envs and the adapter (n strokes per call, against B = n).
    single, batched = rows[0]["strokes_per_s"], rows[1]["strokes_per_s"]
    overheads = [f"{rows[2]['case']}: {1e3 * (1 / rows[2]['strokes_per_s'] - 1 / single):+.2f} ms"]
    overheads += [
        f"{r['case']}: {1e3 * n * (1 / r['strokes_per_s'] - 1 / batched):+.1f} ms" for r in rows[3:]
    ]
    lines += [
        "",
        "Time per call beyond the model's own (1/rate − 1/rate of `evaluate` at the same batch, "
        f"per step of n = {n} strokes or per single-env episode): " + "; ".join(overheads) + ".",
        f"{data['seconds']:g} s per measurement after a warm-up call; the vector envs count the "
        "strokes evaluated, not the reset steps.",
        *framework.footer(data, "env-throughput", data["command"]),
    ]
    return "\n".join(lines) + "\n"


def measure_torch_throughput() -> dict[str, Any]:
    return {"eager": TORCH_EAGER.run(), "compiled": TORCH_COMPILED.run()}


def render_torch_throughput(data: dict[str, Any]) -> str:
    eager, compiled = by_case(data["eager"]["rates"]), by_case(data["compiled"]["rates"])
    g = data["eager"]["gradient"]
    run = data["eager"]
    columns = (
        ("coupled, eager", eager, "coupled"),
        ("coupled, compiled", compiled, "coupled"),
        ("none, eager", eager, "none"),
    )
    batches = sorted({batch for batch, _ in eager} | {batch for batch, _ in compiled})

    def cell(r: dict[str, Any] | None) -> str:
        if r is None:
            return ""
        return (
            f"{framework.spaced(r['evaluations_per_s'])} /s ({r['torch_over_numba']:.2g} × numba)"
        )

    lines = framework.table(
        ["batch", *(title for title, _, _ in columns)],
        ([batch, *(cell(rates.get((batch, i))) for _, rates, i in columns)] for batch in batches),
    )
    lines += [
        "",
        f"torch {run['torch']} on the CPU, {run['dtype']}, {run['torch_threads']} torch thread(s), "
        f"best of {run['repeats']} calls after a warm-up; numba ({run['numba_threads']} threads) "
        "timed on the same strokes in the same process, so the ratio torch / numba (> 1: torch "
        "faster) is the figure to read on a loaded machine. Against numba on "
        f"{run['accuracy']['strokes']} strokes the largest relative difference of any field is "
        f"{run['accuracy']['largest_relative']:.1g} eager and "
        f"{data['compiled']['accuracy']['largest_relative']:.1g} compiled.",
        "One gradient of the power with respect to the 28 parameters: a central difference of "
        f"the numba model ({g['probes']} strokes in one call) {g['central_difference_ms']:.1f} ms; "
        f"autograd {g['autograd_ms_per_stroke_batch_1']:.1f} ms for one stroke and "
        f"{g['autograd_ms_per_stroke_batch_64']:.1f} ms per stroke at batch 64 "
        f"({g['central_difference_ms'] / g['autograd_ms_per_stroke_batch_64']:.1f} × the central "
        "difference's rate).",
        *framework.footer(
            data, "torch-throughput", data["eager"]["command"], data["compiled"]["command"]
        ),
    ]
    return "\n".join(lines) + "\n"


def render_roofline(data: dict[str, Any]) -> str:
    heads = [f"{commit}: ms per call, wall / CPU" for commit in (data["commit"], "now")]
    heads += [f"speed-up, {k}: median (range)" for k in ("wall", "CPU")]
    lines = framework.table(
        ["numba threads", *heads],
        (
            [
                r["threads"],
                *(f"{r[f'wall_{t}_ms']:.0f} / {r[f'cpu_{t}_ms']:.0f}" for t in ("old", "new")),
                *(framework.median_range(r, k, "_ratio") for k in ("wall", "cpu")),
            ]
            for r in data["speed"]
        ),
    )
    s, e, ghz = data["per_stroke"], data["per_element_sample"], data["ghz"]
    cycles = data["ns_per_element_sample"] * ghz
    fma, rsqrt = data["fma_flops_per_ns"] / ghz, data["rsqrt_per_ns"] / ghz
    divider = (e["sqrt"] + e["div"]) / (2.0 * rsqrt)
    stages = data["stages_ms"]
    shares = (f"{v:.1f} ({100 * v / stages['whole call']:.0f} %)" for v in stages.values())
    lines += [
        "",
        "| per stroke | per element sample | measured | the machine's limit |",
        "|---|---|---|---|",
        f"| {framework.spaced(s['element_samples'])} element samples, {s['sweeps']:.1f} force sweeps and "
        f"{s['slopes']:.1f} slopes of annuli | {e['flop']:.0f} flops, {e['sqrt']:.2f} square "
        f"roots, {e['div']:.2f} divisions | {cycles:.1f} cycles ({data['ns_per_element_sample']:.1f} "
        f"ns) of CPU time per element sample, the whole call; {e['flop'] / cycles:.2f} flops per "
        f"cycle | {fma:.1f} FMA flops per cycle, {rsqrt:.3f} of 1/sqrt(x) per cycle: at least "
        f"{e['flop'] / fma:.1f} cycles (flops) and {divider:.1f} cycles (square roots and "
        "divisions) per element sample |",
        "",
        *framework.table(
            ["where the time goes, 1 thread", *stages], [["CPU ms per call (share)", *shares]]
        ),
        "",
        f'`evaluate` at B = {data["batch"]}, V = 1 m/s, `ModelOptions(slipstream="mean")`: '
        f"{data['rounds']} interleaved rounds of {data['calls']} calls per thread count, commit "
        f"{data['commit']}'s kernel in a second process; speed-up = its median time per call over "
        "today's. Operations counted by running the kernel's pointwise formulae once on counting "
        "numbers (a sweep's, a slope's and the span integration's, weighted by the counts the "
        "kernel reports); flops per cycle and 1/sqrt per cycle measured by vectorised numba loops "
        f"in the same run; cycles at the {ghz:.2f} GHz that /proc/cpuinfo reports.",
        *framework.footer(data, "roofline", data["command"]),
    ]
    return "\n".join(lines) + "\n"


def measure_quick_preset() -> dict[str, Any]:
    """Run the quick preset into an empty folder: wall time [s], jobs, model evaluations."""
    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as out:
        wall = framework.run_command([*QUICK_PRESET_COMMAND, "--out", out, "--quiet", "--no-cache"])
        records = RecordStore(Path(out)).records()
    return {
        "command": " ".join(QUICK_PRESET_COMMAND),
        "wall_s": round(wall, 1),
        "jobs": len(records),
        "evaluations": int(sum(r.evaluations for r in records)),
    }


def measure_training() -> dict[str, Any]:
    """Run the README's PPO command into an empty log folder: wall time [s]."""
    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as logs:
        wall = framework.run_command([*TRAINING_COMMAND, "-f", logs])
    return {"command": " ".join(TRAINING_COMMAND), "wall_s": round(wall, 1)}


def _took(data: dict[str, Any], name: str, what: str, where: str) -> str:
    """The sentence of a timed command: ``what`` it is, then its time and ``where`` it ran
    (the load average before and after)."""
    before, after = data["machine_before"], data["machine_after"]
    low, high = sorted((before["load_average_1min"], after["load_average_1min"]))
    return (
        f"`{data['command']}` {what}took **{framework.minutes(data['wall_s'])}** wall clock at a "
        f"load average of {low:g}-{high:g} on {before['cpus']} CPUs {where}. "
        f"{framework.machine_line(data, name)}\n"
    )


def render_quick_preset(data: dict[str, Any]) -> str:
    what = (
        f"(the quick preset: CMA-ES, serially, {data['jobs']} optimisations, "
        f"{framework.spaced(data['evaluations'])} model evaluations, into an empty folder with the record "
        "cache off) "
    )
    return _took(data, "quick-preset", what, "(longer on a busier machine)")


def render_training(data: dict[str, Any]) -> str:
    what = "training, its periodic evaluations and checkpoints; longer on a busier machine"
    return _took(data, "training-time", "", f"into an empty log folder ({what})")


MEASUREMENTS = (
    framework.Measurement("model-throughput", MODEL_THROUGHPUT.run, render_model_throughput),
    framework.Measurement("inflow-cost", INFLOW_SOLVE.run, render_inflow_cost),
    framework.Measurement("torch-throughput", measure_torch_throughput, render_torch_throughput),
    framework.Measurement("env-throughput", ENV_THROUGHPUT.run, render_env_throughput),
    framework.Measurement("roofline", ROOFLINE.run, render_roofline),
    framework.Measurement("quick-preset", measure_quick_preset, render_quick_preset),
    framework.Measurement("training-time", measure_training, render_training),
)
