"""``python -m eval numbers``: measure the numbers README and docs quote, and write them in.

A number a document states is produced here, by the command the document names, and written
into the document between two markers::

    <!-- numbers: comparison -->
    ...generated Markdown, never edited by hand...
    <!-- /numbers -->

Each measurement keeps its raw results in ``docs/numbers/<name>.json`` (per-seed values, the
commands, date, machine and load), and the Markdown is rendered from that file alone, so

* ``python -m eval numbers`` reruns every measurement, rewrites its JSON and the documents;
* ``python -m eval numbers --render`` rewrites the documents from the stored JSON only;
* ``tests/test_docs_numbers.py`` checks that every marked region equals its rendering (a hand
  edit or a stale region fails) and reruns seed 0 of every deterministic row at its stated
  settings against the stored value.

* ``python -m eval numbers --only NAME ...`` reruns only those (:data:`MEASUREMENTS` lists
  them: the comparison of methods, the benchmarks of the model, the torch port and the envs,
  SpeedChange's random and steady baselines, readings of the model on random strokes and
  the resolution study of the defaults).

Adding a number is one :class:`Measurement` (a name, ``measure() -> dict`` and a pure
``render(dict) -> str``) and one region in a document. A benchmark is measured by running its
documented command with ``--json`` (:class:`Benchmark`). Timings are not deterministic: they are
shown with the machine (CPU model, cores), date and load average before and after they were
taken, the documents read their ratios within one run, and the test does not compare them.
"""

from __future__ import annotations

import argparse
import csv
import datetime as dt
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from eval.compare import relative_spread

