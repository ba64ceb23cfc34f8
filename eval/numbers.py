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

Timings are not deterministic: they are shown with the machine, date and load they were taken
at, and the test does not compare them.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import re
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


def run_optimize(row: ComparisonRow, method: str, seeds: Sequence[int]) -> list[dict[str, Any]]:
    """Run the documented command in a fresh folder; one ``{seed, objective, ...}`` per seed."""
    from agents.records import load_records

    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as out:
        command = [sys.executable, *optimize_command(row, method, seeds)[1:], "--out", out]
        done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise RuntimeError(
                f"{' '.join(command)} exited {done.returncode}:\n{done.stderr[-2000:]}"
            )
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
    lines += ["", machine_line(data), "", "Each row's command:", ""]
    lines += [f"    {row['command']}" for row in data["rows"]]
    return "\n".join(lines) + "\n"


# --- the registry -------------------------------------------------------------------------------
@dataclass(frozen=True)
class Measurement:
    name: str
    measure: Callable[[], dict[str, Any]]
    render: Callable[[dict[str, Any]], str]


MEASUREMENTS: dict[str, Measurement] = {
    m.name: m for m in (Measurement("comparison", measure_comparison, render_comparison),)
}


# --- machine, storage, documents ----------------------------------------------------------------
def machine() -> dict[str, Any]:
    """Where and when a measurement ran (timings are read against this)."""
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {
        "date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "cpus": os.cpu_count(),
        "processor": platform.processor() or platform.machine(),
        "python": platform.python_version(),
        "load_average_1min": round(load[0], 2),
    }


def machine_line(data: dict[str, Any]) -> str:
    before, after = data["machine_before"], data["machine_after"]
    return (
        f"Measured {before['date']} on {before['cpus']} CPUs ({before['processor']}, Python "
        f"{before['python']}), load average {before['load_average_1min']} before and "
        f"{after['load_average_1min']} after; regenerate with `python -m eval numbers`."
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
    """``text`` with every marked region replaced by its rendering (unknown names: an error)."""

    def body(match: re.Match[str]) -> str:
        name = match["name"]
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
    return {name: m.render(load(name)) for name, m in MEASUREMENTS.items()}


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
        for name in args.only or sorted(MEASUREMENTS):
            print(f"measuring {name} ...", file=sys.stderr, flush=True)
            before = machine()
            data = MEASUREMENTS[name].measure()
            save(name, {**data, "machine_before": before, "machine_after": machine()})
    for path in write_documents(rendered_all()):
        print(f"updated {path.relative_to(ROOT)}")
    return 0
