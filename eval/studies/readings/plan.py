"""The readings study's plan: the readings (the singles, the named ones, the combinations
their results point to), the continuation from the default's optima and its bias check, and
the jobs of each (:mod:`eval.studies.readings`)."""

from __future__ import annotations

import math
import os
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from agents import jobs as agents_jobs
from agents.jobs import Job
from agents.records import Record
from agents.runner import RunSummary, job_records
from eval.studies import PAPER_STUDIES
from eval.studies.base import StudyPlan
from eval.studies.paper_reading import DECISION_OPTIONS, DEFAULT, Reading, combine
from eval.studies.presets import is_int, is_number
from eval.studies.readings.result import COUNTS, HEADLINES, ReadingResult

NAME = "readings"
TITLE = "Readings of the paper against its claims"
DEFAULT_OUT = os.path.join("results", "readings")
MANIFEST = "readings_manifest.json"
CHECK_CSV = "continuation_check.csv"
#: The phases of a run with the continuation: the default in full, the continuation's bias
#: check, the singles, the combinations; without it, the last two.
PHASES = ("default", "check", "singles", "combinations")

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
    Reading(
        "convected",
        'slipstream="convected" (§5.7): the hind-wing sees the fore-wing\'s wake as it varies '
        "over the cycle, convected over the fore/hind spacing, instead of its cycle mean; the "
        "only reading under which the model depends on the fore/hind phase (K1-K3 get verdicts)",
        options={"slipstream": "convected"},
    ),
)

#: Named readings. ``paper``: the reading with the most agreeing claims (13 of 26, 4 undecided,
#: strictly more than any other) in the paper-preset run of this study (docs/reproduction.md,
#: "Readings at the paper preset"; tests/test_docs_numbers.py checks it against that run's
#: stored readings.csv). Its model part is ``ModelOptions.preset("paper")``; what its decisions
#: mean physically: docs/model.md §5.5 and §7.6.
ALIASES: dict[str, str] = {"paper": "hover-none+Fh-literal"}

#: The columns of readings.csv, in order.
CSV_COLUMNS: tuple[str, ...] = (
    "reading",
    "kind",
    "changes",
    *DECISION_OPTIONS,
    "rotational_coefficient",
    "horizontal_objective",
    "search",
    *COUNTS,
    *HEADLINES,
    "description",
)


@dataclass(frozen=True)
class Continuation(agents_jobs.Continuation):
    """How a reading's optimisations continue from the default reading's optima (one round of
    :class:`agents.jobs.Continuation`, with the bias check's settings).

    Parameters
    ----------
    share : float
        A continued job's budget as a fraction of the preset's, in (0, 1].
    initial_share : float
        The part of that budget for polishing the default's optimum under the reading, in
        [0.05, 0.95]; ``starts`` short searches of the preset's method, each polished, share
        the rest (harness settings ``initial``, ``initial_share`` and ``starts``,
        docs/harness.md).
    starts : int
        Short global searches beside the warm start (1 to 8): they catch a basin that moved.
    check_studies : tuple of str
        The paper studies whose jobs also run in full for each single reading, to measure the
        continuation's bias (``continuation_check.csv``): one per task.
    check_seeds : tuple of int
        The seeds of those full runs (seeds of the preset that are not among them are not
        checked).
    full_median : float
        A single reading's task (``accelerate`` or ``level``) whose checked continued optima
        fall short of the full runs' by more than this median relative difference [-] runs in
        full instead (:func:`full_tasks`), in [-1, 0].
    full_lowest : float
        Likewise for any one checked pair worse than this [-], or a continued optimum
        infeasible where the full run's is feasible, in [-1, 0].
    """

    check_studies: tuple[str, ...] = ("power", "speed")
    check_seeds: tuple[int, ...] = (0,)
    full_median: float = -0.02
    full_lowest: float = -0.5

    def __post_init__(self) -> None:
        super().__post_init__()
        for name in ("full_median", "full_lowest"):
            value = getattr(self, name)
            if not is_number(value) or not -1.0 <= value <= 0.0:
                raise ValueError(
                    f"continuation {name} = {value!r}; allowed: a relative difference in [-1, 0]"
                )
            object.__setattr__(self, name, float(value))
        studies = tuple(self.check_studies)
        if any(name not in PAPER_STUDIES for name in studies):
            raise ValueError(
                f"continuation check_studies = {self.check_studies!r}; allowed: names among "
                f"{', '.join(PAPER_STUDIES)}"
            )
        object.__setattr__(self, "check_studies", studies)
        seeds = tuple(self.check_seeds)
        if not all(is_int(seed, 0) for seed in seeds):
            raise ValueError(
                f"continuation check_seeds = {self.check_seeds!r}; allowed: integers >= 0"
            )
        object.__setattr__(self, "check_seeds", seeds)