NAME = "numbers"
HELP = "rerun the measurements README and docs quote, and write them into the documents"
ROOT = Path(__file__).resolve().parents[1]
NUMBERS_DIR = ROOT / "docs" / "numbers"
DOCUMENTS: tuple[Path, ...] = (ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")))
REGION = re.compile(
    r"(<!-- numbers: (?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /numbers -->)", re.DOTALL
)


# --- the comparison of methods (README "Optimise strokes", docs/harness.md) ---------------------
@dataclass(frozen=True)
class ComparisonRow:
    """One condition of the documented comparison: the same ``eval optimize`` for each method."""

    label: str
    symbol: str
    arguments: tuple[str, ...]
    """``eval optimize`` arguments besides ``--method``, ``--seeds`` and ``--out``."""


COMPARISON_ROWS: tuple[ComparisonRow, ...] = (
    ComparisonRow(
        "accelerating 60 W/kg, 12 000 evaluations",
        "F̄_v",
        ("--task", "accelerate", "--power", "60", "--objective", "vertical", "--budget", "12000"),
    ),
    ComparisonRow(
        "level 1.5 m/s, 16 000 evaluations",
        "η",
        ("--task", "level", "--speed", "1.5", "--budget", "16000"),
    ),
)
COMPARISON_METHODS: tuple[str, ...] = ("cmaes", "pso")
COMPARISON_SEEDS: tuple[int, ...] = (0, 1, 2, 3)


def optimize_command(row: ComparisonRow, method: str, seeds: Sequence[int]) -> list[str]:
    """The documented command (without ``--out``) for one row and method."""
    return [
        "python",
        "-m",
        "eval",
        "optimize",
        *row.arguments,
        "--method",
        method,
        "--seeds",
        *map(str, seeds),
    ]


def run_command(command: Sequence[str], environment: dict[str, str] | None = None) -> None:
    """Run a documented ``python ...`` command from the repository root with this interpreter
    (``environment``: variables set for it); a failure raises with the end of its stderr."""
    command = [sys.executable, *command[1:]] if command[0] == "python" else list(command)
    done = subprocess.run(
        command,
        cwd=ROOT,
        env={**os.environ, **(environment or {})},
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} exited {done.returncode}:\n{done.stderr[-2000:]}")


def run_optimize(row: ComparisonRow, method: str, seeds: Sequence[int]) -> list[dict[str, Any]]:
    """Run the documented command in a fresh folder; one ``{seed, objective, ...}`` per seed."""
    from agents.records import load_records

    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as out:
        run_command([*optimize_command(row, method, seeds), "--out", out])
        records = sorted(load_records([out]), key=lambda r: r.seed)
    if [r.seed for r in records] != list(seeds):
        raise RuntimeError(f"expected records of seeds {list(seeds)}, found {records!r}")
    return [
        {
            "seed": r.seed,
            "objective": r.objective,
            "feasible": bool(r.feasible),
            "evaluations": r.evaluations,
            "wall_time_s": r.wall_time,
        }
        for r in records
    ]


def measure_comparison() -> dict[str, Any]:
    rows = []
    for row in COMPARISON_ROWS:
        for method in COMPARISON_METHODS:
            seeds = run_optimize(row, method, COMPARISON_SEEDS)
            rows.append(
                {
                    "label": row.label,
                    "symbol": row.symbol,
                    "method": method,
                    "command": " ".join(optimize_command(row, method, COMPARISON_SEEDS)),
                    "seeds": seeds,
                }
            )
    return {"rows": rows}


def render_comparison(data: dict[str, Any]) -> str:
    lines = [
        "| condition | method | objective, seeds 0-3 | median | spread | all feasible | time per seed |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in data["rows"]:
        values = [s["objective"] for s in row["seeds"]]
        times = [s["wall_time_s"] for s in row["seeds"]]
        lines.append(
            f"| {row['label']} ({row['symbol']}) | `{row['method']}` | "
            f"{', '.join(f'{v:.4f}' for v in values)} | **{statistics.median(values):.3f}** | "
            f"{100 * relative_spread(values):.1f} % | {'yes' if all(s['feasible'] for s in row['seeds']) else 'no'} | "
            f"{min(times):.1f}-{max(times):.1f} s |"
        )
    lines += ["", machine_line(data, "comparison"), "", "Each row's command:", ""]
    lines += [f"    {row['command']}" for row in data["rows"]]
    return "\n".join(lines) + "\n"


# --- benchmarks: documented commands run with --json (timings: shown, never compared) ---------
@dataclass(frozen=True)
class Benchmark:
    """A documented benchmark command; run with ``--json`` into a temporary file."""

    arguments: tuple[str, ...]
    """``python`` arguments: the script and its options."""
    environment: tuple[tuple[str, str], ...] = ()
    """Environment variables the documented command sets, as (name, value)."""

    @property
    def command(self) -> str:
        """The command as the documents show it."""
        return " ".join([*(f"{k}={v}" for k, v in self.environment), "python", *self.arguments])

    def run(self) -> dict[str, Any]:
        from tandem_env.io.files import read_json

        with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as out:
            path = Path(out) / "numbers.json"
            run_command(["python", *self.arguments, "--json", str(path)], dict(self.environment))
            data = read_json(path)
        return {**data, "command": self.command}


MODEL_THROUGHPUT = Benchmark(("benchmarks/model_throughput.py",))
INFLOW_SOLVE = Benchmark(("benchmarks/inflow_solve.py",))
ENV_THROUGHPUT = Benchmark(("benchmarks/env_throughput.py",))
_TORCH = (
    "benchmarks/model_throughput.py",
    "--backend",
    "torch",
    "--threads",
    "1",
    "--repeats",
    "3",
)
_ONE_THREAD = (("OMP_NUM_THREADS", "1"),)
TORCH_EAGER = Benchmark(
    (*_TORCH, "--batches", "1", "64", "1024", "--induction", "coupled", "none", "--gradient"),
    _ONE_THREAD,
)
TORCH_COMPILED = Benchmark(
    (*_TORCH, "--compile", "--batches", "64", "1024", "--induction", "coupled"), _ONE_THREAD
)
INDUCTIONS: tuple[str, ...] = ("coupled", "isolated", "none")


def spaced(value: float, digits: int = 0) -> str:
    """``value`` with thin groups of thousands as the documents write them (12 000)."""
    return f"{value:,.{digits}f}".replace(",", " ")


def by_case(rows: Iterable[dict[str, Any]]) -> dict[tuple[int, str], dict[str, Any]]:
    return {(r["batch"], r["induction"]): r for r in rows}


def render_model_throughput(data: dict[str, Any]) -> str:
    rates = by_case(data["rates"])
    batches = sorted({batch for batch, _ in rates})
    inductions = [i for i in INDUCTIONS if any((b, i) in rates for b in batches)]
    lines = [
        "| batch | "
        + " | ".join(f"`{i}`: evaluations/s (ms per call, sweeps)" for i in inductions)
        + " |",
        "|---" * (1 + len(inductions)) + "|",
    ]
    for batch in batches:
        cells = []
        for induction in inductions:
            r = rates[batch, induction]
            cells.append(
                f"{spaced(r['evaluations_per_s'])} ({r['ms_per_call']:.2f} ms, "
                f"{r['inflow_sweeps']:.1f})"
            )
        lines.append(f"| {batch} | " + " | ".join(cells) + " |")
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
        "",
        machine_line(data, "model-throughput"),
        "",
        f"    {data['command']}",
    ]
    return "\n".join(lines) + "\n"


def render_inflow_cost(data: dict[str, Any]) -> str:
    rates = by_case(data["rates"])
    ratios = {r["batch"]: r for r in data["ratios"]}
    lines = [
        "| batch | "
        + " | ".join(f"`{i}`: evaluations/s, best / median round" for i in INDUCTIONS)
        + " | coupled / none, wall: median (range) | coupled / none, CPU: median (range) |",
        "|---" * (3 + len(INDUCTIONS)) + "|",
    ]
    for batch in sorted(ratios):
        cells = [
            f"{spaced(rates[batch, i]['best_per_s'])} / {spaced(rates[batch, i]['median_per_s'])}"
            for i in INDUCTIONS
        ]
        r = ratios[batch]
        cells += [
            f"{r[kind + '_median']:.2f} ({r[kind + '_range'][0]:.2f}-{r[kind + '_range'][1]:.2f})"
            for kind in ("wall", "cpu")
        ]
        lines.append(f"| {batch} | " + " | ".join(cells) + " |")
    sweeps = "; ".join(
        f"V = {s['speed']:g} m/s: {100 * s['solved_share']:.0f} % of the annuli need a solve, "
        f"{s['mean_sweeps']:.2f} sweeps on average (at most {s['max_sweeps']})"
        for s in data["sweeps"]
    )
    lines += [
        "",
        f"{data['rounds']} interleaved rounds (every case once per round, back-to-back calls for "
        "0.3 s each), so a load that comes and goes hits all cases alike; the ratios are the "
        "medians of the per-round ratios of time per call.",
        "Force sweeps per fore-wing annulus (own inflow, 200 random strokes, the solver called "
        f"directly): {sweeps}.",
        "",
        machine_line(data, "inflow-cost"),
        "",
        f"    {data['command']}",
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
        "",
        machine_line(data, "env-throughput"),
        "",
        f"    {data['command']}",
    ]
    return "\n".join(lines) + "\n"


def measure_torch_throughput() -> dict[str, Any]:
    return {"eager": TORCH_EAGER.run(), "compiled": TORCH_COMPILED.run()}


def render_torch_throughput(data: dict[str, Any]) -> str:
    eager, compiled = by_case(data["eager"]["rates"]), by_case(data["compiled"]["rates"])
    columns = (("coupled, eager", eager, "coupled"), ("coupled, compiled", compiled, "coupled"),
               ("none, eager", eager, "none"))  # fmt: skip
    batches = sorted({batch for batch, _ in eager} | {batch for batch, _ in compiled})

    def cell(rates: dict[tuple[int, str], dict[str, Any]], key: tuple[int, str]) -> str:
        if key not in rates:
            return ""
        r = rates[key]
        return f"{spaced(r['evaluations_per_s'])} /s ({r['torch_over_numba']:.2g} × numba)"

    lines = [
        "| batch | " + " | ".join(title for title, _, _ in columns) + " |",
        "|---" * (1 + len(columns)) + "|",
    ]
    lines += [
        f"| {batch} | " + " | ".join(cell(rates, (batch, i)) for _, rates, i in columns) + " |"
        for batch in batches
    ]
    g = data["eager"]["gradient"]
    run = data["eager"]
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
        "",
        machine_line(data, "torch-throughput"),
        "",
        f"    {data['eager']['command']}",
        f"    {data['compiled']['command']}",
    ]
    return "\n".join(lines) + "\n"


