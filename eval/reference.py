"""``python -m eval reference``: make the reference table of certified optima.

One job per grid point, objective, planform and seed (:data:`tandem_env.envs.reference.
REFERENCE_GRID`; CMA-ES with its polish, :data:`BUDGETS`, seeds :data:`SEEDS`), run by the
resumable runner (:func:`agents.runner.run_jobs`: records in ``--out``, here or on Dask with
``--scheduler``, a killed run resumes); then, per point, the best seed by the harness's one rule
(:mod:`agents.selection`: feasible first, then the higher objective) is written to the
packaged table ``tandem_env/data/reference_optima.json`` (or ``--table``) with its stroke,
every seed's objective, its certificate and the provenance (the command, package versions,
date, budgets, seeds and each series' fingerprint of the defaults). A figure and a Markdown
table of the optima go to ``--out``. docs/reference.md says how the table is used.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import sys
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from agents.harness import PreparedJob, prepare
from agents.records import Record, package_versions
from agents.runner import OutputNotWritable, run_jobs
from agents.selection import best_index
from agents.tasks import TaskSpec, available_tasks, get_task
from eval.optimize import STOPS, add_cache_argument, add_scheduler_argument, stopped
from tandem_env.envs.reference import (
    REFERENCE_FORMAT,
    REFERENCE_GRID,
    config_fingerprint,
    reference_path,
)
from tandem_env.envs.registration import config_class
from tandem_env.io.files import write_json_atomic
from tandem_env.physics.insect import PLANFORMS

NAME = "reference"
HELP = "make the reference table of certified optima (tandem_env.reference, the envs' scores)"

#: The method every reference optimisation runs (with its polish: the records' certificates).
METHOD = "cmaes"
#: Model evaluations per optimisation, per env id (the paper preset's budgets).
BUDGETS: Mapping[str, int] = {
    "TandemWing/LevelFlight-v0": 16_000,
    "TandemWing/Accelerate-v0": 12_000,
}
#: The seeds of every grid point; the table keeps the best.
SEEDS: tuple[int, ...] = (0, 1, 2, 3)
#: The preset name in every job's key (records of the studies are never mixed in).
PRESET = "reference"
#: Where the records and the figure go by default.
DEFAULT_OUT = Path("results") / "reference"


def _task(env_id: str) -> TaskSpec:
    return next(get_task(n) for n in available_tasks() if get_task(n).env_id == env_id)


def plan(
    seeds: Sequence[int] = SEEDS,
    budgets: Mapping[str, int] = BUDGETS,
    grid: Mapping[str, tuple[tuple[str, ...], tuple[float, ...]]] = REFERENCE_GRID,
    env_kwargs: Mapping[str, Any] | None = None,
) -> dict[tuple[str, str, str, float], list[PreparedJob]]:
    """The jobs of the table: per (env id, objective, planform, condition), one per seed."""
    jobs: dict[tuple[str, str, str, float], list[PreparedJob]] = {}
    for env_id, (objectives, conditions) in grid.items():
        task = _task(env_id)
        for objective in objectives:
            for planform in PLANFORMS:
                for condition in conditions:
                    jobs[env_id, objective, planform, condition] = prepare(
                        METHOD,
                        task,
                        condition,
                        budgets[env_id],
                        seeds,
                        objective=objective if task.objective_kwarg else None,
                        env_kwargs={"planform": planform, **(env_kwargs or {})},
                        preset=PRESET,
                    )
    return jobs


def _point(records: Sequence[Record]) -> dict[str, Any]:
    """One grid point of the table: the best seed's optimum, every seed's objective."""
    best = records[best_index([r.feasible for r in records], [r.reward for r in records])]
    certificate = best.certificate
    return {
        "condition": best.job.condition,
        "objective": best.objective if best.feasible else float("nan"),
        "feasible": bool(best.feasible),
        "seed": best.seed,
        "seed_objectives": [r.objective if r.feasible else None for r in records],
        "normalised_stroke": list(best.normalised_stroke),
        "certificate": {
            k: certificate.get(k) for k in ("method", "status", "gain", "objective_before")
        },
        "record_key": best.key,
    }


def build_table(
    jobs: Mapping[tuple[str, str, str, float], Sequence[PreparedJob]],
    records: Mapping[str, Record],
    provenance: Mapping[str, Any],
) -> dict[str, Any]:
    """The reference table (format :data:`REFERENCE_FORMAT`) from the jobs' records."""
    series: dict[tuple[str, str, str], list[dict[str, Any]]] = {}
    fingerprints: dict[tuple[str, str, str], set[str]] = {}
    for (env_id, objective, planform, _), prepared in jobs.items():
        found = [records[p.job.key] for p in prepared]
        series.setdefault((env_id, objective, planform), []).append(_point(found))
        fingerprints.setdefault((env_id, objective, planform), set()).update(
            config_fingerprint(config_class(env_id), r.results["env"]) for r in found
        )
    for key, seen in fingerprints.items():
        if len(seen) != 1:  # the plan gives every job of a series the same env keywords
            raise ValueError(f"the records of {key} were made with {len(seen)} configurations")
    return {
        "format": REFERENCE_FORMAT,
        "provenance": dict(provenance),
        "series": [
            {
                "env_id": env_id,
                "objective": objective,
                "planform": planform,
                "fingerprint": next(iter(fingerprints[env_id, objective, planform])),
                "points": sorted(points, key=lambda p: p["condition"]),
            }
            for (env_id, objective, planform), points in series.items()
        ],
    }


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--out",
        type=Path,
        default=DEFAULT_OUT,
        help=f"the optimisations' records, figure and table (default {DEFAULT_OUT})",
    )
    parser.add_argument(
        "--table",
        type=Path,
        default=None,
        help="where the table goes (default: the packaged tandem_env/data/reference_optima.json)",
    )
    add_scheduler_argument(parser)
    add_cache_argument(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def provenance(jobs: Iterable[PreparedJob]) -> dict[str, Any]:
    seeds = sorted({p.job.seed for p in jobs})
    return {
        # where it ran (--scheduler, --out) does not change the table
        "command": f"python -m eval {NAME}",
        "date": dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "versions": package_versions(),
        "method": METHOD,
        "budgets": dict(BUDGETS),
        "seeds": seeds,
        "selection": "per point, the best seed: feasible first, then the higher objective",
    }


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    table_path = Path(args.table) if args.table is not None else Path(str(reference_path()))
    if table_path.is_dir():
        parser.error(f"--table {table_path} is a folder; allowed: a JSON file's path")
    if not table_path.parent.is_dir() or not os.access(table_path.parent, os.W_OK):
        parser.error(
            f"--table {table_path}: its folder {table_path.parent} does not exist or cannot be "
            "written; allowed: a file in a writable folder (an installed package's table: give "
            "--table PATH)"
        )
    jobs = plan()
    flat = [p for prepared in jobs.values() for p in prepared]
    if not args.quiet:
        print(
            f"reference: {len(jobs)} grid points x {len(SEEDS)} seeds = {len(flat)} "
            f"optimisations ({sum(p.job.budget for p in flat):,} model evaluations) -> "
            f"{args.out}, table {table_path}",
            file=sys.stderr,
        )
    try:
        summary = run_jobs(
            flat,
            args.out,
            scheduler=args.scheduler,
            progress=not args.quiet,
            cache=args.cache,
            summary_csv=True,
        )
    except OutputNotWritable as error:
        parser.error(str(error))
    except STOPS as error:
        return stopped(parser, error)
    table = build_table(jobs, summary.records, provenance(flat))
    write_json_atomic(table_path, table)
    _report(table, Path(args.out))
    print(
        f"reference: {summary.describe(args.out)}; table written to {table_path}",
        file=sys.stderr,
    )
    return 0


def _report(table: Mapping[str, Any], out: Path) -> None:
    """The table as Markdown (``OUT/reference.md``) and a figure (``OUT/reference.png``)."""
    from eval.reference_report import write_reference_figure, write_reference_markdown

    write_reference_markdown(table, out / "reference.md")
    write_reference_figure(table, out / "reference.png")
    for series in table["series"]:
        weak = [p for p in series["points"] if not p["feasible"]]
        if weak:
            print(
                f"warning: {series['env_id']} {series['objective']} {series['planform']}: no "
                f"feasible optimum at {[p['condition'] for p in weak]}",
                file=sys.stderr,
            )
