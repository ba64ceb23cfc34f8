"""Benchmarks of the model, the inflow solve, the torch port and the envs: documented commands
run with ``--json`` (timings: shown, never compared)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from eval.numbers.framework import Benchmark, Measurement, footer, median_range, spaced
from eval.studies.report import table_head, table_row

MODEL_THROUGHPUT = Benchmark(("benchmarks/model_throughput.py",))
INFLOW_SOLVE = Benchmark(("benchmarks/inflow_solve.py",))
ENV_THROUGHPUT = Benchmark(("benchmarks/env_throughput.py",))
_TORCH = "benchmarks/model_throughput.py --backend torch --threads 1 --repeats 3".split()
_ONE_THREAD = (("OMP_NUM_THREADS", "1"),)
TORCH_EAGER = Benchmark(
    (*_TORCH, "--batches", "1", "64", "1024", "--induction", "coupled", "none", "--gradient"),
    _ONE_THREAD,
)
TORCH_COMPILED = Benchmark(
    (*_TORCH, "--compile", "--batches", "64", "1024", "--induction", "coupled"), _ONE_THREAD
)
INDUCTIONS: tuple[str, ...] = ("coupled", "isolated", "none")


def by_case(rows: Iterable[dict[str, Any]]) -> dict[tuple[int, str], dict[str, Any]]:
    return {(r["batch"], r["induction"]): r for r in rows}


def render_model_throughput(data: dict[str, Any]) -> str:
    rates = by_case(data["rates"])
    batches = sorted({batch for batch, _ in rates})
    inductions = [i for i in INDUCTIONS if any((b, i) in rates for b in batches)]
    lines = table_head(
        ["batch", *(f"`{i}`: evaluations/s (ms per call, sweeps)" for i in inductions)]
    )
    for batch in batches:
        cells = [
            f"{spaced(r['evaluations_per_s'])} ({r['ms_per_call']:.2f} ms, {r['inflow_sweeps']:.1f})"
            for r in (rates[batch, induction] for induction in inductions)
        ]
        lines.append(table_row([batch, *cells]))
    lines += [
        "",
        "Best of "
        f"{data['repeats']} calls after a warm-up, wall clock, numba {data['numba']} with "
        f"{data['numba_threads']} threads, n_time = {data['n_time']}, n_blade = {data['n_blade']}; "
        "sweeps: force sweeps over the cycle needed by a stroke's slowest annulus, mean over the "
        "batch.",
        "",
        "| one coupled `evaluate` at batch 1024 | wall [ms] | CPU, all threads [ms] |",
        "|---|---|---|",
        *(f"| {b['part']} | {b['wall_ms']:.1f} | {b['cpu_ms']:.1f} |" for b in data["breakdown"]),
        *footer(data, "model-throughput", data["command"]),
    ]
    return "\n".join(lines) + "\n"


def render_inflow_cost(data: dict[str, Any]) -> str:
    rates = by_case(data["rates"])
    ratios = {r["batch"]: r for r in data["ratios"]}
    lines = table_head(
        [
            "batch",
            *(f"`{i}`: evaluations/s, best / median round" for i in INDUCTIONS),
            "coupled / none, wall: median (range)",
            "coupled / none, CPU: median (range)",
        ]
    )
    for batch in sorted(ratios):
        cells = [
            f"{spaced(rates[batch, i]['best_per_s'])} / {spaced(rates[batch, i]['median_per_s'])}"
            for i in INDUCTIONS
        ]
        lines.append(
            table_row([batch, *cells, *(median_range(ratios[batch], k) for k in ("wall", "cpu"))])
        )
    sweeps = "; ".join(
        f"V = {s['speed']:g} m/s: {100 * s['solved_share']:.0f} % of the annuli need a solve, "
        f"{s['mean_sweeps']:.2f} sweeps on average (at most {s['max_sweeps']})"
        for s in data["sweeps"]
    )
    for reading, where in (("convected", "§5.7"), ("vortex", "§5.8")):
        slipstream = "; ".join(
            f"batch {r['batch']}: {median_range(r, 'cpu').replace(' (', '× CPU (', 1)}, "
            f"{median_range(r, 'wall').replace(' (', '× wall (', 1)}"
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
        *footer(data, "inflow-cost", data["command"]),
    ]
    return "\n".join(lines) + "\n"


def render_env_throughput(data: dict[str, Any]) -> str:
    rows, n = data["rows"], data["num_envs"]
    lines = [f"| | strokes/s | vs `{data['reference']}` |", "|---|---|---|"]
    lines += [
        f"| {r['case']} | {spaced(r['strokes_per_s'])} | {100 * r['of_reference']:.1f} % |"
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
        *footer(data, "env-throughput", data["command"]),
    ]
    return "\n".join(lines) + "\n"


def measure_torch_throughput() -> dict[str, Any]:
    return {"eager": TORCH_EAGER.run(), "compiled": TORCH_COMPILED.run()}


def render_torch_throughput(data: dict[str, Any]) -> str:
    eager, compiled = by_case(data["eager"]["rates"]), by_case(data["compiled"]["rates"])
    g, run = data["eager"]["gradient"], data["eager"]
    columns = (
        ("coupled, eager", eager, "coupled"),
        ("coupled, compiled", compiled, "coupled"),
        ("none, eager", eager, "none"),
    )
    batches = sorted({batch for batch, _ in eager} | {batch for batch, _ in compiled})

    def cell(rates: dict[tuple[int, str], dict[str, Any]], key: tuple[int, str]) -> str:
        if key not in rates:
            return ""
        r = rates[key]
        return f"{spaced(r['evaluations_per_s'])} /s ({r['torch_over_numba']:.2g} × numba)"

    lines = table_head(["batch", *(title for title, _, _ in columns)])
    lines += [
        table_row([batch, *(cell(rates, (batch, i)) for _, rates, i in columns)])
        for batch in batches
    ]
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
        *footer(data, "torch-throughput", data["eager"]["command"], data["compiled"]["command"]),
    ]
    return "\n".join(lines) + "\n"


MEASUREMENTS = (
    Measurement("model-throughput", MODEL_THROUGHPUT.run, render_model_throughput),
    Measurement("inflow-cost", INFLOW_SOLVE.run, render_inflow_cost),
    Measurement("torch-throughput", measure_torch_throughput, render_torch_throughput),
    Measurement("env-throughput", ENV_THROUGHPUT.run, render_env_throughput),
)
