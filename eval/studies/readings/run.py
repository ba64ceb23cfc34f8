"""The readings study's plan run phase by phase, each reading analysed, its outputs
(readings.csv, the matrix figure, report.md, the manifest) and its campaign of the command line
(:data:`READINGS`, with its ``--continuation`` option)."""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import statistics
import sys
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from agents.harness import prepare_job
from agents.jobs import Job
from agents.progress import CommandProgress, Phase
from agents.record_cache import CacheOption
from agents.runner import Lookup, PlanRun, job_records, run_plan
from agents.store import RECORDS_DIR, RecordStore
from eval.studies import PAPER_STUDIES, report
from eval.studies.base import Records, StudyPlan
from eval.studies.claims import VerdictCount
from eval.studies.paper_reading import DECISION_OPTIONS, DEFAULT, Reading
from eval.studies.readings import plan as rp
from eval.studies.readings.report import matrix_figure, write_readings_report
from eval.studies.tables import Rows
from tandem_env.io.files import read_json, write_csv_atomic, write_json_atomic

#: The columns of continuation_check.csv, in order.
CHECK_COLUMNS: tuple[str, ...] = tuple(
    "reading task objective condition seed budget_full budget_continued objective_full "
    "objective_continued feasible_full feasible_continued difference chosen".split()
)


def check_rows(records: Records, checks: Sequence[tuple[Reading, Job, Job]]) -> Rows:
    """One row per checked pair: the continued and the full optimum (``difference`` =
    (continued − full) / |full| [-]) and which part the continued run reported."""
    rows = []
    for reading, c, f in checks:
        rc, rf = records[c].results, records[f].results
        oc, of = float(rc["objective"]), float(rf["objective"])
        values = (reading.name, f.task, rf["objective_name"], f.condition, f.seed, f.budget)
        feasible = (bool(rf["feasible"]), bool(rc["feasible"]))
        difference = (oc - of) / abs(of) if of else math.nan
        row = (*values, c.budget, of, oc, *feasible, difference, rc["selection"])
        rows.append(dict(zip(CHECK_COLUMNS, row, strict=True)))
    return rows


