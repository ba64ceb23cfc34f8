"""``python -m eval reference``: make the reference table of certified optima.

A plan of the resumable runner (:class:`ReferencePlan`, :func:`agents.runner.run_plan`: records
in ``--out``, here or on Dask, a killed run resumes): the *search* (:func:`plan`: per point of
:data:`tandem_env.envs.reference.REFERENCE_GRID`, objective, planform and seed), then the rounds
of :data:`CONTINUATION`. Per point, the best stroke competing for it (:func:`_pool`) is written
with its provenance to the packaged table (or ``--table``, :func:`build_table`), a figure and a
Markdown table to ``--out``. The method and the table: docs/reference.md.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import sys
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import product
from pathlib import Path
from typing import Any

import numpy as np

import tandem_env
from agents import verify
from agents.harness import PreparedJob, prepare
from agents.jobs import Continuation, Job
from agents.progress import CommandProgress, Phase
from agents.records import Record, package_versions
from agents.runner import Lookup, look_ahead, run_plan
from agents.selection import best_index
from agents.store import RecordStore, read_record_files
from agents.tasks import get_task, task_of
from eval.optimize import add_run_arguments, run_options, run_reporting
from eval.studies.report import table_head, table_row
from tandem_env.envs.reference import (
    REFERENCE_FORMAT,
    REFERENCE_GRID,
    config_fingerprint,
    problem_fingerprint,
    reference_path,
)
from tandem_env.envs.registration import config_class
from tandem_env.io.files import write_json_atomic, write_text_atomic
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

PointKey = tuple[str, str, str, float]
"""(env id, objective, planform, condition) of a grid point."""
Jobs = Mapping[PointKey, Sequence[PreparedJob]]
"""A point's jobs (one per seed) per grid point, as :func:`plan` makes them."""
Found = Mapping[PointKey, Sequence[Record]]
"""Records per grid point."""
Rounds = Sequence[Mapping[PointKey, Job]]
"""The continuation rounds' jobs, a job per point each."""


def plan(
    seeds: Sequence[int] = SEEDS,
    budgets: Mapping[str, int] = BUDGETS,
    grid: Mapping[str, tuple[tuple[str, ...], tuple[float, ...]]] = REFERENCE_GRID,
    env_kwargs: Mapping[str, Any] | None = None,
) -> dict[PointKey, list[PreparedJob]]:
    """The jobs of the table: per (env id, objective, planform, condition), one per seed."""
    jobs: dict[PointKey, list[PreparedJob]] = {}
    for env_id, (objectives, conditions) in grid.items():
        task = get_task(task_of(env_id))
        for objective, planform, condition in product(objectives, PLANFORMS, conditions):
            key = (env_id, objective, planform, condition)
            options = {"env_kwargs": {"planform": planform, **(env_kwargs or {})}, "preset": PRESET}
            options["objective"] = objective if task.declared_objectives.keyword else None
            jobs[key] = prepare(METHOD, task, condition, budgets[env_id], seeds, **options)
    return jobs


#: Tasks whose feasible set grows with the condition: the available power only caps P/m, so a
#: stroke that flies at P_avail flies, with the same forces, at every higher P_avail, and a
#: stroke found for one objective is a candidate for the others (the same constraints).
NESTED_TASKS: frozenset[str] = frozenset({"TandemWing/Accelerate-v0"})
#: A round "raises" a point when it gains more than this [%] (smaller gains are the polish's
#: last digits, not a better optimum).
RAISED_PERCENT = 0.1
#: The continuation (:class:`agents.jobs.Continuation`; the table says whether the last round
#: still moved a point).
CONTINUATION = Continuation(
    share=0.5, initial_share=0.75, starts=None, rounds=15, until=RAISED_PERCENT
)


def _value(record: Record, env_id: str, objective: str) -> float:
    """The record's stroke's value of ``objective`` (its own objective or another metric)."""
    objectives = config_class(env_id).OBJECTIVES
    assert objectives is not None
    return float(record.metrics[str(objectives.metrics[objective])])


