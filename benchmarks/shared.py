"""What the benchmark scripts share: the timing loop, the machine line and the ``--json`` option
and writer."""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import tandem_env as te
from tandem_env.io.files import write_json_atomic

#: The paper's model (the mean reading), which the speed benchmarks time and compare the other
#: readings with whatever ``ModelOptions``' default is (docs/crosscheck.md, *The rule*).
PAPER = te.ModelOptions(slipstream="mean")


def seconds_per_call(
    call: Callable[[], Any], calls: int = 1, min_seconds: float = 0.0
) -> tuple[float, float]:
    """Wall and CPU (all threads of this process) seconds per call, over ``calls`` back-to-back
    calls, more while they last less than ``min_seconds``."""
    count, start, start_cpu = 0, time.perf_counter(), time.process_time()
    while count < calls or time.perf_counter() - start < min_seconds:
        call()
        count += 1
    return (time.perf_counter() - start) / count, (time.process_time() - start_cpu) / count


def call_times(call: Callable[[], Any], repeats: int) -> tuple[list[float], list[float]]:
    """Wall and CPU (all threads) seconds of each of ``repeats`` calls after a warm-up."""
    call()
    wall, cpu = zip(*(seconds_per_call(call) for _ in range(repeats)), strict=True)
    return list(wall), list(cpu)


def best_time(call: Callable[[], Any], repeats: int) -> float:
    """The fastest wall-clock seconds of ``repeats`` calls after a warm-up."""
    return min(call_times(call, repeats)[0])


def machine() -> str:
    """The processor, its cores, numba's threads and the load, as the scripts print them."""
    import numba

    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    return (
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"numba {numba.__version__} with {numba.get_num_threads()} threads, load average {load}"
    )


def parser_with_json(doc: str) -> argparse.ArgumentParser:
    """A script's parser: described by its docstring's first line, with the ``--json`` option
    that :func:`write_numbers` serves."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--json", type=Path, default=None, help="also write the numbers here")
    return parser


def write_numbers(path: Path | None, numbers: dict[str, Any]) -> None:
    """Write ``numbers`` as JSON to ``path``, if given, with the command that measured them."""
    if path is not None:
        script = f"benchmarks/{Path(sys.argv[0]).name}"
        write_json_atomic(path, {"command": " ".join(["python", script, *sys.argv[1:]]), **numbers})
