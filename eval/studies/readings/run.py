"""Running the readings study's plan phase by phase, analysing each reading and writing its
outputs: readings.csv, the matrix figure, report.md and the manifest
(:mod:`eval.studies.readings`)."""

from __future__ import annotations

import math
import os
import statistics
import sys
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict
from datetime import datetime, timezone
from functools import partial
from pathlib import Path
from typing import Any

from agents.jobs import Job
from agents.progress import CommandProgress, Phase
from agents.record_cache import CacheOption
from agents.records import Record
from agents.runner import RunSummary, find_records, job_records, run_jobs
from agents.store import RECORDS_DIR
from eval.studies import PAPER_STUDIES, report
from eval.studies.base import StudyPlan
from eval.studies.paper_reading import DECISION_OPTIONS, DEFAULT, Reading
from eval.studies.readings.figure import matrix_figure
from eval.studies.readings.plan import (
    CHECK_CSV,
    CSV_COLUMNS,
    MANIFEST,
    PHASES,
    SINGLES,
    Continuation,
    Optima,
    ReadingsResult,
    check_jobs,
    combinations,
    full_tasks,
    optima_from,
    optima_of,
    reading_jobs,
    reading_plan,
    study_jobs,
)
from eval.studies.readings.report import write_readings_report
from eval.studies.readings.result import ReadingResult, reading_dir
from tandem_env.io.files import read_json, write_csv_atomic, write_json_atomic
from tandem_env.physics import N_PARAMETERS


def analyse_reading(
    plan: StudyPlan, reading: Reading, out_dir: Path, jobs: Mapping[str, Sequence[Job]]
) -> ReadingResult:
    """Analyse the four studies under ``reading`` (every record present) into its folder;
    ``jobs`` are each study's jobs (:func:`study_jobs`).

    The folder gets a relative link ``records -> ../records`` so the study indexes' record
    paths resolve, and its own ``report.md``.
    """
    p = reading_plan(plan, reading)
    where = reading_dir(out_dir, reading)
    where.mkdir(parents=True, exist_ok=True)
    link = where / RECORDS_DIR
    if not link.exists() and not link.is_symlink():
        try:
            link.symlink_to(Path("..") / RECORDS_DIR, target_is_directory=True)
        except OSError:  # no symlinks here (e.g. some Windows setups): the index paths dangle
            pass
    outputs = tuple(
        study.analyse(p, job_records(out_dir, jobs[name]), where)
        for name, study in PAPER_STUDIES.items()
    )
    report.write_report(where / "report.md", p, outputs, list(PAPER_STUDIES))
    return ReadingResult(reading, outputs)


#: The columns of continuation_check.csv, in order.
CHECK_COLUMNS: tuple[str, ...] = (
    "reading",
    "task",
    "objective",
    "condition",
    "seed",
    "budget_full",
    "budget_continued",
    "objective_full",
    "objective_continued",
    "feasible_full",
    "feasible_continued",
    "difference",
    "chosen",
)


def check_rows(
    records: Mapping[Job, Record], checks: Sequence[tuple[Reading, Job, Job]]
) -> list[dict[str, Any]]:
    """One row per checked job, from the checked jobs' ``records`` (job -> record): the
    continued and the full optimum (``difference`` = (continued − full) / |full| [-]) and which
    part the continued run reported."""
    rows = []
    for reading, c, f in checks:
        rc, rf = records[c].results, records[f].results
        oc, of = float(rc["objective"]), float(rf["objective"])
        rows.append(
            {
                "reading": reading.name,
                "task": f.task,
                "objective": rf["objective_name"],
                "condition": f.condition,
                "seed": f.seed,
                "budget_full": f.budget,
                "budget_continued": c.budget,
                "objective_full": of,
                "objective_continued": oc,
                "feasible_full": bool(rf["feasible"]),
                "feasible_continued": bool(rc["feasible"]),
                "difference": (oc - of) / abs(of) if of else math.nan,
                "chosen": rc["selection"],
            }
        )
    return rows


