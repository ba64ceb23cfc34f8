"""The readings study: which reading of the paper reproduces which of its claims.

``python -m eval study readings [--preset quick|paper]``. For every reading
(:mod:`eval.studies.paper_reading`) the four paper studies (speed, power, kinematics, wing shape: the
``all`` suite) run under it with the preset's method and budgets, and their claims are judged by
the studies' own claim builders. The readings are

1. the single readings (:data:`SINGLES`): the documented default, then each open decision
   changed alone;
2. the combinations the singles point to (:func:`combinations`), derived from their results by
   a rule, not chosen by hand: the singles that each raised the count of agreeing claims over the
   default are combined, all together and as the pair of the best two, and the best of them is
   paired with each other single.

All jobs of a phase go into one :func:`~eval.studies.runner.run_jobs` call, so a job two
readings share (the same env keywords: e.g. every job but the horizontal accelerating ones of
the F̄_h reading, or any job of a reading that restates a default) runs once, and the default's
jobs are the ``all`` suite's own. Records are written as jobs finish; a killed run resumes in
either phase. Outputs under the output directory: ``readings.csv`` (one row per reading),
``readings_matrix.png`` (claims × readings; ``--format`` svg or pdf likewise), ``report.md`` and, per reading, ``<name>/`` with
that reading's study tables, figures and report.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from eval import report
from eval.studies import PAPER_STUDIES
from eval.studies.base import StudyPlan
from eval.studies.paper_reading import DECISION_OPTIONS, DEFAULT, Reading, combine
from eval.studies.readings_figure import matrix_figure
from eval.studies.readings_result import HEADLINES, ReadingResult, reading_dir
from eval.studies.runner import RECORDS_DIR, Job, RunSummary, load_records, run_jobs
from tandem_env.io.files import read_json, write_csv_atomic, write_json_atomic

NAME = "readings"
TITLE = "Readings of the paper against its claims"
DEFAULT_OUT = os.path.join("results", "readings")
MANIFEST = "readings_manifest.json"

#: The single readings: the default, then each open decision changed alone (docs/model.md).
SINGLES: tuple[Reading, ...] = (
    DEFAULT,
    Reading(
        "body",
        'thrust_split="body" (§7): T is the net horizontal wing force, D the body\'s parasite '
        "drag (net efficiency) instead of the forward/rearward parts of the wing force",
        options={"thrust_split": "body"},
    ),
    Reading(
        "elastic",
        'power="elastic" (§6): negative work is stored elastically; P is the mean of the '
        "positive part of the total power instead of the sum of |P_aero| and |P_iner|",
        options={"power": "elastic"},
    ),
    Reading(
        "aerodynamic",
        'power="aerodynamic" (§6.3): only the positive aerodynamic power is charged (inertial '
        "power fully stored and returned) instead of |P_aero| and |P_iner| in full",
        options={"power": "aerodynamic"},
    ),
    Reading(
        "spin-total",
        'spin="total" (§4): circulation and added mass use the section\'s true spin '
        "η̇ − φ̇·sin θ instead of the pitch rate η̇",
        options={"spin": "total"},
    ),
    Reading(
        "Cr-half",
        "C_r = π/2 on both wings (§1.3): the rotational coefficient of the quasi-steady "
        "literature's other normalisation instead of Table 3's π",
        rotational_coefficient=math.pi / 2,
    ),
    Reading(
        "hover-none",
        'hover_inflow="none" (§5.5): Eqs. 20-21 read literally, no induced velocity where the '
        "free stream has no normal component (hover, V = 0) instead of the momentum inflow",
        options={"hover_inflow": "none"},
    ),
    Reading(
        "Fh-literal",
        "F̄_h from Eq. 24 read literally (§7.6): F_h = D_f + D_h, the wings' rearward "
        "horizontal forces, maximised (objective horizontal_literal) instead of the net "
        "horizontal wing force",
        horizontal_objective="horizontal_literal",
    ),
    Reading(
        "Chf=0",
        "C_hf = 0 (§5, Eq. 21): the hind-wing does not see the fore-wing's induced velocity "
        "instead of all of it",
        options={"interference": 0.0},
    ),
    Reading(
        "Chf=2",
        "C_hf = 2 (§5, Eq. 21): the hind-wing sees the fore-wing's fully developed far wake "
        "(twice the induced velocity at the disk) instead of the disk value",
        options={"interference": 2.0},
    ),
)

#: The columns of readings.csv, in order.
CSV_COLUMNS: tuple[str, ...] = (
    "reading",
    "kind",
    "changes",
    *DECISION_OPTIONS,
    "rotational_coefficient",
    "horizontal_objective",
    "agree",
    "differ",
    "undecided",
    "no_data",
    *HEADLINES,
    "description",
)


@dataclass(frozen=True)
class ReadingsResult:
    """What :func:`run_readings` did."""

    results: tuple[ReadingResult, ...]
    """Singles first, then the derived combinations."""
    runs: tuple[RunSummary, ...]
    """One per phase (singles, combinations)."""
    combination_rule: str
    """The rule's outcome in words (which singles gained, what was combined)."""
    files: tuple[Path, ...]
    """readings.csv, the matrix figure, report.md."""
    wall_time: float
    """Seconds for the whole call [s]."""

    @property
    def best(self) -> ReadingResult:
        """The reading with the most agreeing claims (the first such in order)."""
        return max(self.results, key=lambda r: r.agree)


