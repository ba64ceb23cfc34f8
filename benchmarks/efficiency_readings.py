"""Which reading of η = T·V/P (Eq. 22) gives the paper's 12.7 % at 1.5 m/s (docs/efficiency.md).

    python benchmarks/efficiency_readings.py [--scheduler local:2] [--out results/efficiency]

Level flight at 1.5 m/s over the same seeds, through the harness (records shared with ``python
-m eval optimize``): 1. the six readings of T (thrust split) and P (power), each optimised by
CMA-ES (16 000 evaluations) with the SLSQP polish; 2. the same searched as in the paper's era
(``PAPER_SEARCHES``), plus PSO 40 × 50 with linearly decreasing inertia; 3. with ``--claims
PRESET`` instead, the studies' claims under the default and ``hover-none`` readings
(``OUT/claims-PRESET/efficiency_claims.json``). Parts 1-2 print one table and write it with the
run's date, machine and load to ``OUT/efficiency_readings.json``; a rerun computes only what
is missing.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agents.harness import PreparedJob, prepare
from agents.runner import run_jobs
from eval.studies.base import StudyPlan
from eval.studies.paper_reading import DEFAULT, PAPER_SEARCHES, Reading, Search, combine
from eval.studies.presets import get_preset
from eval.studies.readings import SINGLES, run_readings
from eval.studies.report import table_head, table_row
from tandem_env import DRAGONFLY
from tandem_env.io.files import read_json, write_json_atomic

SPEED = 1.5  # [m/s], the paper's peak (Fig. 6)
PAPER_ETA = 12.7  # [%], Fig. 6 (claim S7)
CERTIFIED = Search("cmaes", budgets={"level": 16_000})  # the paper preset's level search
#: T readings: env keyword value -> what T is (docs/model.md §7.3).
THRUST = {
    "sign": "forward part of each wing's horizontal force (gross)",
    "body": "net horizontal wing force; D = body drag",
}
#: P readings: env keyword value -> what P is (docs/model.md §6.3, Eqs. 18-19).
POWER = {
    "absolute": "N_w·(mean|P_aero| + mean|P_iner|)",
    "elastic": "N_w·mean(P_aero + P_iner)⁺",
    "aerodynamic": "N_w·mean(P_aero)⁺",
}
#: The era's other common PSO parameter set, at the middle budget, under the default reading.
LINEAR_INERTIA = Search(
    "pso", swarm_size=40, iterations=50, settings={"polish": "none", "inertia": "linear-decreasing"}
)
#: The reading under which the paper's F̄_v matches converged optima (docs/reproduction.md).
HOVER_NONE = next(r for r in SINGLES if r.name == "hover-none")


@dataclass(frozen=True)
class Case:
    """One row: a reading of T and P searched one way."""

    thrust: str
    power: str
    search: Search

    def prepare(self, seeds: list[int]) -> list[PreparedJob]:
        """Its jobs over ``seeds``, with only what differs from the defaults in their env
        keywords (the reading's), so the records are plain runs' records."""
        options = {"thrust_split": self.thrust, "power": self.power}
        reading = Reading(f"{self.thrust}-{self.power}", "T and P", options=options)
        budget = self.search.budget("level")
        assert budget is not None
        config = dict(self.search.method_config(40))
        kwargs = {"env_kwargs": reading.env_kwargs(), "method_config": config}
        return prepare(self.search.method, "level", SPEED, budget, seeds, **kwargs)


def cases() -> list[Case]:
    """Part 1 (certified) for every reading, then part 2 (the paper-era searches)."""
    searches = [CERTIFIED, *(r.search for r in PAPER_SEARCHES if r.search is not None)]
    out = [Case(t, p, s) for s in searches for t in THRUST for p in POWER]
    return [*out, Case("sign", "absolute", LINEAR_INERTIA)]


def _label(search: Search) -> str:
    if search == CERTIFIED:
        return "CMA-ES 16 000 + SLSQP polish"
    inertia = dict(search.settings).get("inertia")
    return f"PSO {search.swarm_size}×{search.iterations}, no polish" + (
        f", {inertia}" if inertia else ""
    )


def summarise(case: Case, records: list[Any]) -> dict[str, Any]:
    """The row of ``case`` from its seeds' records (η of each seed's best feasible stroke)."""
    feasible = [r for r in records if r.feasible]
    eta = sorted(100 * r.objective for r in feasible)
    row: dict[str, Any] = {
        "T": case.thrust,
        "P": case.power,
        "search": _label(case.search),
        "budget": case.search.budget("level"),
        "seeds": len(records),
        "feasible": len(feasible),
    }
    if not eta:
        return row | {"median_eta": None}
    median = statistics.median(eta)
    thrust = statistics.median(r.metrics["thrust"] for r in feasible) / DRAGONFLY.weight
    power = statistics.median(r.metrics["power_per_mass"] for r in feasible)
    # T = D read exactly: the same strokes' D·V/P (level flight holds T = D only to the
    # task's tolerance, 2 % of W, which exceeds the body's drag at 1.5 m/s)
    eta_d = [100 * r.objective * r.metrics["drag"] / r.metrics["thrust"] for r in feasible]
    return row | {
        "median_eta": round(median, 2),
        "min_eta": round(eta[0], 2),
        "max_eta": round(eta[-1], 2),
        "best_seed": max(feasible, key=lambda r: r.objective).seed,
        "median_over_paper": round(median / PAPER_ETA, 2),
        "paper_in_range": eta[0] <= PAPER_ETA <= eta[-1],
        # a polish that converged ends at a constrained local optimum (KKT residual in the record)
        "polish_converged": sum(r.certificate.get("converged") is True for r in feasible),
        "median_T_over_W": round(thrust, 3),
        "median_P_per_mass": round(power, 1),
        "median_eta_T_is_D": round(statistics.median(eta_d), 2),
    }


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table of docs/efficiency.md."""
    row = (
        "| {T} | {P} | {search} | {median_eta:.1f} | {min_eta:.1f} - {max_eta:.1f} | {best_seed} "
        "| {median_over_paper:.2f} | {in_range} | {polish_converged}/{seeds} "
        "| {median_T_over_W:.3f} | {median_P_per_mass:.1f} | {median_eta_T_is_D:.2f} |"
    )
    lines = [
        "| T | P | search | median η [%] | range [%] | best seed | median / 12.7 % "
        "| 12.7 % in range | polish converged | T/W | P/m [W/kg] | D·V/P [%] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
        *(
            f"| {r['T']} | {r['P']} | {r['search']} | no feasible seed |" + " |" * 8
            if r["median_eta"] is None
            else row.format(**r, in_range="yes" if r["paper_in_range"] else "no")
            for r in rows
        ),
    ]
    return "\n".join(lines)