# --- SpeedChange: the random and steady baselines (deterministic given the optima) -------------
SPEED_CHANGE_EPISODES = 32
SPEED_CHANGE_COMMAND = f"python -m eval speed-change --episodes {SPEED_CHANGE_EPISODES}"
#: The optima's metrics the table shows: info keys of a level-flight step (docs/envs.md).
OPTIMUM_METRICS: tuple[str, ...] = (
    "efficiency",
    "power_per_mass",
    "lift_to_weight",
    "thrust",
    "drag",
)


def speed_change_optima(speeds: Sequence[float] | None = None) -> list[dict[str, Any]]:
    """The steady schedule's level-flight optima as ``eval speed-change`` makes them (its
    defaults: optimiser, budget, seed), one ``{speed, objective, feasible, ...}`` per speed."""
    from agents.records import load_records
    from eval import speed_change
    from tandem_env.envs.speed_change import SpeedChangeConfig

    config = SpeedChangeConfig.from_kwargs()
    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as store:
        speed_change.steady_optima(
            config,
            speeds=speed_change.STEADY_GRID if speeds is None else speeds,
            cache_dir=store,
            progress=False,
        )
        records = sorted(load_records([store]), key=lambda r: r.job.condition)
    return [
        {
            "speed": r.job.condition,
            "method": r.method,
            "budget": r.budget,
            "seed": r.seed,
            "objective": r.objective,
            "feasible": bool(r.feasible),
            **{name: r.metrics[name] for name in OPTIMUM_METRICS},
            "normalised_stroke": list(r.normalised_stroke),
        }
        for r in records
    ]