def single_readings(names: Sequence[str] | None = None) -> tuple[Reading, ...]:
    """The singles named (all by default); the default reading is always included, first."""
    if names is None:
        return SINGLES
    known = {r.name: r for r in SINGLES}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(
            f"unknown reading(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(known)}"
        )
    chosen = [DEFAULT] + [known[n] for n in dict.fromkeys(names) if n != DEFAULT.name]
    return tuple(chosen)


def reading_plan(plan: StudyPlan, reading: Reading) -> StudyPlan:
    """``plan`` (preset and methods) under ``reading``."""
    return replace(plan, reading=reading)


def reading_jobs(plan: StudyPlan, reading: Reading) -> list[Job]:
    """Every job of the ``all`` suite under ``reading`` (duplicates between studies included)."""
    p = reading_plan(plan, reading)
    return [job for study in PAPER_STUDIES.values() for job in study.jobs(p)]


def combinations(
    default: ReadingResult, singles: Sequence[ReadingResult]
) -> tuple[list[Reading], str]:
    """The combination readings the singles' results point to, and the rule's outcome in words.

    Rule, in two parts:

    1. *Gainers together.* The gainers are the singles (other than the default) with more
       agreeing claims than the default, best first (ties in :data:`SINGLES` order). Taken best
       first, each gainer joins the set unless it conflicts with one already in it (two values
       of one option); combined are the pair of its best two (if it has 2 or more) and the
       whole set (if it has 3 or more).
    2. *The best single with each other.* If a gainer exists, the best one is paired with every
       other single it does not conflict with: a change that loses claims on its own can win
       them beside another (one that lowers F̄_h, say, where the best raises it too far), and
       the singles' counts cannot show that.

    Duplicates (the same changes) are dropped. Without a gainer there is nothing to combine.
    """
    base = default.agree
    gainers = sorted(
        (r for r in singles if r.reading != default.reading and r.agree > base),
        key=lambda r: -r.agree,
    )
    chosen: list[ReadingResult] = []
    skipped: list[str] = []
    for candidate in gainers:
        clash = [c.reading.name for c in chosen if candidate.reading.conflicts(c.reading)]
        if clash:
            skipped.append(f"{candidate.reading.name} (conflicts with {', '.join(clash)})")
        else:
            chosen.append(candidate)
    gains = ", ".join(f"{r.reading.name} (+{r.agree - base})" for r in gainers) or "none"
    words = f"singles that raised the agreeing claims over the default ({base}): {gains}"
    if skipped:
        words += f"; left out: {', '.join(skipped)}"
    groups: list[list[ReadingResult]] = []
    if len(chosen) >= 2:
        groups.append(chosen[:2])
    if len(chosen) >= 3:
        groups.append(chosen)
    if gainers:
        top = gainers[0]
        groups += [
            [top, other]
            for other in singles
            if other.reading not in (default.reading, top.reading)
            and not top.reading.conflicts(other.reading)
        ]
    out: list[Reading] = []
    for group in groups:
        reading = combine([g.reading for g in group], _combined_name(group))
        if all(r.changes() != reading.changes() for r in out):
            out.append(reading)
    if out:
        words += "; combined: " + "; ".join(r.name for r in out)
    elif not gainers:
        words += "; no gainer, so no combination"
    else:  # one gainer, and every other single is the default or changes the same option
        words += (
            f"; no combination: {gainers[0].reading.name} is the only gainer and no other "
            "single run here can join it (none, or each changes the same option)"
        )
    return out, words