def _best(records: Sequence[Record], env_id: str, objective: str) -> Record:
    """The best stroke for ``objective`` by the harness's rule (feasible first, then higher)."""
    values = [_value(r, env_id, objective) for r in records]
    return records[best_index([r.feasible for r in records], values)]


def continuation(
    jobs: Jobs, found: Found | None, index: int = 0, rule: Continuation = CONTINUATION
) -> dict[PointKey, Job]:
    """Continuation round ``index`` (0, 1, ...): per point, one job of ``rule`` warm-started from
    the best strokes ``found`` at this point, its grid neighbours and, for a task in
    :data:`NESTED_TASKS`, the other objectives here; stand-ins where ``found`` is None."""
    best = {key: _best(list(records), key[0], key[1]) for key, records in (found or {}).items()}
    continued = {}
    for key, prepared in jobs.items():
        env_id, objective, planform, condition = key
        objectives, grid = REFERENCE_GRID[env_id]
        i = grid.index(condition)
        sources = [key] + [
            (env_id, objective, planform, grid[j]) for j in (i - 1, i + 1) if 0 <= j < len(grid)
        ]
        if env_id in NESTED_TASKS:
            sources += [(env_id, o, planform, condition) for o in objectives if o != objective]
        strokes = [*dict.fromkeys(tuple(best[k].normalised_stroke) for k in sources if k in best)]
        continued[key] = rule.job(prepared[0].job, strokes if found is not None else None, index)
    return continued


@dataclass(eq=False)
class ReferencePlan:
    """The table's phases (an :class:`agents.runner.Plan`): the search, then the rounds of
    ``rule`` until it stops. Running, it keeps the rounds' jobs (:attr:`rounds`) and gains
    (:attr:`convergence`), said on stderr unless ``quiet``."""

    jobs: Jobs
    rule: Continuation = CONTINUATION
    quiet: bool = True
    rounds: list[dict[PointKey, Job]] = field(default_factory=list, init=False)
    convergence: list[dict[str, Any]] = field(default_factory=list, init=False)

    def __call__(self, found: Lookup) -> Iterator[Phase]:
        """The phases, each round's jobs from the optima before it."""
        jobs = self.jobs
        search = tuple(p.job for prepared in jobs.values() for p in prepared)
        yield Phase("search", search)
        records = found(search)
        by_key = {} if records is None else {j.key: r for j, r in records.items()}
        rounds: list[dict[PointKey, Job]] = []
        for index in range(self.rule.rounds):
            name = f"continuation {index + 1}"
            known = None if records is None else gather(jobs, rounds, by_key)
            continued = continuation(jobs, known, index, self.rule)
            stand_ins = frozenset(j.key for j in continued.values() if known is None)
            yield Phase(name, tuple(continued.values()), stand_ins)
            records = None if known is None else found(continued.values())
            if known is None or records is None:
                continue
            rounds.append(continued)
            by_key |= {j.key: r for j, r in records.items()}
            after = best_objectives(gather(jobs, rounds, by_key))
            gains = round_gains(best_objectives(known), after)
            if found.running:
                self.rounds = rounds
                self.convergence.append({"round": index + 1, **gains})
                if not self.quiet:
                    print(
                        f"reference: {name} raised {gains['points_raised']} of {len(jobs)} "
                        f"points, by at most {gains['largest_gain_percent']:.2f} %",
                        file=sys.stderr,
                    )
            if self.rule.stops(gains["largest_gain_percent"]):
                return


def _pool(found: Found, key: PointKey) -> list[Record]:
    """The strokes that compete for ``key``: its own and, for a task in :data:`NESTED_TASKS`,
    every stroke found at a lower or equal condition for any objective (same planform)."""
    env_id, _, planform, condition = key
    if env_id not in NESTED_TASKS:
        return list(found[key])
    keys = [k for k in found if (k[0], k[2]) == (env_id, planform) and k[3] <= condition]
    return [r for k in keys for r in found[k]]