def check_summary(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per reading and task, and over all (last): the continuation's bias on the checked pairs
    (both feasible; :data:`CHECK_COLUMNS` says what each column is)."""
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["reading"], row["task"]), []).append(row)
    if rows:  # the overall row last
        groups[("all", "all")] = list(rows)
    out = []
    for (reading, task), members in groups.items():
        both = [r for r in members if r["feasible_full"] and r["feasible_continued"]]
        values = [float(r["difference"]) for r in both]
        lost = sum(bool(r["feasible_full"]) and not r["feasible_continued"] for r in members)
        row = {"reading": reading, "task": task, "pairs": len(values)}
        row["median"] = statistics.median(values) if values else math.nan
        row |= {"lowest": min(values, default=math.nan), "highest": max(values, default=math.nan)}
        row["within_0.5%"] = sum(v >= -0.005 for v in values)
        out.append({**row, "infeasible": len(members) - len(values), "infeasible_continued": lost})
    return out


def _earlier_invocations(out_dir: Path, plan: StudyPlan) -> list[dict[str, Any]]:
    """The invocations into ``out_dir`` at this preset its manifest records (one written before
    invocations were recorded gives its one run); says so when it holds another preset's."""
    try:
        before = read_json(out_dir / rp.MANIFEST)
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
    names = rp.PHASES[2:] if before.get("continuation") is None else rp.PHASES
    phases = [{"name": name, **phase} for name, phase in zip(names, before["phases"], strict=False)]
    return [{"finished": None, "phases": phases, "wall_time_s": before.get("wall_time_s")}]


def _load() -> float | None:
    """The 1-minute load average (None where the system has none)."""
    return round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else None


#: What the readings study's plan cannot count before its singles are analysed.
COMBINATIONS_LATER = "the combinations the singles' results point to (counted once known)"


def _flat(jobs: Iterable[Mapping[str, Sequence[Job]]]) -> tuple[Job, ...]:
    return tuple(job for by_study in jobs for group in by_study.values() for job in group)


@dataclass(eq=False)
class ReadingsPlan:
    """The readings study's phases (an :class:`agents.runner.Plan`): with ``continuation`` the
    default in full, the bias check (:func:`check_jobs`) and the singles continued from the
    default's optima (:func:`full_tasks` in full), else the readings in full; then the
    combinations their results point to (if ``derive``). A look-ahead gets stand-ins; a run
    analyses each reading into ``store`` for :meth:`finish`."""

    plan: StudyPlan
    store: RecordStore
    readings: Sequence[Reading] = rp.SINGLES
    continuation: rp.Continuation | None = rp.Continuation()
    derive: bool = True
    progress: bool = True
    title: str = "readings study"

    def __post_init__(self) -> None:
        self.readings = readings = tuple(self.readings)
        names = [r.name for r in readings]
        if not readings or readings[0] != DEFAULT:
            raise ValueError(
                f"readings = {names}; allowed: the default reading first, "
                "then others (their claims are compared with the default's)"
            )
        if len(set(names)) != len(names):
            raise ValueError(f"readings = {names}; allowed: distinct names")
        self.earlier = _earlier_invocations(self.store.directory, self.plan)
        self.load_before = _load()
        self.results: list[rp.ReadingResult] = []
        self.rows: list[dict[str, Any]] = []
        self.full: dict[str, dict[str, str]] = {}
        self.words = "not derived (derive=False)"
        #: What :func:`agents.runner.run_plan` runs: this plan, its phases computed in turn.
        self.phases = self

    def _analyse(
        self, jobs: Mapping[str, Mapping[str, Sequence[Job]]], readings: Iterable[Reading]
    ) -> None:
        """Analyse the four studies' ``jobs`` (:func:`study_jobs`) under each of ``readings`` into
        its folder, with its ``report.md`` and a link ``records -> ../records`` for the indexes."""
        for reading in readings:
            if self.progress:
                print(f"analysing reading {reading.name}", file=sys.stderr)
            p, where = replace(self.plan, reading=reading), self.store.directory / reading.name
            where.mkdir(parents=True, exist_ok=True)
            link = where / RECORDS_DIR
            # no symlinks here (e.g. some Windows setups): the index paths dangle
            with contextlib.suppress(OSError):
                if not link.exists() and not link.is_symlink():
                    link.symlink_to(Path("..") / RECORDS_DIR, target_is_directory=True)
            own = jobs[reading.name]
            outputs = tuple(
                study.analyse(p, job_records(self.store, own[name]), where)
                for name, study in PAPER_STUDIES.items()
            )
            report.write_report(where / "report.md", p, outputs, list(PAPER_STUDIES))
            self.results.append(rp.ReadingResult(reading, outputs))

    def __call__(self, found: Lookup) -> Iterator[Phase]:
        """The phases, each from the records of those before it."""
        plan, continuation, readings = self.plan, self.continuation, self.readings
        later = COMBINATIONS_LATER if self.derive else ""
        rows: list[dict[str, Any]] = []  # one per checked job
        full: dict[str, dict[str, str]] = {}
        if continuation is None:
            jobs = {r.name: rp.study_jobs(plan, r) for r in readings}
            yield Phase(rp.PHASES[2], _flat(jobs.values()), later=later)
        else:
            # the default first: the others start from its optima
            jobs = {DEFAULT.name: rp.study_jobs(plan, DEFAULT)}
            default = _flat(jobs.values())
            yield Phase(rp.PHASES[0], default)
            done = found(default)
            optima: rp.Optima | None = None if done is None else rp.optima_of(done, jobs)
            others = readings[1:]
            checks = [
                (r, c, f) for r in others for c, f in rp.check_jobs(plan, r, continuation, optima)
            ]
            check = tuple(dict.fromkeys(job for _, c, f in checks for job in (c, f)))
            stand_ins = frozenset(c.key for _, c, _ in checks) if done is None else frozenset()
            yield Phase(rp.PHASES[1], check, stand_ins)
            if done is not None and checks and (checked := found(check)):
                rows = check_rows(checked, checks)
            full = rp.full_tasks(check_summary(rows), continuation)
            jobs |= {
                r.name: rp.study_jobs(plan, r, continuation, optima, full.get(r.name, {}))
                for r in others
            }
            singles = _flat(jobs[r.name] for r in others)
            own = {job.key for r in others for job in rp.reading_jobs(plan, r)}
            stand_ins = frozenset(j.key for j in singles if j.key not in own and done is None)
            yield Phase(rp.PHASES[2], singles, stand_ins, later)
        if not found.running:
            return
        self.rows, self.full = rows, full
        self._analyse(jobs, readings)
        if not self.derive:
            return
        derived, self.words = rp.combinations(self.results[0], self.results)
        derived = [r for r in derived if r.name not in jobs]
        if derived:
            optima = None if continuation is None else rp.optima_of(self.store, jobs)
            jobs |= {r.name: rp.study_jobs(plan, r, continuation, optima) for r in derived}
            yield Phase(rp.PHASES[3], _flat(jobs[r.name] for r in derived))
            self._analyse(jobs, derived)

    def finish(self, run: PlanRun) -> rp.ReadingsResult:
        """Write the bias check's CSV, readings.csv, the matrix, report.md and the manifest of
        ``run`` (this plan's)."""
        out, plan, results, words = self.store.directory, self.plan, self.results, self.words
        if self.rows:
            write_csv_atomic(out / rp.CHECK_CSV, self.rows)
        summary = check_summary(self.rows)
        csv_path, report = out / "readings.csv", out / "report.md"
        write_csv_atomic(csv_path, csv_rows(results))
        methods = ", ".join(plan.methods)
        title = f"Paper claims under each reading ({plan.preset.name} preset, {methods})"
        figure = matrix_figure(results, plan.figure(out, "readings_matrix"), title)
        write_readings_report(report, self, csv_path, figure, summary)
        this = {
            "finished": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "cpus": os.cpu_count(),
            "load_average_1min": [self.load_before, _load()],
            "phases": [{"name": name, **r.to_dict()} for name, r in run.runs.items()],
            "wall_time_s": round(run.wall_time, 1),
        }
        claims = [dict(id=c.id, statement=c.statement, paper=c.paper) for c in results[0].claims]
        readings = [
            {"name": r.reading.name, "changes": r.reading.changes(), "agree": r.agree}
            | {"verdicts": r.verdicts()}
            for r in results
        ]
        continuation = None if self.continuation is None else asdict(self.continuation)
        manifest = {"preset": plan.preset.name, "methods": list(plan.methods), "claims": claims}
        manifest |= {"readings": readings, "combination_rule": words, "continuation": continuation}
        manifest |= {"continuation_check": summary, "run_in_full": self.full}
        write_json_atomic(out / rp.MANIFEST, {**manifest, "invocations": [*self.earlier, this]})
        files = (csv_path, figure, report)
        runs = tuple(run.runs.values())
        return rp.ReadingsResult(tuple(results), runs, words, files, run.wall_time, tuple(run.runs))


def run_readings(
    plan: StudyPlan,
    out_dir: str | os.PathLike[str] | RecordStore,
    *,
    readings: Sequence[Reading] = rp.SINGLES,
    derive: bool = True,
    scheduler: str | None = None,
    progress: bool = True,
    continuation: rp.Continuation | None = rp.Continuation(),
    cache: CacheOption = True,
    rerun: bool = False,
    command: CommandProgress | None = None,
) -> rp.ReadingsResult:
    """Run the readings study into ``out_dir`` (:class:`ReadingsPlan`: the ``readings``, the
    default first; the combinations if ``derive``; ``continuation`` None runs all in full) and
    write its outputs; ``plan``'s reading is ignored. ``scheduler``, ``cache``, ``rerun`` and
    ``command`` as for :func:`agents.runner.run_plan`. ValueError for bad ``readings``."""
    store = RecordStore.at(out_dir)
    study = ReadingsPlan(plan, store, readings, continuation, derive, progress)
    done = run_plan(study, store, scheduler, cache, progress=progress, rerun=rerun, command=command)
    return study.finish(done)


def csv_rows(results: Sequence[rp.ReadingResult]) -> list[dict[str, Any]]:
    """One row per reading (:data:`CSV_COLUMNS`)."""
    rows = []
    for r in results:
        reading = r.reading
        c_r = r.reading.rotational_coefficient
        row: dict[str, Any] = {
            "reading": reading.name,
            "kind": "combination" if reading.derived_from else "single",
            "changes": reading.describe_changes(),
            **{name: getattr(reading.model_options, name) for name in DECISION_OPTIONS},
            "rotational_coefficient": math.pi if c_r is None else float(c_r),
            "horizontal_objective": reading.horizontal_objective,
            "search": "" if reading.search is None else reading.search.describe(),
            **asdict(r.counts),
            **{k: v if math.isnan(v) else float(f"{v:.4g}") for k, v in r.headline().items()},
            "description": reading.description,
        }
        rows.append({k: row[k] for k in rp.CSV_COLUMNS})
    return rows


def continuation_option(text: str) -> rp.Continuation | None:
    """``--continuation``: a share in (0, 1], or none."""
    if text.strip().lower() == "none":
        return None
    try:
        share = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a number; allowed: a share of the budget in (0, 1], or none to run "
            "every reading in full"
        ) from None
    try:
        return rp.Continuation(share=share)
    except ValueError as error:
        raise argparse.ArgumentTypeError(
            f"{error} (got {text!r}; or none to run every reading in full)"
        ) from None