def check_summary(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per reading and task, and over all (last): the continuation's bias on the checked jobs
    (both feasible): pairs, median, lowest and highest relative difference, how many continued
    optima are within 0.5 % of the full run's or above it, the pairs with either infeasible, and
    those with only the continued one infeasible."""
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["reading"], row["task"]), []).append(row)
    if rows:  # the overall row last
        groups[("all", "all")] = list(rows)
    out = []
    for (reading, task), members in groups.items():
        values = [
            float(r["difference"])
            for r in members
            if r["feasible_full"] and r["feasible_continued"]
        ]
        out.append(
            {
                "reading": reading,
                "task": task,
                "pairs": len(values),
                "median": statistics.median(values) if values else math.nan,
                "lowest": min(values, default=math.nan),
                "highest": max(values, default=math.nan),
                "within_0.5%": sum(v >= -0.005 for v in values),
                "infeasible": len(members) - len(values),
                "infeasible_continued": sum(
                    bool(r["feasible_full"]) and not r["feasible_continued"] for r in members
                ),
            }
        )
    return out


def _earlier_invocations(out_dir: Path, plan: StudyPlan) -> list[dict[str, Any]]:
    """The invocations into ``out_dir`` at this preset its manifest records: a resumed run (or
    one that only redraws the outputs) keeps their work and times. A manifest written before
    invocations were recorded (no ``invocations``) gives its one run, with the phases named in
    order. Says so (stderr) when ``out_dir`` holds another preset's readings, which are
    replaced."""
    try:
        before = read_json(out_dir / MANIFEST)
    except (FileNotFoundError, ValueError):
        return []
    if not isinstance(before, Mapping) or before.get("preset") is None:
        return []
    if before["preset"] != plan.preset.name:
        print(
            f"note: {out_dir} holds the {before['preset']!r} preset's readings; its readings.csv, "
            f"matrix and report are replaced by the {plan.preset.name!r} preset's (the records "
            "of both stay: they are keyed by preset). Use --out for a separate folder.",
            file=sys.stderr,
        )
        return []
    earlier = list(before.get("invocations", ()))
    if earlier or "phases" not in before:
        return earlier
    names = PHASES[2:] if before.get("continuation") is None else PHASES
    phases = [{"name": name, **phase} for name, phase in zip(names, before["phases"], strict=False)]
    return [{"finished": None, "phases": phases, "wall_time_s": before.get("wall_time_s")}]


def _load() -> float | None:
    """The 1-minute load average (None where the system has none)."""
    return round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else None


#: What the readings study's plan cannot count before its singles are analysed.
COMBINATIONS_LATER = "the combinations the singles' results point to (counted once known)"

ByReading = Mapping[Reading, Mapping[str, Sequence[Job]]]
"""Readings and each one's jobs by study name (:func:`study_jobs`)."""


def _flat(jobs: Iterable[Mapping[str, Sequence[Job]]]) -> tuple[Job, ...]:
    return tuple(job for by_study in jobs for group in by_study.values() for job in group)


def _phases(
    plan: StudyPlan,
    readings: Sequence[Reading],
    continuation: Continuation | None,
    records: Callable[[Sequence[Job]], Mapping[Job, Record] | None],
    each: Callable[[Phase, ByReading], None],
) -> tuple[dict[str, dict[str, list[Job]]], list[dict[str, Any]], dict[str, dict[str, str]]]:
    """The phases of :func:`run_readings` before the combinations, in order: each goes to
    ``each`` with the readings whose jobs it completes (the run runs it there, the plan only
    collects it); then ``records`` gives its records if the next phases depend on them (None
    when some are missing: those phases get stand-ins at the right budgets,
    :class:`~agents.progress.Phase`, their keys provisional, and the singles are planned as if no
    task ran in full). Returns every reading's jobs (reading name -> study -> jobs), the bias
    check's rows (:func:`check_rows`) and the tasks run in full (:func:`full_tasks`)."""
    if continuation is None:
        jobs = {r.name: study_jobs(plan, r) for r in readings}
        each(Phase(PHASES[2], _flat(jobs.values())), {r: jobs[r.name] for r in readings})
        return jobs, [], {}
    # the default first: the others start from its optima
    jobs = {DEFAULT.name: study_jobs(plan, DEFAULT)}
    default = Phase(PHASES[0], _flat(jobs.values()))
    each(default, {DEFAULT: jobs[DEFAULT.name]})
    found = records(default.jobs)
    if found is None:  # stand-in optima: the jobs' budgets are right, their keys not final
        optima: Optima = {
            DEFAULT.name: {
                name: [[0.0] * N_PARAMETERS] * len(group)
                for name, group in jobs[DEFAULT.name].items()
            }
        }
    else:
        optima = optima_from(found, jobs)
    # the bias check, then each single reading: a task the check fails runs in full
    others = readings[1:]
    checks = [(r, c, f) for r in others for c, f in check_jobs(plan, r, continuation, optima)]
    check = tuple(dict.fromkeys(job for _, c, f in checks for job in (c, f)))
    stand_ins = frozenset(c.key for _, c, _ in checks) if found is None else frozenset()
    each(Phase(PHASES[1], check, stand_ins), {})
    rows: list[dict[str, Any]] = []  # one per checked job
    if found is not None and checks and (done := records(check)):
        rows = check_rows(done, checks)
    full = full_tasks(check_summary(rows), continuation)
    jobs |= {
        r.name: study_jobs(plan, r, continuation, optima, full.get(r.name, {})) for r in others
    }
    singles = _flat(jobs[r.name] for r in others)
    own = {job.key for r in others for job in reading_jobs(plan, r)}
    stand_ins = frozenset(j.key for j in singles if j.key not in own) if found is None else None
    each(Phase(PHASES[2], singles, stand_ins or frozenset()), {r: jobs[r.name] for r in others})
    return jobs, rows, full


def planned_phases(
    plan: StudyPlan,
    out_dir: str | os.PathLike[str],
    readings: Sequence[Reading] = SINGLES,
    continuation: Continuation | None = Continuation(),
    cache: CacheOption = True,
) -> list[Phase]:
    """The phases of :func:`run_readings` before the combinations, as far as the records in
    ``out_dir`` and the record cache decide them now (nothing is written or run; stand-ins
    where they do not: :func:`_phases`)."""
    phases: list[Phase] = []
    records = partial(find_records, out_dir, cache=cache)
    _phases(plan, readings, continuation, records, lambda phase, _: phases.append(phase))
    return phases


def run_readings(
    plan: StudyPlan,
    out_dir: str | os.PathLike[str],
    *,
    readings: Sequence[Reading] = SINGLES,
    derive: bool = True,
    scheduler: str | None = None,
    progress: bool = True,
    continuation: Continuation | None = Continuation(),
    cache: CacheOption = True,
    command: CommandProgress | None = None,
) -> ReadingsResult:
    """Run the readings study into ``out_dir``: the ``readings`` (singles; the default first),
    then, if ``derive``, the combinations their results point to (:func:`combinations`).

    With ``continuation`` (the default; None runs every reading in full) the default reading
    runs first and the others continue from its optima (:class:`Continuation`), with the bias
    check on the singles.

    ``plan`` gives the preset and methods (its own reading is ignored). ``scheduler`` and
    ``cache`` (the record cache) as for :func:`agents.runner.run_jobs`. ``command`` (the
    command's progress, :class:`~agents.progress.CommandProgress`) is re-planned
    (:func:`planned_phases`) and told at each phase's start. Raises ValueError if ``readings``
    does not start with the default reading or repeats a name.
    """
    started = time.perf_counter()
    out = Path(out_dir)
    readings = tuple(readings)
    if not readings or readings[0] != DEFAULT:
        raise ValueError(
            f"readings = {[r.name for r in readings]}; allowed: the default reading first, "
            "then others (their claims are compared with the default's)"
        )
    names = [r.name for r in readings]
    if len(set(names)) != len(names):
        raise ValueError(f"readings = {names}; allowed: distinct names")
    earlier = _earlier_invocations(out, plan)
    load_before = _load()
    runs: dict[str, RunSummary] = {}  # by phase name
    results: list[ReadingResult] = []

    def run_phase(phase: Phase, chosen: ByReading) -> None:
        """Run the phase's jobs in one call, and analyse the readings ``chosen``."""
        runs[phase.name] = run_jobs(
            phase.jobs, out, scheduler=scheduler, progress=progress, cache=cache, command=command
        )
        for reading, jobs in chosen.items():
            if progress:
                print(f"analysing reading {reading.name}", file=sys.stderr)
            results.append(analyse_reading(plan, reading, out, jobs))

    def start(phase: Phase, chosen: ByReading) -> None:
        # The whole command again, from what the records decide now.
        if command is not None:
            command.plan(planned_phases(plan, out, readings, continuation, cache))
            command.start(phase.name)
        run_phase(phase, chosen)

    jobs, rows, full = _phases(plan, readings, continuation, partial(job_records, out), start)
    words = "not derived (derive=False)"
    if derive:
        derived, words = combinations(results[0], results)
        derived = [r for r in derived if r.name not in names]
        if command is not None:
            command.plan([], later="")  # the combinations are known now
        if derived:
            optima = None if continuation is None else optima_of(out, jobs)
            jobs |= {r.name: study_jobs(plan, r, continuation, optima) for r in derived}
            phase = Phase(PHASES[3], _flat(jobs[r.name] for r in derived))
            if command is not None:
                command.plan([phase])
                command.start(phase.name)
            run_phase(phase, {r: jobs[r.name] for r in derived})
    if rows:
        write_csv_atomic(out / CHECK_CSV, rows)
    summary = check_summary(rows)
    files = write_outputs(plan, results, words, out, summary, continuation, full)
    wall = time.perf_counter() - started
    this = {
        "finished": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "cpus": os.cpu_count(),
        "load_average_1min": [load_before, _load()],
        "phases": [{"name": name, **run.to_dict()} for name, run in runs.items()],
        "wall_time_s": round(wall, 1),
    }
    write_json_atomic(
        out / MANIFEST,
        {
            "preset": plan.preset.name,
            "methods": list(plan.methods),
            "claims": [
                {"id": c.id, "statement": c.statement, "paper": c.paper} for c in results[0].claims
            ],
            "readings": [
                {
                    "name": r.reading.name,
                    "changes": r.reading.changes(),
                    "agree": r.agree,
                    "verdicts": r.verdicts(),
                }
                for r in results
            ],
            "combination_rule": words,
            "continuation": None if continuation is None else asdict(continuation),
            "continuation_check": summary,
            "run_in_full": full,
            "invocations": [*earlier, this],
        },
    )
    return ReadingsResult(
        tuple(results), tuple(runs.values()), words, tuple(files), wall, tuple(runs)
    )


def csv_rows(results: Sequence[ReadingResult]) -> list[dict[str, Any]]:
    """One row per reading (:data:`CSV_COLUMNS`)."""
    rows = []
    for r in results:
        options = r.reading.model_options
        c_r = r.reading.rotational_coefficient
        row: dict[str, Any] = {
            "reading": r.reading.name,
            "kind": "combination" if r.reading.derived_from else "single",
            "changes": r.reading.describe_changes(),
            **{name: getattr(options, name) for name in DECISION_OPTIONS},
            "rotational_coefficient": math.pi if c_r is None else float(c_r),
            "horizontal_objective": r.reading.horizontal_objective,
            "search": "" if r.reading.search is None else r.reading.search.describe(),
            **asdict(r.counts),
            **{k: v if math.isnan(v) else float(f"{v:.4g}") for k, v in r.headline().items()},
            "description": r.reading.description,
        }
        rows.append({k: row[k] for k in CSV_COLUMNS})
    return rows


def write_outputs(
    plan: StudyPlan,
    results: Sequence[ReadingResult],
    rule: str,
    out_dir: Path,
    check: Sequence[Mapping[str, Any]] = (),
    continuation: Continuation | None = None,
    full: Mapping[str, Mapping[str, str]] | None = None,
) -> list[Path]:
    """readings.csv, readings_matrix.<format> and report.md (:func:`write_readings_report`
    says what ``check``, ``continuation`` and ``full`` are)."""
    csv_path = out_dir / "readings.csv"
    write_csv_atomic(csv_path, csv_rows(results))
    claims = results[0].claims
    columns = [
        (r.reading.name, [r.verdicts().get(c.id, "no data") for c in claims]) for r in results
    ]
    figure = matrix_figure(
        [c.id for c in claims],
        [c.statement for c in claims],
        columns,
        plan.figure(out_dir, "readings_matrix"),
        f"Paper claims under each reading ({plan.preset.name} preset, {', '.join(plan.methods)})",
        split=next((k for k, r in enumerate(results) if r.reading.derived_from), None),
    )
    report_path = write_readings_report(
        out_dir / "report.md", plan, results, rule, csv_path, figure, check, continuation, full
    )
    return [csv_path, figure, report_path]
