"""The readings study's plan: the readings (the singles, the named ones, the combinations
their results point to), the continuation from the default's optima and its bias check, and
the jobs of each (:mod:`eval.studies.readings`); one reading's analysed studies
(:class:`ReadingResult`), readings.csv's headline numbers and a reading's output folder."""

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
from eval.studies.base import StudyOutput, StudyPlan
from eval.studies.claims import Claim, VerdictCount
from eval.studies.paper_reading import DECISION_OPTIONS, DEFAULT, Reading, combine
from eval.studies.power import EXCESS_UNIT
from eval.studies.presets import is_int, is_number
from eval.studies.tables import Row

NAME = "readings"
TITLE = "Readings of the paper against its claims"
DEFAULT_OUT = os.path.join("results", "readings")
MANIFEST = "readings_manifest.json"
CHECK_CSV = "continuation_check.csv"
#: The phases of a run with the continuation: the default in full, the continuation's bias
#: check, the singles, the combinations; without it, the last two.
PHASES = ("default", "check", "singles", "combinations")

#: The single readings: the default, then each open decision changed alone (docs/model.md), as
#: name: (its changes from the default, what it assumes).
_SINGLES: dict[str, tuple[dict[str, Any], str]] = {
    "body": (
        {"thrust_split": "body"},
        'thrust_split="body" (§7): T is the net horizontal wing force, D the body\'s parasite '
        "drag (net efficiency) instead of the forward/rearward parts of the wing force",
    ),
    "elastic": (
        {"power": "elastic"},
        'power="elastic" (§6): negative work is stored elastically; P is the mean of the '
        "positive part of the total power instead of the sum of |P_aero| and |P_iner|",
    ),
    "aerodynamic": (
        {"power": "aerodynamic"},
        'power="aerodynamic" (§6.3): only the positive aerodynamic power is charged (inertial '
        "power fully stored and returned) instead of |P_aero| and |P_iner| in full",
    ),
    "spin-total": (
        {"spin": "total"},
        'spin="total" (§4): circulation and added mass use the section\'s true spin '
        "η̇ − φ̇·sin θ instead of the pitch rate η̇",
    ),
    "Cr-half": (
        {"rotational_coefficient": math.pi / 2},
        "C_r = π/2 on both wings (§1.3): the rotational coefficient of the quasi-steady "
        "literature's other normalisation instead of Table 3's π",
    ),
    "hover-none": (
        {"hover_inflow": "none"},
        'hover_inflow="none" (§5.5): Eqs. 20-21 read literally, no induced velocity where the '
        "free stream has no normal component (hover, V = 0) instead of the momentum inflow",
    ),
    "Fh-literal": (
        {"horizontal_objective": "horizontal_literal"},
        "F̄_h from Eq. 24 read literally (§7.6): F_h = D_f + D_h, the wings' rearward "
        "horizontal forces, maximised (objective horizontal_literal) instead of the net "
        "horizontal wing force",
    ),
    "Chf=0": (
        {"interference": 0.0},
        "C_hf = 0 (§5, Eq. 21): the hind-wing does not see the fore-wing's induced velocity "
        "instead of all of it",
    ),
    "Chf=2": (
        {"interference": 2.0},
        "C_hf = 2 (§5, Eq. 21): the hind-wing sees the fore-wing's fully developed far wake "
        "(twice the induced velocity at the disk) instead of the disk value",
    ),
    "convected": (
        {"slipstream": "convected"},
        'slipstream="convected" (§5.7): the hind-wing sees the fore-wing\'s wake as it varies '
        "over the cycle, convected over the fore/hind spacing, instead of its cycle mean; the "
        "only reading under which the model depends on the fore/hind phase (K1-K3 get verdicts)",
    ),
}
SINGLES: tuple[Reading, ...] = (
    DEFAULT,
    *(Reading.from_changes(name, text, changes) for name, (changes, text) in _SINGLES.items()),
)

#: Named readings. ``paper``: the reading with the most agreeing claims in the paper-preset run
#: of this study (docs/reproduction.md, "Readings at the paper preset"); its model part is
#: ``ModelOptions.preset("paper")``.
ALIASES: dict[str, str] = {"paper": "hover-none+Fh-literal"}

#: The verdict counts of readings.csv and the readings tables, in their order
#: (:class:`~eval.studies.claims.VerdictCount` fields): column -> table title.
COUNTS = {
    k: k.replace("_", " ") for k in ("agree", "differ", "undecided", "not_identifiable", "no_data")
}

