"""The framework of ``python -m eval numbers``: where numbers live, one :class:`Measurement`,
the documented commands it runs, the machine a timing is read against, shared helpers."""

from __future__ import annotations

import contextlib
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
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from threadpoolctl import threadpool_info

from agents.store import read_record_files
from eval.studies.report import table_head, table_row
from tandem_env.io.files import atomic_path, read_json, write_text_atomic

ROOT = Path(__file__).resolve().parents[2]
NUMBERS_DIR = ROOT / "docs" / "numbers"
DOCUMENTS: tuple[Path, ...] = (ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")))
REGION = re.compile(
    r"(<!-- numbers: (?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /numbers -->)", re.DOTALL
)


def _run(command: Sequence[str], environment: dict[str, str] | None = None) -> str:
    """Run ``command`` from the repository root (``environment``: variables set for it); its
    standard output. A failure raises with the end of its stderr."""
    env = {**os.environ, **(environment or {})}
    done = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} exited {done.returncode}:\n{done.stderr[-2000:]}")
    return done.stdout


def run_command(command: Sequence[str], environment: dict[str, str] | None = None) -> float:
    """Run a documented ``python ...`` command with this interpreter; its wall time [s]."""
    start = time.perf_counter()
    _run([sys.executable, *command[1:]] if command[0] == "python" else command, environment)
    return time.perf_counter() - start


def optimize_command(arguments: Sequence[str], seeds: Sequence[int]) -> str:
    """The documented ``eval optimize`` command of ``arguments`` over ``seeds`` (no ``--out``)."""
    return " ".join(["python -m eval optimize", *arguments, "--seeds", *map(str, seeds)])


def run_seeds(arguments: Sequence[str], seeds: Sequence[int]) -> list[Any]:
    """Run the documented ``eval optimize`` command into a fresh folder with the record cache
    off (measured now, wall times too); its records, by seed."""
    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as out:
        run_command([*optimize_command(arguments, seeds).split(), "--out", out, "--no-cache"])
        records = sorted(read_record_files([out]), key=lambda r: r.seed)
    if [r.seed for r in records] != list(seeds):
        raise RuntimeError(f"expected records of seeds {list(seeds)}, found {records!r}")
    return records


def seed_cells(by_kernel: Sequence[Sequence[dict[str, Any]]]) -> tuple[str, str, str, str]:
    """The cells of one command's seeds under each BLAS kernel (the machine's own first): each
    seed's objective and their median (bold) at the digits every kernel gives, whether all are
    feasible under every kernel, and the range of the own kernel's wall times per seed."""
    times = [s["wall_time_s"] for s in by_kernel[0]]
    objectives = [[s["objective"] for s in kernel] for kernel in by_kernel]
    return (
        ", ".join(agreed(values, "{:.4f}") for values in zip(*objectives, strict=True)),
        f"**{agreed([statistics.median(v) for v in objectives], '{:.3f}')}**",
        "yes" if all(s["feasible"] for kernel in by_kernel for s in kernel) else "no",
        f"{min(times):.1f}-{max(times):.1f} s",
    )


# --- BLAS kernels: the optimisations' last digits are the machine's ---------------------------
#: OpenBLAS kernels (``OPENBLAS_CORETYPE``) an optimisation's numbers are measured under besides
#: the machine's own: the generic AVX and AVX2 kernels, which every x86-64 CPU the project runs
#: on can execute. Another kernel changes the last bits of the linear algebra (CMA-ES's
#: eigendecomposition, the polish's QP); the searches turn that into other digits, at times
#: into another local optimum (docs/harness.md, "Machine-dependent digits").
OTHER_BLAS_KERNELS: tuple[str, ...] = ("Sandybridge", "Haswell")


