"""The kernel against the CPU's limit and against commit 8e3cf19's kernel (docs/model.md §12):
``benchmarks/roofline.py`` run with ``--json`` (timings: shown, never compared)."""

from __future__ import annotations

from typing import Any

from eval.numbers.framework import Benchmark, Measurement, footer, median_range, spaced
from eval.studies.report import table_head, table_row

ROOFLINE = Benchmark(("benchmarks/roofline.py",))


def render_roofline(data: dict[str, Any]) -> str:
    lines = table_head(
        [
            "numba threads",
            f"{data['commit']}: ms per call, wall / CPU",
            "now: ms per call, wall / CPU",
            "speed-up, wall: median (range)",
            "speed-up, CPU: median (range)",
        ]
    )
    for r in data["speed"]:
        lines.append(
            table_row(
                [
                    r["threads"],
                    f"{r['wall_old_ms']:.0f} / {r['cpu_old_ms']:.0f}",
                    f"{r['wall_new_ms']:.0f} / {r['cpu_new_ms']:.0f}",
                    *(median_range(r, k, "_ratio") for k in ("wall", "cpu")),
                ]
            )
        )
    s, e, ghz = data["per_stroke"], data["per_element_sample"], data["ghz"]
    cycles = data["ns_per_element_sample"] * ghz
    fma, rsqrt = data["fma_flops_per_ns"] / ghz, data["rsqrt_per_ns"] / ghz
    divider = (e["sqrt"] + e["div"]) / (2.0 * rsqrt)
    lines += [
        "",
        "| per stroke | per element sample | measured | the machine's limit |",
        "|---|---|---|---|",
        f"| {spaced(s['element_samples'])} element samples, {s['sweeps']:.1f} force sweeps and "
        f"{s['slopes']:.1f} slopes of annuli | {e['flop']:.0f} flops, {e['sqrt']:.2f} square "
        f"roots, {e['div']:.2f} divisions | {cycles:.1f} cycles ({data['ns_per_element_sample']:.1f} "
        f"ns) of CPU time per element sample, the whole call; {e['flop'] / cycles:.2f} flops per "
        f"cycle | {fma:.1f} FMA flops per cycle, {rsqrt:.3f} of 1/sqrt(x) per cycle: at least "
        f"{e['flop'] / fma:.1f} cycles (flops) and {divider:.1f} cycles (square roots and "
        "divisions) per element sample |",
        "",
        "| where the time goes, 1 thread | " + " | ".join(data["stages_ms"]) + " |",
        "|---" * (len(data["stages_ms"]) + 1) + "|",
        "| CPU ms per call (share) | "
        + " | ".join(
            f"{v:.1f} ({100 * v / data['stages_ms']['whole call']:.0f} %)"
            for v in data["stages_ms"].values()
        )
        + " |",
        "",
        f'`evaluate` at B = {data["batch"]}, V = 1 m/s, `ModelOptions(slipstream="mean")`: '
        f"{data['rounds']} interleaved rounds of {data['calls']} calls per thread count, commit "
        f"{data['commit']}'s kernel in a second process; speed-up = its median time per call over "
        "today's. Operations counted by running the kernel's pointwise formulae once on counting "
        "numbers (a sweep's, a slope's and the span integration's, weighted by the counts the "
        "kernel reports); flops per cycle and 1/sqrt per cycle measured by vectorised numba loops "
        f"in the same run; cycles at the {ghz:.2f} GHz that /proc/cpuinfo reports.",
        *footer(data, "roofline", data["command"]),
    ]
    return "\n".join(lines) + "\n"


MEASUREMENT = Measurement("roofline", ROOFLINE.run, render_roofline)
