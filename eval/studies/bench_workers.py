"""Measure the study runner's two modes on the same jobs (docs/reproduction.md cites the result).

    python -m eval.studies.bench_workers [--jobs 8] [--budget 4000]

``--workers 1``: one process, numba's default threads (2 on a 2-core machine);
``--workers 2``: a spawn pool of two processes with one numba thread each.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from eval.studies.base import Plan
from eval.studies.presets import QUICK
from eval.studies.runner import run_jobs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=8, help="level-flight optimisations (even)")
    parser.add_argument("--budget", type=int, default=4000, help="evaluations per optimisation")
    args = parser.parse_args()
    seeds = tuple(range(max(1, args.jobs // 2)))
    preset = replace(QUICK, name="bench", seeds=seeds, level_budget=args.budget)
    jobs = Plan(preset).jobs("level", [1.0, 1.5])
    root = Path(tempfile.mkdtemp(prefix="bench_workers_"))
    try:
        for workers in (1, 2, 1, 2):  # twice each: the machine may be shared
            out = root / f"w{workers}"
            shutil.rmtree(out, ignore_errors=True)
            start = time.perf_counter()
            summary = run_jobs(jobs, out, workers=workers, progress=False)
            seconds = time.perf_counter() - start
            rate = summary.ran * args.budget / seconds
            print(
                f"workers={workers}: {summary.ran} x {args.budget} evaluations in {seconds:.1f} s "
                f"= {rate:.0f} evaluations/s",
                flush=True,
            )
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