def speed_change_rows(optima: Sequence[dict[str, Any]], first_seed: int) -> list[dict[str, Any]]:
    """``summary_rows`` of the random and steady policies over the evaluation episodes, the
    steady one playing ``optima``."""
    import numpy as np

    from eval import speed_change

    steady = speed_change.SteadyPolicy(
        np.array([o["speed"] for o in optima], dtype=np.float64),
        np.array([o["normalised_stroke"] for o in optima], dtype=np.float64),
    )
    seeds = range(first_seed, first_seed + SPEED_CHANGE_EPISODES)
    episodes = [
        speed_change.episode_metrics(log)
        for policy in (speed_change.RandomPolicy(seed=0), steady)
        for log in speed_change.run_episodes(policy, list(seeds))
    ]
    return speed_change.summary_rows(episodes)


def measure_speed_change() -> dict[str, Any]:
    from eval import speed_change

    optima = speed_change_optima()
    return {
        "command": SPEED_CHANGE_COMMAND,
        "first_seed": speed_change.FIRST_SEED,
        "optima": optima,
        "rows": speed_change_rows(optima, speed_change.FIRST_SEED),
    }


def render_speed_change(data: dict[str, Any]) -> str:
    from eval.speed_change import markdown_table

    optima = data["optima"]
    first = optima[0]
    random = next(r for r in data["rows"] if r["policy"] == "random")
    lines = [
        markdown_table(data["rows"]).rstrip("\n"),
        "",
        f"Random strokes end their episodes after {random['flight_time_mean_s']:.2f} s on "
        f"average. The steady schedule's level-flight optima ({first['method']}, "
        f"{spaced(first['budget'])} evaluations, seed {first['seed']}; "
        f"{sum(o['feasible'] for o in optima)} of {len(optima)} level-feasible):",
        "",
        "| V [m/s] | η | P/m [W/kg] | L/W | T − D [mN] | feasible |",
        "|---|---|---|---|---|---|",
        *(
            f"| {o['speed']:g} | {o['efficiency']:.3f} | {o['power_per_mass']:.1f} | "
            f"{o['lift_to_weight']:.3f} | {1e3 * (o['thrust'] - o['drag']):+.3f} | "
            f"{'yes' if o['feasible'] else 'no'} |"
            for o in optima
        ),
        "",
        machine_line(data, "speed-change"),
        "",
        f"    {data['command']}",
    ]
    return "\n".join(lines) + "\n"


# --- readings of the model on random strokes (deterministic: the test reruns them) -------------
RANDOM_STROKES = 1000
"""Random Table 4 strokes (uniform in the normalised box, seed 0) of the model's readings."""


def random_strokes(n: int = RANDOM_STROKES, seed: int = 0) -> Any:
    """(n, 28) physical strokes drawn uniformly in Table 4's box."""
    import numpy as np

    import tandem_env as te

    return te.normalised_to_physical(np.random.default_rng(seed).uniform(-1.0, 1.0, (n, 28)))


ROTATION_SPEEDS: tuple[float, ...] = (0.0, 1.5)
"""Flight speeds [m/s] of the rotational-coefficient reading (hover and 1.5 m/s)."""