def best_objectives(found: Found) -> dict[PointKey, float]:
    """Each point's best feasible objective among what competes for it (NaN: none flies)."""
    best = {key: _best(_pool(found, key), key[0], key[1]) for key in found}
    return {k: _value(b, k[0], k[1]) if b.feasible else float("nan") for k, b in best.items()}


def round_gains(
    before: Mapping[PointKey, float], after: Mapping[PointKey, float]
) -> dict[str, Any]:
    """How much a continuation round raised the points: how many by more than
    :data:`RAISED_PERCENT`, the largest and the median relative gain [%]."""
    gains = [100 * (after[k] / before[k] - 1) for k in before if before[k] > 0]
    raised = [g for g in gains if g > RAISED_PERCENT]
    return {
        "points_raised": len(raised),
        "largest_gain_percent": round(max(gains, default=0.0), 3),
        "median_gain_percent": round(float(np.median(gains)) if gains else 0.0, 4),
    }


#: What the table keeps of each best stroke's certificate.
CERTIFICATE_KEYS = ("method", "status", "gain", "objective_before")


def _point(
    key: PointKey,
    search: Sequence[Record],
    rounds: Sequence[Record],
    found: Found,
    candidates: Sequence[Record] = (),
) -> dict[str, Any]:
    """One grid point: the best stroke competing for it (:func:`_pool`)."""
    env_id, objective, _, condition = key
    best = _best(_pool(found, key), env_id, objective)
    if best in search:
        source = f"seed {best.seed}"
    elif best in rounds:
        source = f"continuation round {list(rounds).index(best) + 1}"
    elif best in candidates:
        source = (
            f"candidate: {best.job.method}, seed {best.seed}, budget {best.budget}, at "
            f"{best.job.condition:g} (record {best.key})"
        )
    else:
        source = f"{best.job.env('objective', objective)} optimum at {best.job.condition:g}"
    return {
        "condition": condition,
        "objective": _value(best, env_id, objective) if best.feasible else float("nan"),
        "feasible": bool(best.feasible),
        "source": source,
        "seed_objectives": [r.objective if r.feasible else None for r in search],
        "continued_objectives": [r.objective if r.feasible else None for r in rounds],
        "candidate_objectives": [
            _value(r, env_id, objective) if r.feasible else None
            for r in found[key][len(search) + len(rounds) :]
        ],
        "normalised_stroke": list(best.normalised_stroke),
        "certificate": {k: best.certificate.get(k) for k in CERTIFICATE_KEYS},
        "record_key": best.key,
    }


def gather(
    jobs: Jobs, rounds: Rounds, records: Mapping[str, Record]
) -> dict[PointKey, list[Record]]:
    """Every record of each point: its seeds' then its continuation rounds'."""
    return {
        key: [records[p.job.key] for p in prepared] + [records[r[key].key] for r in rounds]
        for key, prepared in jobs.items()
    }