def blas_kernel() -> str:
    """The kernel numpy's BLAS runs here: OpenBLAS's core type (``SkylakeX``, ``Haswell``, ...,
    as threadpoolctl reports it; ``OPENBLAS_CORETYPE`` chooses it), else the library's name."""
    import numpy  # noqa: F401  (threadpoolctl sees the BLAS of the modules already loaded)

    for library in threadpool_info():
        if library["user_api"] == "blas":
            return str(library.get("architecture") or library["internal_api"])
    return "none"


def other_kernels() -> list[str]:
    """The kernels of :data:`OTHER_BLAS_KERNELS` but the machine's own (none where numpy's BLAS
    is not OpenBLAS: its kernel cannot be chosen)."""
    if not any(lib["internal_api"] == "openblas" for lib in threadpool_info()):
        return []
    return [kernel for kernel in OTHER_BLAS_KERNELS if kernel.lower() != blas_kernel().lower()]


def measure_other_kernels(name: str) -> dict[str, Any]:
    """The machine's own kernel (``blas_kernel``) and measurement ``name`` again in a fresh
    process under each of :func:`other_kernels` (``other_kernels``, by kernel)."""
    script = (
        "import json, sys; from eval.numbers import MEASUREMENTS; "
        "json.dump(MEASUREMENTS[sys.argv[1]].measure(), sys.stdout)"
    )
    command = [sys.executable, "-c", script, name]
    others = {k: json.loads(_run(command, {"OPENBLAS_CORETYPE": k})) for k in other_kernels()}
    return {"blas_kernel": blas_kernel(), "other_kernels": others}