def measure_rotational_coefficient() -> dict[str, Any]:
    """L/W with the paper's C_r = π over L/W with π/2 (both wings), for the random strokes that
    lift at least half the weight with π (docs/model.md §1.3)."""
    import math
    from dataclasses import replace

    import numpy as np

    import tandem_env as te

    strokes = random_strokes()
    insect = te.DRAGONFLY
    half = replace(
        insect,
        fore=replace(insect.fore, rotational_coefficient=math.pi / 2),
        hind=replace(insect.hind, rotational_coefficient=math.pi / 2),
    )
    rows = []
    for speed in ROTATION_SPEEDS:
        paper = te.evaluate(strokes, speed, insect=insect).lift_to_weight
        lifting = paper >= 0.5
        ratio = paper[lifting] / te.evaluate(strokes[lifting], speed, insect=half).lift_to_weight
        p5, p95 = np.percentile(ratio, [5, 95])
        rows.append(
            {
                "speed": speed,
                "strokes": int(lifting.sum()),
                "median": float(np.median(ratio)),
                "p5": float(p5),
                "p95": float(p95),
            }
        )
    return {"random_strokes": RANDOM_STROKES, "seed": 0, "rows": rows}


def render_rotational_coefficient(data: dict[str, Any]) -> str:
    hover, forward = data["rows"]
    return (
        f"On {spaced(data['random_strokes'])} random Table 4 strokes (seed {data['seed']}, "
        f"default options) that lift at least half the weight with C_r = π ({hover['strokes']} "
        f"in hover, {forward['strokes']} at {forward['speed']:g} m/s), L/W with C_r = π is a "
        f"median {hover['median']:.2f}× its value with C_r = π/2 in hover and "
        f"{forward['median']:.2f}× at {forward['speed']:g} m/s (5th-95th percentiles "
        f"{hover['p5']:.2f}-{hover['p95']:.1f}× and {forward['p5']:.2f}-{forward['p95']:.1f}×; "
        "`evaluate` with `rotational_coefficient` replaced on both wings, written by `python -m "
        "eval numbers --only rotational-coefficient`).\n"
    )


POWER_SPEEDS: tuple[float, ...] = (0.0, 1.0, 2.0)
"""Flight speeds [m/s] of the power-conventions reading."""


def measure_power_conventions() -> dict[str, Any]:
    """The ``"aerodynamic"`` power over the ``"absolute"`` and ``"elastic"`` ones on the random
    strokes (docs/model.md §6.3)."""
    import numpy as np

    import tandem_env as te

    strokes = random_strokes()
    rows = []
    for speed in POWER_SPEEDS:
        power = {
            kind: te.evaluate(strokes, speed, options=te.ModelOptions(power=kind)).power
            for kind in ("absolute", "elastic", "aerodynamic")
        }
        rows.append(
            {
                "speed": speed,
                "over_absolute_median": float(np.median(power["aerodynamic"] / power["absolute"])),
                "over_elastic_median": float(np.median(power["aerodynamic"] / power["elastic"])),
                "above_elastic_share": float(np.mean(power["aerodynamic"] > power["elastic"])),
            }
        )
    return {"random_strokes": RANDOM_STROKES, "seed": 0, "rows": rows}


def render_power_conventions(data: dict[str, Any]) -> str:
    rows = data["rows"]

    def listed(values: Sequence[str]) -> str:
        return ", ".join(values[:-1]) + " and " + values[-1]

    speeds = listed([f"{r['speed']:g}" for r in rows])
    absolute = listed([f"{r['over_absolute_median']:.2f}×" for r in rows])
    elastic = listed([f"{r['over_elastic_median']:.2f}×" for r in rows])
    above = listed([f"{100 * r['above_elastic_share']:.1f} %" for r in rows])
    return (
        f"On {spaced(data['random_strokes'])} random Table 4 strokes (seed {data['seed']}, other "
        f"options default) aerodynamic power is a median {absolute} the absolute power at "
        f"V = {speeds} m/s, {elastic} the elastic one, and exceeds the elastic one for {above} "
        "of the strokes "
        "(written by `python -m eval numbers --only power-conventions`).\n"
    )


# --- the resolution study at the defaults (deterministic: the test reruns it) -------------------
CONVERGENCE = Benchmark(("benchmarks/convergence.py", "--resolutions", "128x24"))
CONVERGENCE_BOUND_PERCENT = 0.5
"""The defaults' bound on the error of forces and power against the refined run [%] (§11.4)."""
CONVERGENCE_COLUMNS: tuple[tuple[str, str], ...] = (
    ("lift_to_weight", "L/W"),
    ("thrust", "T"),
    ("drag", "D"),
    ("power", "P"),
)


