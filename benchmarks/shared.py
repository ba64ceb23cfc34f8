"""What the benchmark scripts share: the timing loop, the machine line and the ``--json`` writer."""

from __future__ import annotations

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


def call_times(call: Callable[[], Any], repeats: int) -> tuple[list[float], list[float]]:
    """Wall and CPU (all threads) seconds of each of ``repeats`` calls after a warm-up."""
    call()
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        call()
        wall.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    return wall, cpu


def best_time(call: Callable[[], Any], repeats: int) -> float:
    """The best wall seconds of ``repeats`` calls after a warm-up (:func:`call_times`)."""
    return min(call_times(call, repeats)[0])


def machine() -> str:
    """The processor, its cores and numba's threads, as the scripts print them."""
    import numba

    return (
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"numba {numba.__version__} with {numba.get_num_threads()} threads"
    )


def write_numbers(path: Path | None, numbers: dict[str, Any]) -> None:
    """Write ``numbers`` as JSON to ``path``, if given, with the command that measured them."""
    if path is not None:
        script = f"benchmarks/{Path(sys.argv[0]).name}"
        write_json_atomic(path, {"command": " ".join(["python", script, *sys.argv[1:]]), **numbers})