@dataclass(frozen=True)
class ReadingsResult:
    """What :func:`run_readings` did."""

    results: tuple[ReadingResult, ...]
    """Singles first, then the derived combinations."""
    runs: tuple[RunSummary, ...]
    """One per phase (:attr:`phases`)."""
    combination_rule: str
    """The rule's outcome in words (which singles gained, what was combined)."""
    files: tuple[Path, ...]
    """readings.csv, the matrix figure, report.md."""
    wall_time: float
    """Seconds for the whole call [s]."""
    phases: tuple[str, ...] = ()
    """The phases' names (:data:`PHASES`), one per run."""

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
    return (DEFAULT, *(known[n] for n in dict.fromkeys(names) if n != DEFAULT.name))


def reading_by_name(name: str) -> Reading:
    """The reading ``name``: a single (:data:`SINGLES`), singles joined by ``+`` (their
    combination, as the study derives them, e.g. ``hover-none+Fh-literal``) or an alias of
    :data:`ALIASES` (``paper``), an alias also inside a combination (``paper+body``). Raises
    ValueError naming what is allowed."""
    given = name
    known = {r.name: r for r in SINGLES}
    allowed = f"{', '.join([*ALIASES, *known])}, or these joined by '+'"
    if not isinstance(name, str) or not name.strip("+ "):
        raise ValueError(f"reading {given!r}: no name; allowed: {allowed}")
    # Each part is a single or an alias, which stands for its singles.
    parts = [single for part in name.split("+") for single in ALIASES.get(part, part).split("+")]
    unknown = [part for part in name.split("+") if part not in known and part not in ALIASES]
    if unknown:
        raise ValueError(
            f"reading {given!r}: unknown {', '.join(map(repr, unknown))}; allowed: {allowed}"
        )
    name = "+".join(parts)
    if len(parts) == 1:
        return known[name]
    if len(set(parts)) != len(parts) or DEFAULT.name in parts:
        raise ValueError(
            f"reading {given!r} is {name!r}; allowed: distinct singles other than the default "
            f"({allowed})"
        )
    return combine([known[part] for part in parts], name)


def reading_jobs(plan: StudyPlan, reading: Reading) -> list[Job]:
    """Every job of the ``all`` suite under ``reading`` (duplicates between studies included)."""
    p = replace(plan, reading=reading)
    return [job for study in PAPER_STUDIES.values() for job in study.jobs(p)]


Optima = Mapping[str, Mapping[str, Sequence[Sequence[float]]]]
"""Optima of readings already run: reading name -> study name -> the normalised optimum of each
of the study's jobs under that reading, in the study's order (:func:`optima_of`)."""


def continued_from(reading: Reading) -> tuple[str, ...]:
    """The readings whose optima ``reading`` continues from: a combination's parts (each a
    small change away from it, and run before it), any other reading the default's."""
    return reading.derived_from or (DEFAULT.name,)