def check_continuation(plan: StudyPlan, continuation: rp.Continuation) -> None:
    """Prepare a continued job of every configuration (method, budget, settings) of the
    default's jobs as the harness will: ValueError, before any work, naming a share whose
    continued jobs cannot run (below one population, a part without evaluations)."""
    jobs = {(j.method, j.budget, j.method_config): j for j in rp.reading_jobs(plan, DEFAULT)}
    for job in jobs.values():
        continued = continuation.job(job, None)  # the default's optima are not known yet
        try:
            prepare_job(continued)
        except ValueError as error:
            raise ValueError(
                f"--continuation {continuation.share:g}: a continued {job.method} job "
                f"({continued.budget} of its {job.budget} evaluations, from the default's "
                f"optimum) cannot run: {error}; allowed: a share (and method) whose continued "
                "jobs run, or --continuation none to run every reading in full"
            ) from None


class ReadingsCampaign:
    """The readings study on the command line."""

    names = (rp.NAME,)
    description = """\
  readings     the four paper studies under each reading of the paper's open decisions (the
               default, each decision changed alone, the combinations those results point
               to): readings.csv, a claims × readings matrix, report.md (default out
               results/readings)"""
    default_out = rp.DEFAULT_OUT
    reading_help = (
        "readings study: run these single readings (repeat; the default is always "
        f"run; allowed: {', '.join(r.name for r in rp.SINGLES)})"
    )
    options: Mapping[str, dict[str, Any]] = {
        "--continuation": {
            "type": continuation_option,
            "default": rp.Continuation(),
            "metavar": "SHARE|none",
            "help": "readings study only: the other readings continue from the default's "
            f"optima on SHARE of the budget (default {rp.Continuation().share:g}; "
            "docs/reproduction.md, Readings); none runs every reading in full",
        }
    }

    def plan(self, args: argparse.Namespace, plan: StudyPlan, out: RecordStore) -> ReadingsPlan:
        """The study of the readings ``--reading`` names (ValueError, before any work, for a
        bad one or a share whose continued jobs cannot run)."""
        chosen = rp.single_readings(args.reading)
        singles = f"{len(chosen) - 1} single reading{'s' * (len(chosen) != 2)}"
        title = f"readings study (the default and {singles})"
        if args.continuation is not None:
            check_continuation(plan, args.continuation)
            title = (
                f"readings study (the default in full; {singles} continuing from its optima on "
                f"{args.continuation.share:g} of the budget, a task the bias check fails in full)"
            )
        return ReadingsPlan(
            plan, out, chosen, args.continuation, progress=not args.quiet, title=title
        )

    def report(self, args: argparse.Namespace, result: rp.ReadingsResult) -> None:
        """Print what the run did (stderr) and found (stdout)."""
        for phase, run in zip(result.phases, result.runs, strict=True):
            done = f"{run.describe(args.out)} ({run.executor}); {run.wall_time:.1f} s"
            print(f"{phase}: {run.total} optimisations: {done}", file=sys.stderr)
        for r in result.results:
            print(f"{r.reading.name}: {VerdictCount.of(r.claims).text()}")
        print(f"best: {result.best.reading.name} ({result.best.agree} claims agree)")
        print(f"combinations: {result.combination_rule}")
        print(f"report: {result.files[-1]}; total {result.wall_time:.1f} s")


#: The readings study's campaign (:data:`eval.study.CAMPAIGNS`).
READINGS = ReadingsCampaign()