def build_table(
    jobs: Jobs,
    rounds: Rounds,
    records: Mapping[str, Record],
    provenance: Mapping[str, Any],
    candidates: Found | None = None,
) -> dict[str, Any]:
    """The reference table (format :data:`REFERENCE_FORMAT`) from every phase's records and
    the ``candidates`` (:func:`candidates`) competing beside them."""
    found = gather(jobs, rounds, records)
    ours = {key: len(mine) for key, mine in found.items()}
    for key, extra in (candidates or {}).items():
        found[key] += extra
    every_candidate = [r for extra in (candidates or {}).values() for r in extra]
    series: dict[tuple[str, str, str], list[dict[str, Any]]] = {}
    fingerprints: dict[tuple[str, str, str], set[str]] = {}
    seeds = len(next(iter(jobs.values())))
    for key, mine in found.items():
        search, rounds_ = mine[:seeds], mine[seeds : ours[key]]
        point = _point(key, search, rounds_, found, every_candidate)
        series.setdefault(key[:3], []).append(point)
        fingerprints.setdefault(key[:3], set()).update(
            config_fingerprint(config_class(key[0]), r.results["env"]) for r in mine
        )
    for name, seen in fingerprints.items():
        if len(seen) != 1:  # the plan gives every job of a series the same env keywords
            raise ValueError(f"the records of {name} were made with {len(seen)} configurations")
    return {
        "format": REFERENCE_FORMAT,
        "provenance": {**provenance, "candidates": sorted({r.key for r in every_candidate})},
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


def candidates(records: Iterable[Record], jobs: Jobs) -> dict[PointKey, list[Record]]:
    """Strokes of other runs (``--candidates``, docs/reference.md; any method: a policy's, a
    study's) per grid point they compete for: a feasible record of the table's env at a grid
    condition, of the problem of one of the table's series there (its fingerprint: the same
    model, insect and planform), competes for every objective of that planform. It must be this
    model's (its revision, :attr:`~agents.records.Record.model`), its stroke must replay,
    through the env, to its record (:func:`agents.verify.refuted`, as every reused record does)
    and fly; any other record is refused (ValueError)."""
    configs = {
        k: config_class(k[0]).from_kwargs(**dict(p[0].job.env_kwargs)) for k, p in jobs.items()
    }
    fingerprints = {key: problem_fingerprint(config) for key, config in configs.items()}
    kept: dict[PointKey, list[Record]] = {}
    revision = tandem_env.physics.MODEL_REVISION
    for record in records:
        env_id, condition = record.env_id, record.job.condition
        mine = config_fingerprint(config_class(env_id), record.results["env"])
        keys = [k for k in jobs if (k[0], k[3]) == (env_id, condition) and fingerprints[k] == mine]
        why = (
            f"it was made by model revision {record.model}, not this model's {revision} "
            "(tandem_env.physics.MODEL_REVISION): rerun it"
            if record.model != revision
            else "it does not fly"
            if not record.feasible
            else f"no series of the table at {env_id} {condition:g} with its model and insect"
            if not keys
            else None
        )
        if why is None and (
            refuted := verify.refuted({record.key: record}, {record.key: record.job})
        ):
            why = f"its stroke does not replay to its record ({refuted[record.key]})"
        if why is not None:
            raise ValueError(
                f"candidate record {record.key} ({record.job.label()}): {why}; allowed: a "
                "feasible record of the table's env and model at a grid condition"
            )
        for key in keys:
            kept.setdefault(key, []).append(record)
    return kept


def add_arguments(parser: argparse.ArgumentParser) -> None:
    text = f"the optimisations' records, figure and table (default {DEFAULT_OUT})"
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=text)
    text = "where the table goes (default: the packaged tandem_env/data/reference_optima.json)"
    parser.add_argument("--table", type=Path, default=None, help=text)
    text = (
        "record files or folders of other runs (e.g. eval optimize --out) whose strokes "
        "compete for the table's points, with their provenance (docs/reference.md)"
    )
    parser.add_argument("--candidates", type=Path, nargs="+", default=[], metavar="PATH", help=text)
    add_run_arguments(parser, "--scheduler", "--no-cache", "--rerun", "--quiet")