def kernel_views(data: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """A measurement's data under each kernel, the machine's own first (one view without)."""
    own = {k: v for k, v in data.items() if k != "other_kernels"}
    return {data.get("blas_kernel", "unknown"): own, **data.get("other_kernels", {})}


def for_kernel(data: dict[str, Any], kernel: str) -> dict[str, Any] | None:
    """The data measured under ``kernel`` (case-insensitive), or None where it was not."""
    return next((v for k, v in kernel_views(data).items() if k.lower() == kernel.lower()), None)


def kernels_line(data: dict[str, Any]) -> str:
    """The sentence under a BLAS-dependent table: its kernels, and what a range means."""
    own, *others = kernel_views(data)
    kernels = ", ".join([f"{own} (the measuring machine's own)", *others])
    return (
        f"Measured under the BLAS kernels {kernels}; a cell a–b is a number that differs between "
        'them, the others are the same under each (docs/harness.md, "Machine-dependent digits").'
    )


def agreed(values: Sequence[float], form: str) -> str:
    """One number measured under several kernels as shown: ``form`` of it where every kernel
    gives the same text, else their range, ``min–max``."""
    if len(texts := {form.format(v) for v in values}) == 1:
        return texts.pop()
    return f"{form.format(min(values))}–{form.format(max(values))}"


def within_shown(value: float, values: Sequence[float], form: str) -> bool:
    """Whether ``value`` (from a kernel not measured) is what :func:`agreed` shows of
    ``values``: the same text, or inside the shown range."""
    low, _, high = agreed(values, form).partition("–")
    return float(low) <= float(form.format(value)) <= float(high or low)


# --- benchmarks: documented commands run with --json (timings: shown, never compared) ---------
@dataclass(frozen=True)
class Benchmark:
    """A documented benchmark command; run with ``--json`` into a temporary file."""

    arguments: tuple[str, ...]
    """``python`` arguments: the script and its options."""
    environment: tuple[tuple[str, str], ...] = ()
    """Environment variables the documented command sets, as (name, value)."""

    def run(self) -> dict[str, Any]:
        """Its numbers, with the command as the documents show it."""
        command = " ".join([*(f"{k}={v}" for k, v in self.environment), "python", *self.arguments])
        with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as out:
            path = Path(out) / "numbers.json"
            run_command(["python", *self.arguments, "--json", str(path)], dict(self.environment))
            return {**read_json(path), "command": command}


def table(titles: Sequence[str], rows: Iterable[Iterable[object]]) -> list[str]:
    """A Markdown table's lines: its heading, the rule under it and a line per row of cells."""
    return [*table_head(titles), *map(table_row, rows)]


def median_range(row: dict[str, Any], kind: str, median: str = "_median", unit: str = "") -> str:
    """A row's ``{kind}{median}`` and ``{kind}_range`` as the tables write them: 1.23 (1.10-1.40)
    (``unit`` after the median)."""
    low, high = row[kind + "_range"]
    return f"{row[kind + median]:.2f}{unit} ({low:.2f}-{high:.2f})"


def spaced(value: float, digits: int = 0) -> str:
    """``value`` with thin groups of thousands as the documents write them (12 000)."""
    return f"{value:,.{digits}f}".replace(",", " ")


def minutes(seconds: float, padded: bool = False) -> str:
    """``seconds`` as the documents write a duration: 4 min 5 s (``padded``: 4 min 05 s)."""
    whole, rest = divmod(round(seconds), 60)
    if not whole:
        return f"{rest} s"
    return f"{whole} min {rest:02d} s" if padded else f"{whole} min {rest} s"


@dataclass(frozen=True)
class Measurement:
    """One generated number set: ``measure`` runs it (its JSON), ``render`` turns the stored
    JSON into the region's Markdown."""

    name: str
    measure: Callable[[], dict[str, Any]]
    render: Callable[[dict[str, Any]], str]
    on_request: bool = False
    """Measured only when named in ``--only``: it collects a long study's outputs (run first)."""
    blas_dependent: bool = False
    """Its numbers come from optimisations, whose last digits depend on the BLAS kernel: also
    measured under :data:`OTHER_BLAS_KERNELS`, rendered at the digits all give."""


def machine() -> dict[str, Any]:
    """Where and when a measurement ran (timings are read against this; the CPU's model name
    where the system tells it, Linux, else the architecture)."""
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    processor = cpu = platform.processor() or platform.machine()
    with contextlib.suppress(OSError):
        lines = Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines()
        cpu = next((x.partition(":")[2].strip() for x in lines if x.startswith("model name")), cpu)
    return {
        "date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "cpus": os.cpu_count(),
        "processor": processor,
        "cpu_model": cpu,
        "python": platform.python_version(),
        "load_average_1min": round(load[0], 2),
    }


def machine_line(data: dict[str, Any], name: str) -> str:
    """When, where and under what load measurement ``name`` ran, and how to rerun it."""
    before, after = data["machine_before"], data["machine_after"]
    cpu = before.get("cpu_model", before["processor"])  # an older measurement has none
    return (
        f"Measured {before['date']} on {before['cpus']} CPUs ({cpu}, Python "
        f"{before['python']}), load average (1 min) {before['load_average_1min']} before and "
        f"{after['load_average_1min']} after; regenerate with `python -m eval numbers --only "
        f"{name}`."
    )


def footer(data: dict[str, Any], name: str, *commands: str, heading: str = "") -> list[str]:
    """The lines that close a region: :func:`machine_line`, ``heading`` and the commands."""
    headed = [heading, ""] if heading else []
    return ["", machine_line(data, name), "", *headed, *(f"    {c}" for c in commands)]


def read_rows(path: Path) -> list[dict[str, str]]:
    """The rows of a CSV file a run wrote, as text."""
    with open(path, newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def copy_outputs(run: Path, copies: dict[str, Path]) -> None:
    """Copy a finished run's small outputs (its file name -> the docs' copy), atomically."""
    for name, copy in copies.items():
        with atomic_path(copy) as tmp:
            shutil.copyfile(run / name, tmp)


def json_path(name: str) -> Path:
    return NUMBERS_DIR / f"{name}.json"


def load(name: str) -> dict[str, Any]:
    return json.loads(json_path(name).read_text(encoding="utf-8"))


def save(name: str, data: dict[str, Any]) -> None:
    write_text_atomic(json_path(name), json.dumps(data, indent=1, ensure_ascii=False) + "\n")


def regions(text: str) -> Iterable[re.Match[str]]:
    return REGION.finditer(text)