#: Headline numbers of readings.csv: column -> (claim id whose median it is, description).
HEADLINES: dict[str, tuple[str, str]] = {
    "eta_max_pct": ("S7", "highest median level-flight efficiency over speeds [%]"),
    "Fv_50": ("P1a", f"median F̄_v at 50 W/kg {EXCESS_UNIT}"),
    "Fv_90": ("P1b", f"median F̄_v at 90 W/kg {EXCESS_UNIT}"),
    "Fh_50": ("P2a", f"median F̄_h at 50 W/kg {EXCESS_UNIT}"),
    "Fh_90": ("P2b", f"median F̄_h at 90 W/kg {EXCESS_UNIT}"),
    "Fa_50": ("P6a", f"median F̄_a at 50 W/kg {EXCESS_UNIT}"),
    "Fa_90": ("P6b", f"median F̄_a at 90 W/kg {EXCESS_UNIT}"),
}


@dataclass(frozen=True)
class ReadingResult:
    """One reading's studies, analysed."""

    reading: Reading
    outputs: tuple[StudyOutput, ...]

    @property
    def claims(self) -> list[Claim]:
        return [c for o in self.outputs for c in o.claims]

    @property
    def counts(self) -> VerdictCount:
        """Its verdict counts on the median."""
        return VerdictCount.of(self.claims)

    agree = property(lambda self: self.counts.agree, doc="How many claims agree (the median's).")
    differ = property(lambda self: self.counts.differ, doc="How many claims differ (the median's).")

    def verdicts(self) -> dict[str, str]:
        return {c.id: c.verdict for c in self.claims}

    def headline(self) -> dict[str, float]:
        """The :data:`HEADLINES` numbers: the medians of those claims (NaN where absent)."""
        by_id = {c.id: c for c in self.claims}
        return {k: getattr(by_id.get(cid), "median", math.nan) for k, (cid, _) in HEADLINES.items()}


#: The columns of readings.csv, in order.
CSV_COLUMNS: tuple[str, ...] = (
    *("reading", "kind", "changes", *DECISION_OPTIONS),
    *("rotational_coefficient", "horizontal_objective", "search", *COUNTS, *HEADLINES),
    "description",
)


@dataclass(frozen=True)
class Continuation(agents_jobs.Continuation):
    """How a reading's optimisations continue from the default reading's optima: one round of
    :class:`agents.jobs.Continuation` (``share``, ``initial_share``, ``starts``), with the
    bias check's settings."""

    check_studies: tuple[str, ...] = ("power", "speed")
    """The paper studies whose jobs also run in full for each single reading, to measure the
    continuation's bias (``continuation_check.csv``): one per task."""
    check_seeds: tuple[int, ...] = (0,)
    """The seeds of those full runs."""
    full_median: float = -0.02
    """A single reading's task whose checked continued optima fall short of the full runs' by
    more than this median relative difference [-] runs in full instead (:func:`full_tasks`)."""
    full_lowest: float = -0.5
    """Likewise for any one checked pair worse than this [-]."""

    def __post_init__(self) -> None:
        super().__post_init__()
        for name in ("full_median", "full_lowest"):
            value = getattr(self, name)
            if not is_number(value) or not -1.0 <= value <= 0.0:
                allowed = "a relative difference in [-1, 0]"
                raise ValueError(f"continuation {name} = {value!r}; allowed: {allowed}")
            object.__setattr__(self, name, float(value))
        studies = f"names among {', '.join(PAPER_STUDIES)}"
        for name, ok, allowed in (
            ("check_studies", lambda s: s in PAPER_STUDIES, studies),
            ("check_seeds", lambda s: is_int(s, 0), "integers >= 0"),
        ):
            given = getattr(self, name)
            if not all(map(ok, values := tuple(given))):
                raise ValueError(f"continuation {name} = {given!r}; allowed: {allowed}")
            object.__setattr__(self, name, values)


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
    if unknown := [n for n in names if n not in known]:
        raise ValueError(
            f"unknown reading(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(known)}"
        )
    return (DEFAULT, *(known[n] for n in dict.fromkeys(names) if n != DEFAULT.name))


def reading_by_name(name: str) -> Reading:
    """The reading ``name``: a single (:data:`SINGLES`), an alias (:data:`ALIASES`) or these
    joined by ``+`` (their combination, e.g. ``paper+body``); ValueError naming what is allowed."""
    known = {r.name: r for r in SINGLES}
    allowed = f"{', '.join([*ALIASES, *known])}, or these joined by '+'"
    if not isinstance(name, str) or not name.strip("+ "):
        raise ValueError(f"reading {name!r}: no name; allowed: {allowed}")
    # Each part is a single or an alias, which stands for its singles.
    parts = [single for part in name.split("+") for single in ALIASES.get(part, part).split("+")]
    if unknown := [part for part in name.split("+") if part not in known and part not in ALIASES]:
        raise ValueError(
            f"reading {name!r}: unknown {', '.join(map(repr, unknown))}; allowed: {allowed}"
        )
    joined = "+".join(parts)
    if len(parts) == 1:
        return known[joined]
    if len(set(parts)) != len(parts) or DEFAULT.name in parts:
        raise ValueError(
            f"reading {name!r} is {joined!r}; allowed: distinct singles other than the default "
            f"({allowed})"
        )
    return combine([known[part] for part in parts], joined)