def study_jobs(
    plan: StudyPlan,
    reading: Reading,
    continuation: Continuation | None = None,
    optima: Optima | None = None,
    full: Collection[str] = (),
) -> dict[str, list[Job]]:
    """Each paper study's jobs under ``reading``, by study name.

    Without ``continuation`` (or for the default reading, or a reading of the search itself,
    ``Reading.search``: its point is the search from scratch) these are the studies' own
    jobs. With it, each job pairs with the default's job of the same position (the studies
    build both lists in one order, differing only in the reading's keywords): a job the
    default shares (same key) stays, and so does a job of a task in ``full`` (run in full:
    :func:`full_tasks`); any other continues from the optima of the same position in
    ``optima`` of the readings :func:`continued_from` names (duplicate strokes once); without
    ``optima`` (not run yet) it is a stand-in (:meth:`agents.jobs.Continuation.job`).
    """
    p = replace(plan, reading=reading)
    if continuation is None or reading == DEFAULT or reading.search is not None:
        return {name: study.jobs(p) for name, study in PAPER_STUDIES.items()}
    sources = continued_from(reading)
    missing = [name for name in sources if optima is not None and name not in optima]
    if missing:
        raise ValueError(f"reading {reading.name!r} continues from {missing}, not run yet")
    base = replace(plan, reading=DEFAULT)
    out: dict[str, list[Job]] = {}
    for name, study in PAPER_STUDIES.items():
        jobs = []
        pairs = zip(study.jobs(base), study.jobs(p), strict=True)
        for position, (default_job, job) in enumerate(pairs):
            if job.key == default_job.key or job.task in full:
                jobs.append(job)
                continue
            strokes = None
            if optima is not None:
                strokes = list({tuple(optima[source][name][position]): None for source in sources})
            jobs.append(continuation.job(job, strokes))
        out[name] = jobs
    return out


def optima_of(
    out_dir: Path, jobs: Mapping[str, Mapping[str, list[Job]]]
) -> dict[str, dict[str, list[list[float]]]]:
    """:data:`Optima` of the readings in ``jobs`` (reading -> study -> jobs, every record
    present in ``out_dir``)."""
    flat = [job for by_study in jobs.values() for group in by_study.values() for job in group]
    return optima_from(job_records(out_dir, flat), jobs)


def optima_from(
    records: Mapping[Job, Record], jobs: Mapping[str, Mapping[str, list[Job]]]
) -> dict[str, dict[str, list[list[float]]]]:
    """:data:`Optima` of the readings in ``jobs`` (reading -> study -> jobs) from their
    ``records`` (job -> record, every job's present)."""
    return {
        reading: {
            study: [list(records[job].results["normalised_stroke"]) for job in group]
            for study, group in by_study.items()
        }
        for reading, by_study in jobs.items()
    }


def check_jobs(
    plan: StudyPlan, reading: Reading, continuation: Continuation, optima: Optima | None
) -> list[tuple[Job, Job]]:
    """(continued job, the same job in full) for the continuation's bias check: the check
    studies' jobs at the check seeds that the reading does not share with the default (none
    for a search reading, which runs in full)."""
    continued = study_jobs(plan, reading, continuation, optima)
    full = study_jobs(plan, reading)
    pairs = dict.fromkeys(
        (c, f)
        for name in continuation.check_studies
        for c, f in zip(continued[name], full[name], strict=True)
        if c != f and f.seed in continuation.check_seeds
    )
    return list(pairs)


def full_tasks(
    summary: Sequence[Mapping[str, Any]], continuation: Continuation
) -> dict[str, dict[str, str]]:
    """reading -> task -> why that task's jobs run in full: the bias check
    (:func:`check_summary` rows) found its continued optima short of the full runs' by more
    than ``continuation.full_median`` on the median or ``full_lowest`` in one pair, or a
    continued optimum infeasible where the full run's is feasible."""
    out: dict[str, dict[str, str]] = {}
    for row in summary:
        if row["reading"] == "all" or row["task"] == "all":
            continue
        why = []
        if row["pairs"] and row["median"] < continuation.full_median:
            why.append(f"median {100 * row['median']:+.1f} %")
        if row["pairs"] and row["lowest"] < continuation.full_lowest:
            why.append(f"lowest {100 * row['lowest']:+.1f} %")
        if row["infeasible_continued"]:
            count = row["infeasible_continued"]
            why.append(f"{count} continued optim{'um' if count == 1 else 'a'} infeasible")
        if why:
            out.setdefault(row["reading"], {})[row["task"]] = ", ".join(why)
    return out


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
        reading = combine([g.reading for g in group], "+".join(g.reading.name for g in group))
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