def _meta(started: tuple[Any, float], scheduler: str | None) -> dict[str, Any]:
    """Date, machine, load and command of a run just finished (``started``: the load average and
    ``time.perf_counter()`` at its start); the docs quote them beside its numbers."""
    load_before, start = started
    return {
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "machine": f"{os.cpu_count()} CPU cores ({platform.machine()}), "
        f"Python {platform.python_version()}",
        "load_average_before": [round(x, 2) for x in load_before],
        "load_average_after": [round(x, 2) for x in os.getloadavg()],
        "command": " ".join(["python", *sys.argv]),
        "scheduler": scheduler or "serial",
        "wall_time_s": round(time.perf_counter() - start, 1),
    }


def claim_readings() -> tuple[Reading, ...]:
    """Part 3's readings: the default and hover-none, each as the preset searches and searched
    by each search reading."""
    return (
        DEFAULT,
        *PAPER_SEARCHES,
        HOVER_NONE,
        *(combine([HOVER_NONE, search]) for search in PAPER_SEARCHES),
    )


def claims(preset: str, out: Path, scheduler: str | None) -> int:
    """Part 3: the four studies' claims under :func:`claim_readings`; a search reading's claim
    is "moved" where its verdict differs from that of the same model searched as the preset
    searches."""
    where = out / f"claims-{preset}"
    started = os.getloadavg(), time.perf_counter()
    # continuation None: every reading searched from scratch (the search is what is read)
    options = {"derive": False, "scheduler": scheduler, "progress": False, "continuation": None}
    plan = StudyPlan(get_preset(preset))
    result = run_readings(plan, where, readings=claim_readings(), **options)
    meta = _meta(started, scheduler) | {"preset": preset}
    by_model = {json.dumps(r.reading.env_kwargs(), sort_keys=True): r for r in result.results}
    names = [r.reading.name for r in result.results]
    print(*table_head(["claim", "paper", *names]), sep="\n")
    rows = []
    for claim in result.results[0].claims:
        cells, moved = [], []
        for r in result.results:
            c = {x.id: x for x in r.claims}.get(claim.id)
            cells.append("no data" if c is None else f"{c.verdict} ({c.median:.3g}{c.unit})")
            base = by_model[json.dumps(r.reading.env_kwargs(), sort_keys=True)]
            searched = r.reading.search is not None and base.reading.search is None
            if searched and r.verdicts().get(claim.id) != base.verdicts().get(claim.id):
                moved.append(r.reading.name)
        rows.append({"claim": claim.id, "paper": claim.paper, "cells": cells, "moved_by": moved})
        print(table_row([claim.id, claim.paper, *cells]))
    counts = {r.reading.name: {"agree": r.agree, "differ": r.differ} for r in result.results}
    print("agree: " + ", ".join(f"{n} {c['agree']}" for n, c in counts.items()))
    print("differ: " + ", ".join(f"{n} {c['differ']}" for n, c in counts.items()))
    meta["runs"] = [s.to_dict() for s in result.runs]
    path = where / "efficiency_claims.json"
    write_json_atomic(path, {"meta": meta, "counts": counts, "claims": rows})
    print(f"{meta['wall_time_s']:.0f} s; wrote {path}", file=sys.stderr)
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=os.path.join("results", "efficiency"))
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(8)))
    parser.add_argument("--scheduler", help="as for python -m eval optimize, e.g. local:2")
    parser.add_argument(
        "--part", choices=("all", "certified", "search"), default="all", help="which part to run"
    )
    parser.add_argument(
        "--claims",
        metavar="PRESET",
        help="run part 3 instead: the studies' claims under the default and the search "
        "readings at this preset (quick or paper)",
    )
    args = parser.parse_args()
    if args.claims is not None:
        return claims(args.claims, Path(args.out), args.scheduler)
    wanted = {"all": (True, False), "certified": (True,), "search": (False,)}[args.part]
    prepared = {c: c.prepare(args.seeds) for c in cases() if (c.search == CERTIFIED) in wanted}
    started = os.getloadavg(), time.perf_counter()
    jobs = [p for group in prepared.values() for p in group]
    summary = run_jobs(jobs, args.out, scheduler=args.scheduler, progress=False)
    runs = {"runs": summary.total, "ran": summary.ran, "reused": summary.reused}
    meta = _meta(started, args.scheduler) | runs | {"speed": SPEED, "paper_eta": PAPER_ETA}
    rows = [summarise(c, [summary.records[p.job.key] for p in g]) for c, g in prepared.items()]
    print(table(rows))
    path = Path(args.out) / "efficiency_readings.json"
    if summary.ran == 0 and path.exists():  # nothing ran: keep the timing of the run that did
        before = read_json(path).get("meta", {})
        meta["measured_by"] = before.get("measured_by", before)
    write_json_atomic(path, {"meta": meta, "rows": rows})
    print(
        f"{summary.total} runs ({summary.ran} run, {summary.reused} reused) in "
        f"{meta['wall_time_s']:.0f} s; load {meta['load_average_before']} -> "
        f"{meta['load_average_after']}; wrote {path}",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