def render_convergence(data: dict[str, Any]) -> str:
    rows = sorted(data["rows"], key=lambda r: (r["speed"] == 0.0, r["speed"]))  # hover last

    def cell(error: dict[str, float]) -> str:
        text = f"{error['median']:.1g} % / {error['max']:.2g} %"
        if error["max"] > CONVERGENCE_BOUND_PERCENT:  # the few strokes beyond it: how few
            text += f" (p95 {error['p95']:.2g} %)"
        return text

    lines = [
        "| V [m/s] | "
        + " | ".join(f"{title} median / max" for _, title in CONVERGENCE_COLUMNS)
        + " |",
        "|---" * (1 + len(CONVERGENCE_COLUMNS)) + "|",
    ]
    for r in rows:
        speed = "0 (hover)" if r["speed"] == 0.0 else f"{r['speed']:.1f}"
        cells = " | ".join(cell(r["error_percent"][name]) for name, _ in CONVERGENCE_COLUMNS)
        lines.append(f"| {speed} | {cells} |")
    lines += [
        "",
        f"{data['strokes']} random strokes (seed {data['seed']}), n_time = {rows[0]['n_time']}, "
        f"n_blade = {rows[0]['n_blade']} against {4 * rows[0]['n_time']} and "
        f"{4 * rows[0]['n_blade']}; written by `python -m eval numbers --only convergence` from:",
        "",
        f"    {data['command']}",
    ]
    return "\n".join(lines) + "\n"


# --- the readings study at the paper preset (docs/reproduction.md, "Readings") -----------------
READINGS_PAPER_OUT = Path("results") / "readings-paper"
READINGS_PAPER_COMMAND = (
    f"python -m eval study readings --preset paper --scheduler local:2 --out {READINGS_PAPER_OUT}"
)
#: The run's small outputs kept where the docs include them: run's file -> the docs' copy.
READINGS_PAPER_FILES: dict[str, Path] = {
    "readings.csv": ROOT / "docs" / "readings" / "paper_readings.csv",
    "continuation_check.csv": ROOT / "docs" / "readings" / "paper_continuation_check.csv",
    "readings_manifest.json": ROOT / "docs" / "readings" / "paper_readings_manifest.json",
    "readings_matrix.png": ROOT / "docs" / "figures" / "readings_paper_matrix.png",
}
#: The headline columns of the readings table: (title, readings.csv columns).
READINGS_COLUMNS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("η_max [%]", ("eta_max_pct",)),
    ("F̄_v 50 / 90", ("Fv_50", "Fv_90")),
    ("F̄_h 50 / 90", ("Fh_50", "Fh_90")),
    ("F̄_a 50 / 90", ("Fa_50", "Fa_90")),
)