def provenance(
    jobs: Iterable[Job],
    records: Mapping[str, Record],
    convergence: Sequence[Mapping[str, Any]] = (),
    seeds: Sequence[int] = SEEDS,
) -> dict[str, Any]:
    """How the table was made: command, date, versions, method, budgets, the search's seeds,
    the optimisations' summed wall time [s] (as their records say) and the continuation."""
    jobs = list(jobs)
    return {
        # where it ran (--scheduler, --out) does not change the table
        "command": f"python -m eval {NAME}",
        "date": dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "versions": package_versions(),
        "method": METHOD,
        "budgets": dict(BUDGETS),
        "seeds": list(seeds),
        "optimisations": len(jobs),
        "optimisation_seconds": round(sum(records[job.key].wall_time for job in jobs), 1),
        "continuation": (
            f"{len(convergence)} rounds (until one raised no point by more than "
            f"{CONTINUATION.until:g} %, at most {CONTINUATION.rounds}), each on "
            f"{CONTINUATION.share:g} of the budget, "
            f"{CONTINUATION.initial_share:g} of that for the warm starts (this point's, its "
            "neighbours' and, accelerating, the other objectives' best strokes)"
        ),
        "convergence": [dict(c) for c in convergence],
        "raised_percent": RAISED_PERCENT,
        "selection": (
            "per point, the best of its seeds and continuation (and, accelerating, of every "
            "stroke found at a lower or equal P_avail for any objective): feasible first, then "
            "the higher objective"
        ),
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
    try:  # checked before any optimisation
        extra = candidates(read_record_files(args.candidates), jobs)
    except ValueError as error:  # a RecordError too
        parser.error(f"--candidates: {error}")
    table_plan = ReferencePlan(jobs, quiet=args.quiet)
    try:
        store = RecordStore(args.out)
    except ValueError as error:
        parser.error(str(error))
    title = f"{NAME} (the reference table -> {table_path})"
    detail = f"{METHOD}, {len(jobs)} grid points"
    command = CommandProgress(
        title, store, cache=args.cache, enabled=not args.quiet, detail=detail, rerun=args.rerun
    )
    command.announce(look_ahead(table_plan, store, args.cache))
    options = dict(run_options(args), command=command, summary_csv=True)
    run = run_reporting(parser, lambda: run_plan(table_plan, store, **options))
    if isinstance(run, int):
        return run
    rounds = table_plan.rounds
    every = [p.job for prepared in jobs.values() for p in prepared]
    every += [job for r in rounds for job in r.values()]
    made = provenance(every, run.records, table_plan.convergence)
    table = build_table(jobs, rounds, run.records, made, extra)
    write_json_atomic(table_path, table)
    # The table as people read it: Markdown (OUT/reference.md) and a figure (OUT/reference.png).
    write_text_atomic(Path(args.out) / "reference.md", reference_markdown(table))
    write_reference_figure(table, Path(args.out) / "reference.png")
    for series in table["series"]:
        if weak := [p for p in series["points"] if not p["feasible"]]:
            print(
                f"warning: {series['env_id']} {series['objective']} {series['planform']}: no "
                f"feasible optimum at {[p['condition'] for p in weak]}",
                file=sys.stderr,
            )
    print(f"reference: {len(every)} optimisations; table written to {table_path}", file=sys.stderr)
    return 0


# Okabe-Ito colours, one per objective (readable in colour-blind vision and in grey).
_COLOURS = dict(efficiency="#0072B2", vertical="#0072B2", horizontal="#D55E00", resultant="#009E73")


def _condition_header(env_id: str) -> str:
    condition = config_class(env_id).CONDITION
    assert condition is not None
    return f"{condition.symbol} [{condition.unit}]"


def _spread(point: Mapping[str, Any]) -> str:
    if not (values := [v for v in point["seed_objectives"] if v is not None]):
        return "none feasible"
    return f"{min(values):.4g}-{max(values):.4g} ({len(values)}/{len(point['seed_objectives'])})"


def reference_markdown(table: Mapping[str, Any]) -> str:
    """One table per task: the optimum of each objective and planform at each condition, with
    the range of the search's seeds' feasible optima (how many seeds found a feasible stroke)."""
    by_env: dict[str, list[Mapping[str, Any]]] = {}
    for series in table["series"]:
        by_env.setdefault(series["env_id"], []).append(series)
    parts = []
    for env_id, series_list in by_env.items():
        columns = [f"{s['objective']}, {s['planform']}" for s in series_list]
        lines = table_head([_condition_header(env_id), *(t for c in columns for t in (c, "seeds"))])
        for i, point in enumerate(series_list[0]["points"]):
            cells = [f"{point['condition']:g}"]
            for s in series_list:
                p = s["points"][i]
                cells += [f"{p['objective']:.4g}" if p["feasible"] else "-", _spread(p)]
            lines.append(table_row(cells))
        parts.append(f"**{env_id}**\n\n" + "\n".join(lines) + "\n")
    provenance = table["provenance"]
    budgets = ", ".join(
        f"{env_id.split('/')[-1]} {budget:,}" for env_id, budget in provenance["budgets"].items()
    )
    hours = provenance["optimisation_seconds"] / 3600
    parts.append(
        f"Made by `{provenance['command']}` on {provenance['date']} (tandem_env "
        f"{provenance['versions']['tandem_env']}): {provenance['method']}, seeds "
        f"{provenance['seeds']}, budgets {budgets} evaluations, then continuation: "
        f"{provenance['continuation']}; {provenance['optimisations']} optimisations, "
        f"{hours:.2f} h of one core's time in all (their records' wall times summed). "
        + " ".join(
            f"Continuation round {c['round']} raised {c['points_raised']} of the points by more "
            f"than {provenance['raised_percent']:g} %, by at most {c['largest_gain_percent']:.2f} % (median "
            f"{c['median_gain_percent']:.3f} %)."
            for c in provenance["convergence"]
        )
        + _absorbed(table)
        + "\n"
    )
    return "\n".join(parts)


def _absorbed(table: Mapping[str, Any]) -> str:
    """What the candidates (``--candidates``) raised: the points whose best stroke is one, and
    by how much above the table's own seeds and rounds [%]."""
    raised = [
        (s["objective"], s["planform"], p["condition"], 100 * (p["objective"] / own - 1))
        for s in table["series"]
        for p in s["points"]
        if p["source"].startswith("candidate")
        if (own := max(v for v in (*p["seed_objectives"], *p["continued_objectives"]) if v))
    ]
    if not table["provenance"].get("candidates"):
        return ""
    listed = ", ".join(f"{o} {f} at {c:g} (+{g:.3f} %)" for o, f, c, g in raised) or "none"
    return (
        f" Candidates: {len(table['provenance']['candidates'])} strokes of other runs "
        f"(`--candidates`); the best at {len(raised)} points: {listed}."
    )


def write_reference_figure(table: Mapping[str, Any], path: Path) -> None:
    """The optima against the condition: one panel per task, a line per objective and
    planform (solid tear-drop, dashed real), every seed's feasible optimum as a faint dot."""
    from eval.figures import PLANFORM_VARIANT, VARIANT_LINES, plt, save

    env_ids = list(dict.fromkeys(s["env_id"] for s in table["series"]))
    fig, axes = plt.subplots(1, len(env_ids), figsize=(5.2 * len(env_ids), 3.8), squeeze=False)
    for ax, env_id in zip(axes[0], env_ids, strict=True):
        objectives = config_class(env_id).OBJECTIVES
        assert objectives is not None
        for series in (s for s in table["series"] if s["env_id"] == env_id):
            colour = _COLOURS.get(series["objective"], "#000000")
            points = [p for p in series["points"] if p["feasible"]]
            x, y = ([p[k] for p in points] for k in ("condition", "objective"))
            line = VARIANT_LINES[PLANFORM_VARIANT.get(series["planform"], 2)]  # as Figs. 15-16
            label = f"{series['objective']}, {series['planform']}"
            ax.plot(x, y, line, color=colour, marker="o", markersize=3, label=label)
            for p in series["points"]:
                seeds = [v for v in p["seed_objectives"] if v is not None]
                ax.plot([p["condition"]] * len(seeds), seeds, ".", color=colour, alpha=0.25)
        ax.set(xlabel=_condition_header(env_id), ylabel=f"reference objective [{objectives.unit}]")
        ax.set_title(env_id.split("/")[-1])
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    save(fig, path)  # atomically, its folder created