def _combined_name(results: Sequence[ReadingResult]) -> str:
    return "+".join(r.reading.name for r in results)


def analyse_reading(plan: StudyPlan, reading: Reading, out_dir: Path) -> ReadingResult:
    """Analyse the four studies under ``reading`` (every record present) into its folder.

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
        study.analyse(p, load_records(out_dir, study.jobs(p)), where)
        for study in PAPER_STUDIES.values()
    )
    report.write_report(where / "report.md", p, outputs, list(PAPER_STUDIES))
    return ReadingResult(reading, outputs)


def _phase(
    plan: StudyPlan,
    readings: Sequence[Reading],
    out_dir: Path,
    scheduler: str | None,
    progress: bool,
) -> tuple[list[ReadingResult], RunSummary]:
    jobs = [job for reading in readings for job in reading_jobs(plan, reading)]
    summary = run_jobs(jobs, out_dir, scheduler=scheduler, progress=progress)
    results = []
    for reading in readings:
        if progress:
            print(f"analysing reading {reading.name}", file=sys.stderr)
        results.append(analyse_reading(plan, reading, out_dir))
    return results, summary


def _check_preset(out_dir: Path, plan: StudyPlan) -> None:
    """Say so (stderr) when ``out_dir`` holds another preset's readings, which are replaced."""
    try:
        before = read_json(out_dir / MANIFEST)
    except (FileNotFoundError, ValueError):
        return
    if isinstance(before, Mapping) and before.get("preset") not in (None, plan.preset.name):
        print(
            f"note: {out_dir} holds the {before['preset']!r} preset's readings; its readings.csv, "
            f"matrix and report are replaced by the {plan.preset.name!r} preset's (the records "
            "of both stay: they are keyed by preset). Use --out for a separate folder.",
            file=sys.stderr,
        )


def run_readings(
    plan: StudyPlan,
    out_dir: str | os.PathLike[str],
    *,
    readings: Sequence[Reading] = SINGLES,
    derive: bool = True,
    scheduler: str | None = None,
    progress: bool = True,
) -> ReadingsResult:
    """Run the readings study into ``out_dir``: the ``readings`` (singles; the default first),
    then, if ``derive``, the combinations their results point to (:func:`combinations`).

    ``plan`` gives the preset and methods (its own reading is ignored). ``scheduler`` as for
    :func:`eval.studies.runner.run_jobs`. Raises ValueError if ``readings`` does not start with
    the default reading or repeats a name.
    """
    start = time.perf_counter()
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
    _check_preset(out, plan)
    singles, first = _phase(plan, readings, out, scheduler, progress)
    runs = [first]
    words = "not derived (derive=False)"
    results = list(singles)
    if derive:
        derived, words = combinations(singles[0], singles)
        derived = [r for r in derived if r.name not in names]
        if derived:
            more, second = _phase(plan, derived, out, scheduler, progress)
            results += more
            runs.append(second)
    files = write_outputs(plan, results, words, out)
    wall = time.perf_counter() - start
    write_json_atomic(
        out / MANIFEST,
        {
            "preset": plan.preset.name,
            "methods": list(plan.methods),
            "readings": [
                {"name": r.reading.name, "changes": r.reading.changes(), "agree": r.agree}
                for r in results
            ],
            "combination_rule": words,
            "phases": [s.to_dict() for s in runs],
            "wall_time_s": round(wall, 1),
        },
    )
    return ReadingsResult(tuple(results), tuple(runs), words, tuple(files), wall)


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
            "agree": r.agree,
            "differ": r.differ,
            "undecided": r.undecided,
            "no_data": r.no_data,
            **{k: _round(v) for k, v in r.headline().items()},
            "description": r.reading.description,
        }
        rows.append({k: row[k] for k in CSV_COLUMNS})
    return rows


def _round(value: float) -> float:
    return value if math.isnan(value) else float(f"{value:.4g}")


def write_outputs(
    plan: StudyPlan, results: Sequence[ReadingResult], rule: str, out_dir: Path
) -> list[Path]:
    """readings.csv, readings_matrix.<format> and report.md."""
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
    report_path = report.write_readings_report(
        out_dir / "report.md", plan, results, rule, csv_path, figure
    )
    return [csv_path, figure, report_path]