def measure_readings_paper() -> dict[str, Any]:
    """Collect the finished paper-preset readings run in :data:`READINGS_PAPER_OUT` (it takes
    1-2 h on 2 cores: run :data:`READINGS_PAPER_COMMAND` first) and copy its small outputs
    into the docs (:data:`READINGS_PAPER_FILES`)."""
    from eval.studies.readings import MANIFEST
    from tandem_env.io.files import atomic_path, read_json

    out = READINGS_PAPER_OUT
    if not (out / MANIFEST).is_file():
        raise SystemExit(f"{out} holds no finished readings run; run `{READINGS_PAPER_COMMAND}`")
    manifest = read_json(out / MANIFEST)
    if manifest.get("preset") != "paper" or "invocations" not in manifest:
        raise SystemExit(
            f"{out / MANIFEST} is not a paper-preset readings run of this version (preset "
            f"{manifest.get('preset')!r}); run `{READINGS_PAPER_COMMAND}`"
        )
    with open(out / "readings.csv", newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    for name, copy in READINGS_PAPER_FILES.items():
        copy.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(copy) as tmp:
            shutil.copyfile(out / name, tmp)
    keep = ("invocations", "continuation", "continuation_check", "run_in_full")
    return {
        "command": READINGS_PAPER_COMMAND,
        "rows": rows,
        "claims": manifest["claims"],
        "combination_rule": manifest["combination_rule"],
        **{key: manifest[key] for key in keep},
    }


def _duration(seconds: float) -> str:
    minutes, rest = divmod(round(seconds), 60)
    return f"{minutes} min {rest:02d} s" if minutes else f"{rest} s"


def _invocation_line(invocation: dict[str, Any]) -> str:
    """One invocation of a readings run: when, where, and each phase's work and time."""
    where = (
        f", {invocation['cpus']} CPUs, load average (1 min) "
        + " → ".join(str(x) for x in invocation["load_average_1min"])
        if "cpus" in invocation
        else ""
    )
    phases = "; ".join(
        f"{p['name']} {p['jobs']} optimisations ({p['ran']} run, {p['reused']} reused) in "
        f"{_duration(p['wall_time_s'])}"
        for p in invocation["phases"]
    )
    finished = invocation["finished"] or "finished before invocations were recorded"
    return f"- {finished}{where}: {phases}; {_duration(invocation['wall_time_s'])} in all."


def render_readings_paper(data: dict[str, Any]) -> str:
    """The readings table (the paper's numbers first, the best count in bold), the run's
    phases, the combination rule and the continuation's bias check with what ran in full."""
    from eval.studies.readings.report import check_table
    from eval.studies.readings.result import HEADLINES

    paper = {c["id"]: c["paper"] for c in data["claims"]}
    rows = data["rows"]
    worked = [inv for inv in data["invocations"] if any(p["ran"] for p in inv["phases"])]
    reused = [inv for inv in data["invocations"] if inv not in worked]
    best = max(int(r["agree"]) for r in rows)
    head = " | ".join(title for title, _ in READINGS_COLUMNS)
    lines = [
        f"| reading | changes from the default | agree | differ | undecided | not identifiable | "
        f"no data | {head} |",
        "|---|---|---|---|---|---|---|" + "---|" * len(READINGS_COLUMNS),
        "| paper | | | | | | | "
        + " | ".join(
            " / ".join(paper.get(HEADLINES[c][0], "–") for c in columns)
            for _, columns in READINGS_COLUMNS
        )
        + " |",
    ]
    for r in rows:
        mark = "**" if int(r["agree"]) == best else ""
        numbers = [
            " / ".join(f"{float(r[c]):.3g}" for c in columns) for _, columns in READINGS_COLUMNS
        ]
        lines.append(
            f"| {mark}`{r['reading']}`{mark} | {r['changes']} | {mark}{r['agree']}{mark} | "
            f"{r['differ']} | {r['undecided']} | {r.get('not_identifiable', '–')} | "
            f"{r['no_data']} | {' | '.join(numbers)} |"
        )
    counted = all("not_identifiable" in r for r in rows)
    lines += [
        "",
        f"{len(data['claims'])} claims; verdicts on the median over the seeds, undecided where "
        "the bootstrap over seeds leaves it open, not identifiable where the model does not "
        "depend on what the claim is about (docs/reproduction.md, *Agreement rules*)."
        + (
            ""
            if counted
            else " This run was analysed before the identifiability rule (– in its column): "
            "its agree, differ and undecided counts include verdicts on the fore/hind phase "
            "claims K1-K3, which the model does not depend on under any of its readings (all "
            "with the mean slipstream)."
        ),
        f"Combination rule: {data['combination_rule']}.",
        "",
        "The invocations into the run's folder that optimised (a job stored by an earlier "
        "invocation is reused):",
        "",
        *[_invocation_line(inv) for inv in worked],
        "",
        f"{len(reused)} more invocation(s) reused every job and only analysed and redrew "
        f"the outputs ({', '.join(_duration(inv['wall_time_s']) for inv in reused) or 'none'}).",
        "",
        "Bias check of the continuation (difference = (continued − full) / |full| of the "
        "reported objective, per job; a single reading's task that falls short ran in full):",
        "",
        *check_table(data["continuation_check"], data["run_in_full"]),
        "",
        "Collected from the run's own outputs by `python -m eval numbers --only readings-paper` "
        f"(after `{data['command']}`; its readings.csv, manifest, bias check and matrix are "
        "copied to docs/readings/ and docs/figures/).",
    ]
    return "\n".join(lines) + "\n"


# --- the registry -------------------------------------------------------------------------------
@dataclass(frozen=True)
class Measurement:
    """One generated number set: ``measure`` runs it (its JSON, without the machine fields that
    :func:`main` adds), ``render`` turns the stored JSON into the region's Markdown."""

    name: str
    measure: Callable[[], dict[str, Any]]
    render: Callable[[dict[str, Any]], str]
    on_request: bool = False
    """Measured only when named in ``--only``: it collects a long study's outputs (run first)."""


MEASUREMENTS: dict[str, Measurement] = {
    m.name: m
    for m in (
        Measurement("comparison", measure_comparison, render_comparison),
        Measurement("model-throughput", MODEL_THROUGHPUT.run, render_model_throughput),
        Measurement("inflow-cost", INFLOW_SOLVE.run, render_inflow_cost),
        Measurement("torch-throughput", measure_torch_throughput, render_torch_throughput),
        Measurement("env-throughput", ENV_THROUGHPUT.run, render_env_throughput),
        Measurement("speed-change", measure_speed_change, render_speed_change),
        Measurement(
            "rotational-coefficient", measure_rotational_coefficient, render_rotational_coefficient
        ),
        Measurement("power-conventions", measure_power_conventions, render_power_conventions),
        Measurement("convergence", CONVERGENCE.run, render_convergence),
        Measurement(
            "readings-paper", measure_readings_paper, render_readings_paper, on_request=True
        ),
    )
}


# --- machine, storage, documents ----------------------------------------------------------------
def cpu_model() -> str:
    """The CPU's model name where the system tells it (Linux), else the architecture."""
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                return line.partition(":")[2].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> dict[str, Any]:
    """Where and when a measurement ran (timings are read against this)."""
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {
        "date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "cpus": os.cpu_count(),
        "processor": platform.processor() or platform.machine(),
        "cpu_model": cpu_model(),
        "python": platform.python_version(),
        "load_average_1min": round(load[0], 2),
    }


def machine_line(data: dict[str, Any], name: str) -> str:
    """When, where and under what load measurement ``name`` ran, and how to rerun it."""
    before, after = data["machine_before"], data["machine_after"]
    cpu = before.get("cpu_model", before["processor"])
    return (
        f"Measured {before['date']} on {before['cpus']} CPUs ({cpu}, Python "
        f"{before['python']}), load average (1 min) {before['load_average_1min']} before and "
        f"{after['load_average_1min']} after; regenerate with `python -m eval numbers --only "
        f"{name}`."
    )


def json_path(name: str) -> Path:
    return NUMBERS_DIR / f"{name}.json"


def load(name: str) -> dict[str, Any]:
    return json.loads(json_path(name).read_text(encoding="utf-8"))


def save(name: str, data: dict[str, Any]) -> None:
    from tandem_env.io.files import atomic_path

    NUMBERS_DIR.mkdir(parents=True, exist_ok=True)
    with atomic_path(json_path(name)) as tmp:
        Path(tmp).write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n", "utf-8")


def regions(text: str) -> Iterable[re.Match[str]]:
    return REGION.finditer(text)


def render_document(text: str, rendered: dict[str, str]) -> str:
    """``text`` with every marked region replaced by its rendering (a measurement not stored
    yet: left as it is; a name no measurement has: an error)."""

    def body(match: re.Match[str]) -> str:
        name = match["name"]
        if name not in rendered and name in MEASUREMENTS:
            return match.group(0)
        if name not in rendered:
            raise KeyError(f"unknown numbers region {name!r}; known: {sorted(rendered)}")
        return match.group(1) + rendered[name] + match.group(4)

    return REGION.sub(body, text)


def write_documents(rendered: dict[str, str]) -> list[Path]:
    changed = []
    for path in DOCUMENTS:
        text = path.read_text(encoding="utf-8")
        new = render_document(text, rendered)
        if new != text:
            path.write_text(new, encoding="utf-8")
            changed.append(path)
    return changed


def rendered_all() -> dict[str, str]:
    """Every stored measurement's Markdown (one not measured yet has none)."""
    return {
        name: m.render(load(name)) for name, m in MEASUREMENTS.items() if json_path(name).exists()
    }


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--render",
        action="store_true",
        help="rewrite the documents from the stored docs/numbers/*.json without measuring",
    )
    parser.add_argument(
        "--only",
        nargs="+",
        choices=sorted(MEASUREMENTS),
        metavar="NAME",
        help=f"measure only these ({', '.join(sorted(MEASUREMENTS))})",
    )


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    if not args.render:
        every = [name for name, m in sorted(MEASUREMENTS.items()) if not m.on_request]
        for name in args.only or every:
            print(f"measuring {name} ...", file=sys.stderr, flush=True)
            before = machine()
            data = MEASUREMENTS[name].measure()
            save(name, {**data, "machine_before": before, "machine_after": machine()})
    for path in write_documents(rendered_all()):
        print(f"updated {path.relative_to(ROOT)}")
    return 0