def reading_jobs(plan: StudyPlan, reading: Reading) -> list[Job]:
    """Every job of the ``all`` suite under ``reading`` (duplicates between studies included)."""
    return [job for group in study_jobs(plan, reading).values() for job in group]


Optima = Mapping[str, Mapping[str, Sequence[Sequence[float]]]]
"""reading -> study -> the normalised optimum of each of its jobs, in order (:func:`optima_of`)."""


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
    """Each paper study's jobs under ``reading``, by study name: the studies' own without
    ``continuation`` (and for the default or a search reading). With it, a job the default
    shares or of a task in ``full`` stays; any other continues from the optima at its position
    of the readings :func:`continued_from` names (a stand-in without ``optima``)."""
    p = replace(plan, reading=reading)
    if continuation is None or reading == DEFAULT or reading.search is not None:
        return {name: study.jobs(p) for name, study in PAPER_STUDIES.items()}
    sources = continued_from(reading)
    if missing := [name for name in sources if optima is not None and name not in optima]:
        raise ValueError(f"reading {reading.name!r} continues from {missing}, not run yet")
    base = replace(plan, reading=DEFAULT)
    out: dict[str, list[Job]] = {}
    for name, study in PAPER_STUDIES.items():
        out[name] = []
        pairs = zip(study.jobs(base), study.jobs(p), strict=True)
        for i, (default_job, job) in enumerate(pairs):  # i: the job's position in its study
            if job.key != default_job.key and job.task not in full:
                at = None if optima is None else {tuple(optima[s][name][i]): None for s in sources}
                job = continuation.job(job, None if at is None else list(at))
            out[name].append(job)
    return out


def optima_of(
    records: Mapping[Job, Record] | Path, jobs: Mapping[str, Mapping[str, list[Job]]]
) -> dict[str, dict[str, list[list[float]]]]:
    """:data:`Optima` of the readings in ``jobs`` (reading -> study -> jobs) from their
    ``records`` (job -> record), or from the store at ``records`` (every record present)."""
    if not isinstance(records, Mapping):
        flat = [job for by_study in jobs.values() for group in by_study.values() for job in group]
        records = job_records(records, flat)
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
    """(continued job, the same job in full) of the check studies' jobs at the check seeds that
    the reading does not share with the default: the continuation's bias check."""
    continued = study_jobs(plan, reading, continuation, optima)
    full = study_jobs(plan, reading)
    pairs = (
        (c, f)
        for name in continuation.check_studies
        for c, f in zip(continued[name], full[name], strict=True)
        if c != f and f.seed in continuation.check_seeds
    )
    return list(dict.fromkeys(pairs))


def full_tasks(summary: Sequence[Row], continuation: Continuation) -> dict[str, dict[str, str]]:
    """reading -> task -> why its jobs run in full: the bias check (:func:`check_summary`
    rows) found them short by more than ``full_median`` or ``full_lowest``, or a continued
    optimum infeasible where the full run's is feasible."""
    out: dict[str, dict[str, str]] = {}
    limits = {"median": continuation.full_median, "lowest": continuation.full_lowest}
    for row in summary:
        if row["reading"] == "all" or row["task"] == "all":
            continue
        why = [
            f"{k} {100 * row[k]:+.1f} %" for k, v in limits.items() if row["pairs"] and row[k] < v
        ]
        if count := row["infeasible_continued"]:
            why.append(f"{count} continued optim{'um' if count == 1 else 'a'} infeasible")
        if why:
            out.setdefault(row["reading"], {})[row["task"]] = ", ".join(why)
    return out


def combinations(
    default: ReadingResult, singles: Sequence[ReadingResult]
) -> tuple[list[Reading], str]:
    """The combination readings the singles' results point to, and the rule's outcome in words
    (docs/reproduction.md, "Readings"): the gainers (more agreeing claims than the default, best
    first), each joining unless it conflicts with one before it, combine as their best two and
    as all; the best gainer also pairs with every other single it does not conflict with (a
    change that loses claims alone can win them beside another). Duplicates are dropped."""
    base = default.agree
    gainers = sorted(
        (r for r in singles if r.reading != default.reading and r.agree > base),
        key=lambda r: -r.agree,
    )
    chosen: list[ReadingResult] = []
    skipped: list[str] = []
    for candidate in gainers:
        if clash := [c.reading.name for c in chosen if candidate.reading.conflicts(c.reading)]:
            skipped.append(f"{candidate.reading.name} (conflicts with {', '.join(clash)})")
        else:
            chosen.append(candidate)
    gains = ", ".join(f"{r.reading.name} (+{r.agree - base})" for r in gainers) or "none"
    words = f"singles that raised the agreeing claims over the default ({base}): {gains}"
    if skipped:
        words += f"; left out: {', '.join(skipped)}"
    # the best two and all (the same group when there are two: duplicates are dropped below)
    groups = [group for group in (chosen[:2], chosen) if len(group) >= 2]
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
