"""The paper's claims (docs/model.md §9) as checkable rows, and the rules that decide agreement.

Each study declares its claims once, as data (a ``CLAIMS`` table of :class:`ClaimSpec`); this
module judges and formats them all (:func:`judged`, :data:`TESTS`). Every claim is judged by its rule (:data:`RULES`) on the seeds' medians and on each condition's
best seed (what the paper's "best of N runs" gives); a verdict the bootstrap over seeds flips
is undecided (:data:`CONFIDENCE_RULE`), and a claim about what the model does not depend on is
not identifiable (:data:`IDENTIFIABILITY_RULE`)."""

from __future__ import annotations

import math
import operator
from collections import Counter
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np
from scipy.stats import spearmanr

from eval.studies.presets import fail
from eval.studies.tables import Rows, Spread, Sweep, pinned, spread, table4_bounds
from tandem_env import ModelOptions

Verdict = Literal["agrees", "differs", "undecided", "not identifiable", "not run", "no data"]
Rule = Literal["number", "range", "trend", "follows", "location", "angle", "phase", "compare"]

RELATIVE_TOLERANCE = 0.20
TREND_RHO = 0.5
LOCATION_TOLERANCE = 0.25  # m/s, one step of the paper's sweep
ANGLE_TOLERANCE = 15.0  # deg
IN_PHASE = 15.0  # deg

#: Bootstrap behind every verdict's confidence: resamples of the seeds, the share of them in
#: which a verdict may flip before it is undecided, and the fixed RNG seed (same records, same
#: verdicts).
BOOTSTRAP_RESAMPLES = 200
FLIP_THRESHOLD = 0.20
BOOTSTRAP_SEED = 0
CONFIDENCE_RULE = (
    f"each verdict (on the median and on the best seed) is recomputed on {BOOTSTRAP_RESAMPLES} "
    "bootstrap resamples of the seeds (at every condition its seeds drawn with replacement, a "
    "seed's vertical and horizontal optimisations together; fixed RNG seed, so the same records "
    f"give the same verdicts); a verdict that flips in more than {100 * FLIP_THRESHOLD:.0f} % of "
    "the resamples is **undecided** (the seeds run do not decide it) and counted apart; each "
    "verdict shows the share of resamples that flip it"
)

#: The fore/hind phase (Fig. 11): what the paper's phase claims are about.
PHASE = "fore/hind phase"
#: What a claim may be about that a reading of the model can lack: the quantity, and whether
#: the model under the options, at the flight speed [m/s] (None: forward flight), depends on it.
QUANTITIES: dict[str, Callable[[ModelOptions, float | None], bool]] = {
    PHASE: lambda options, speed: options.phase_resolved(speed)
}
IDENTIFIABILITY_RULE = (
    "a claim about a quantity the model does not depend on under the options run is **not "
    "identifiable**: every value of that quantity is an optimum, so what the seeds report is "
    "what the search left; it gets no agree/differ verdict and is counted apart. The "
    f"{PHASE} (K1-K3) is such a quantity except under the convected slipstream "
    "(`slipstream='convected'` with coupled induction and C_hf > 0, and not in hover under "
    "`hover_inflow='none'`; `ModelOptions.phase_resolved`, docs/model.md §5.7)"
)

#: A stroke parameter that one bound holds at every condition does not move with the
#: condition; its ρ would be undefined (a constant) or the noise within the bound's tolerance.
HELD_RULE = (
    "a stroke parameter pinned at the same Table 4 bound at every condition (at least 3; "
    "pinned as in the summary CSVs) does not move: its ρ is 0"
)
RULES: dict[str, str] = {
    "number": "median within ±20 % of the paper",
    "range": "median inside the paper's range widened by 20 %",
    "trend": f"Spearman ρ(condition, medians) ≥ 0.5 in the claimed direction; {HELD_RULE}",
    "follows": f"Spearman ρ between the two quantities' medians ≥ 0.5; {HELD_RULE}",
    "location": "extremum of the medians within ±0.25 m/s of the paper's",
    "angle": "median within ±15° of the paper's",
    "phase": "in phase: median |ΔΦ| < 15°; out of phase: ≥ 15°",
    "compare": "the claimed order holds between medians at every condition",
}


@dataclass(frozen=True)
class Dependence:
    """What of the model a claim is about: a quantity of :data:`QUANTITIES`, at the flight
    speed of the claim's optimisations."""

    quantity: str
    speed: float | None = None
    """The flight speed V [m/s] of the claim's optimisations; None: forward flight (V > 0)."""

    def __post_init__(self) -> None:
        if self.quantity not in QUANTITIES:
            fail("quantity", self.quantity, ", ".join(QUANTITIES), "Dependence")

    def resolved(self, options: ModelOptions) -> bool:
        """Whether the model under ``options`` depends on the quantity at this speed."""
        return QUANTITIES[self.quantity](options, self.speed)


@dataclass(frozen=True)
class Claim:
    """One row of the report's paper-vs-ours table."""

    id: str
    """Stable identifier, e.g. ``"S7"`` (tests look rows up by it)."""
    study: str
    figure: str
    """The paper's figure, e.g. ``"Fig. 6"``."""
    statement: str
    paper: str
    """The paper's number or statement."""
    rule: Rule
    median: float = math.nan
    """Our statistic from the seeds' medians (a value, ρ, a location, a fraction)."""
    q25: float = math.nan
    q75: float = math.nan
    best: float = math.nan
    """The same statistic from each condition's best seed."""
    unit: str = ""
    verdict: Verdict = "no data"
    """On the median, after the bootstrap (:func:`_settled`)."""
    best_verdict: Verdict = "no data"
    """On the best seed, after the bootstrap."""
    leaning: Verdict | None = None
    """The median's verdict on the seeds as run (None: the same as ``verdict``)."""
    best_leaning: Verdict | None = None
    flips: float = math.nan
    """Share of bootstrap resamples in which the median's verdict differs from ``leaning``
    (NaN: not resampled)."""
    best_flips: float = math.nan
    detail: str = ""
    """Extra numbers behind the verdict (e.g. the monotonic fraction, n feasible)."""
    note: str = ""
    """Why a difference is understood, when it is."""
    depends_on: tuple[Dependence, ...] = ()
    """What of the model the claim is about, where a reading can lack it (:func:`identifiable`)."""
    lacks: tuple[str, ...] = ()
    """The quantities of ``depends_on`` the model did not depend on in the run: the verdicts
    are then ``"not identifiable"`` (:func:`identifiable`)."""

    def __post_init__(self) -> None:
        for side in ("", "best_"):
            if getattr(self, f"{side}leaning") is None:
                object.__setattr__(self, f"{side}leaning", getattr(self, f"{side}verdict"))

    def verdict_text(self, best: bool = False) -> str:
        """The verdict with its confidence, e.g. ``undecided (leans differs, flips 35 %)``."""
        if self.lacks:
            return f"not identifiable (the model does not depend on the {', '.join(self.lacks)})"
        side = "best_" if best else ""
        verdict, leaning, flips = (getattr(self, side + k) for k in ("verdict", "leaning", "flips"))
        if math.isnan(flips):
            return verdict
        share = f"flips {100.0 * flips:.0f} %"
        if verdict == "undecided":
            return f"undecided (leans {leaning}, {share})"
        return f"{verdict} ({share})"

    def ours(self) -> str:
        if math.isnan(self.median):
            return "–"
        text = f"{self.median:.3g}"
        if not (math.isnan(self.q25) or math.isnan(self.q75)):
            text += f" [{self.q25:.3g}, {self.q75:.3g}]"
        return f"{text} {self.unit}".strip()

    def best_text(self) -> str:
        return "–" if math.isnan(self.best) else f"{self.best:.3g} {self.unit}".strip()


@dataclass(frozen=True)
class VerdictCount:
    """How many claims agree, differ, are undecided, not identifiable or without a verdict."""

    agree: int
    differ: int
    undecided: int
    no_data: int
    not_identifiable: int = 0

    decided = property(lambda self: self.agree + self.differ, doc="Claims that agree or differ.")

    @classmethod
    def of(cls, claims: Iterable[Claim], best: bool = False) -> VerdictCount:
        """Counts of the verdicts on the median (on the best seed if ``best``)."""
        n = Counter(c.best_verdict if best else c.verdict for c in claims)
        unknowable = n["not identifiable"]
        rest = n.total() - n["agrees"] - n["differs"] - n["undecided"] - unknowable
        return cls(n["agrees"], n["differs"], n["undecided"], rest, unknowable)

    def text(self) -> str:
        """``3 agree, 2 differ, 4 undecided, 3 not identifiable, 1 no data``."""
        return (
            f"{self.agree} agree, {self.differ} differ, {self.undecided} undecided, "
            f"{self.not_identifiable} not identifiable, {self.no_data} no data"
        )


#: How each rule judges a statistic against the claim's target (:attr:`ClaimSpec.target`).
TESTS: dict[str, Callable[[float, Any], bool]] = {
    "number": lambda v, paper: abs(v - paper) <= RELATIVE_TOLERANCE * abs(paper),
    "range": lambda v, ends: (
        (1 - RELATIVE_TOLERANCE) * ends[0] <= v <= (1 + RELATIVE_TOLERANCE) * ends[1]
    ),
    "trend": lambda rho, direction: direction * rho >= TREND_RHO,
    "location": lambda at, paper: abs(at - paper) <= LOCATION_TOLERANCE + 1e-9,
    "angle": lambda v, paper: abs(v - paper) <= ANGLE_TOLERANCE,
    "phase": lambda v, in_phase: (v < IN_PHASE) == in_phase,
    "compare": lambda v, order: {">": operator.gt, "==": operator.eq}[order[0]](v, order[1]),
}
TESTS["follows"] = TESTS["trend"]  # a ρ between two quantities, judged as a trend's


def judge(value: float, rule: Rule, target: Any) -> bool | None:
    """Whether ``value`` agrees with ``target`` under ``rule`` (:data:`TESTS`); None for NaN."""
    return None if math.isnan(value) else bool(TESTS[rule](value, target))


#: A claim's statistic: :class:`Claim` fields (``median``, ``best``, ``q25``, ``q75``, ``unit``,
#: ``detail``, ...), or None where the claim is not made (what it compares is not run).
Stats = dict[str, Any] | None
#: A claim's statistic from a study's view of one method's rows and the claim's target.
Measure = Callable[[Any, Any], Stats]


@dataclass(frozen=True)
class ClaimSpec:
    """One claim of the paper, declared once: what the report's row says and how it is judged;
    ``measure(view, target)`` gives its statistic from a study's view of one method's rows."""

    id: str
    figure: str
    statement: str
    """The claim; ``{name}`` fields are the preset's (e.g. ``{phase_speed:g}``)."""
    paper: str
    rule: Rule
    target: Any
    """What the rule compares with (:data:`TESTS`): the paper's number [its unit], range
    (low, high), location [m/s] or angle [deg]; a trend's direction (+1 rises, −1 falls);
    whether in phase; a compare rule's (order, value)."""
    measure: Measure
    note: str = ""
    """Why a difference is understood, when it is."""

    def claim(self, study: str, view: Any, method: str, index: int, words: Mapping) -> Claim | None:
        """The row of ``method`` (ids ``S7`` for the first method, ``S7/random`` for the
        others), judged on the median and the best seed; None where it is not made."""
        fields = self.measure(view, self.target)
        if fields is None:
            return None
        row = {"statement": self.statement.format_map(words), "note": self.note, **fields}
        said: dict[bool | None, Verdict] = {True: "agrees", False: "differs", None: "no data"}
        ok = lambda k: said[judge(row.get(k, math.nan), self.rule, self.target)]  # noqa: E731
        cid = self.id if index == 0 else f"{self.id}/{method}"
        own = {"study": study, "figure": self.figure, "paper": self.paper, "rule": self.rule}
        return Claim(cid, **own, verdict=ok("median"), best_verdict=ok("best"), **row)


def judged(
    specs: Iterable[ClaimSpec], study: str, view: Any, method: str, index: int, words: Mapping = {}
) -> list[Claim]:
    """The claims ``specs`` make of one method's ``view`` (:meth:`ClaimSpec.claim`)."""
    found = (spec.claim(study, view, method, index, words) for spec in specs)
    return [c for c in found if c is not None]


def seeds_feasible(s: Spread) -> str:
    """How many of the seeds were feasible, e.g. ``"3/5 seeds feasible"``."""
    return f"{s.n_feasible}/{s.n} seeds feasible"


def _finite(x: Sequence[float], y: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """The pairs of ``x`` and ``y`` where both are finite."""
    xa, ya = np.asarray(x, float), np.asarray(y, float)
    keep = np.isfinite(xa) & np.isfinite(ya)
    return xa[keep], ya[keep]


def rho(x: Sequence[float], y: Sequence[float]) -> float:
    """Spearman's ρ of finite pairs (NaN with fewer than 3 pairs or a constant series)."""
    xa, ya = _finite(x, y)
    if xa.size < 3 or np.ptp(ya) == 0.0 or np.ptp(xa) == 0.0:
        return math.nan
    return float(spearmanr(xa, ya).statistic)


# --- statistics: what a ClaimSpec's measure gives ----------------------------------------------
def spread_stats(s: Spread, **fields: Any) -> dict[str, Any]:
    """One spread over seeds: median, quartiles, best seed and the feasible seeds as the detail
    (``fields`` override these)."""
    stats = {"median": s.median, "q25": s.q25, "q75": s.q75, "best": s.best}
    return {**stats, "detail": seeds_feasible(s), **fields}


def trend_stats(
    series: Sweep, direction: int, against: Sweep | None = None, **fields: Any
) -> dict[str, Any]:
    """ρ between the condition and the medians (and the best seeds), the medians' monotonic
    fraction (share of steps in the condition's order that move in ``direction``) as the
    detail; with ``against``, ρ between its medians (best seeds) and these at their common
    conditions, no detail; ``fields`` override these (:func:`held_at_bound`'s)."""
    common = [c for c in series if against is None or c in against]
    x = lambda k: common if against is None else [getattr(against[c], k) for c in common]  # noqa: E731
    stats = {k: rho(x(k), [getattr(series[c], k) for c in common]) for k in ("median", "best")}
    xa, ya = _finite(common, [series[c].median for c in common])
    steps = np.diff(ya[np.argsort(xa)])
    frac = math.nan if steps.size == 0 else float(np.mean(np.sign(steps) == direction))
    detail = "" if against is not None or math.isnan(frac) else f"monotonic fraction {frac:.2f}"
    return {**stats, "unit": "(ρ)", "detail": detail, **fields}


def held_at_bound(rows: Sequence[Mapping[str, Any]], quantity: str) -> dict[str, Any]:
    """What :data:`HELD_RULE` changes in a ``trend`` or ``follows`` row of ``quantity`` over
    one series' rows: ρ = 0 for the medians and/or the best seeds that one Table 4 bound holds
    at every condition (``tables.pinned``), with a ``detail`` and ``note`` naming it; empty
    where none does or below 3 conditions."""
    conditions = sorted({float(r["condition"]) for r in rows})
    bounds = table4_bounds(quantity)
    if len(conditions) < 3 or bounds is None:
        return {}
    sides: dict[str, set[str]] = {"median": set(), "best": set()}
    for c in conditions:
        members = [r for r in rows if float(r["condition"]) == c]
        top = spread(members, quantity).best_seed
        sides["median"].add(pinned(members, quantity))
        sides["best"].add(pinned([r for r in members if r["seed"] == top], quantity))
    held = {k: side.pop() for k, side in sides.items() if len(side) == 1 and "" not in side}
    if not held:
        return {}
    side = held.get("median", held.get("best", ""))
    value = bounds[0] if side == "lower" else bounds[1]
    on = " and ".join({"median": "the medians", "best": "the best seeds"}[k] for k in held)
    return {
        **dict.fromkeys(held, 0.0),
        "detail": f"{on} at the {side} Table 4 bound ({value:g}) at every condition: ρ = 0",
        "note": f"the optimum presses against Table 4's {side} bound at every condition: the "
        "bound, not the condition, sets the parameter, so it follows no trend (differs)",
    }


def location_stats(series: Sweep, kind: Literal["min", "max"], **fields: Any) -> dict[str, Any]:
    """The condition [m/s] of the extremum of the medians (and of the best seeds)."""

    def where(values: list[float]) -> float:
        xa, ya = _finite(list(series), values)
        return float(xa[np.argmin(ya) if kind == "min" else np.argmax(ya)]) if ya.size else math.nan

    at = {k: where([getattr(s, k) for s in series.values()]) for k in ("median", "best")}
    return {**at, "unit": "m/s", **fields}


# --- confidence: the bootstrap over seeds ------------------------------------------------------
def _strata(rows: Sequence[Mapping[str, Any]]) -> list[tuple[list[int], dict[int, list[dict]]]]:
    """(seeds, {seed: rows}) per condition of each series (method, task, planform; objectives
    together, so a seed's two accelerating optimisations stay paired), in a fixed order."""
    groups: dict[tuple[str, ...], dict[int, list[dict]]] = {}
    for row in rows:
        key = tuple(str(row.get(k)) for k in ("method", "task", "planform", "condition"))
        groups.setdefault(key, {}).setdefault(int(row["seed"]), []).append(dict(row))
    return [(sorted(groups[k]), groups[k]) for k in sorted(groups)]


def resample(
    strata: Sequence[tuple[list[int], Mapping[int, list[dict]]]], rng: np.random.Generator
) -> Rows:
    """One bootstrap resample: at every condition as many seeds as it has, drawn with
    replacement; the k-th draw's rows get seed k (a seed drawn twice counts twice)."""
    out: Rows = []
    for seeds, by_seed in strata:
        for k, i in enumerate(rng.integers(0, len(seeds), size=len(seeds))):
            out += [{**row, "seed": k} for row in by_seed[seeds[i]]]
    return out


def with_confidence(
    claims_of: Callable[[Rows], list[Claim]],
    rows: Sequence[Mapping[str, Any]],
    resamples: int = BOOTSTRAP_RESAMPLES,
    seed: int = BOOTSTRAP_SEED,
) -> list[Claim]:
    """``claims_of(rows)`` (tidy rows) with each verdict's confidence (:data:`CONFIDENCE_RULE`):
    rerun on ``resamples`` resamples of the seeds (:func:`resample`, RNG seeded by ``seed``); a
    claim missing from a resample counts as flipped."""
    claims = claims_of([dict(r) for r in rows])
    if not claims or resamples <= 0:
        return claims
    strata, rng = _strata(rows), np.random.default_rng(seed)
    flips = {c.id: np.zeros(2) for c in claims}
    for _ in range(resamples):
        again = {c.id: c for c in claims_of(resample(strata, rng))}
        for c in claims:
            o = again.get(c.id)
            flips[c.id] += (
                1.0 if o is None else (o.verdict != c.verdict, o.best_verdict != c.best_verdict)
            )
    return [_settled(c, *(flips[c.id] / resamples)) for c in claims]


def _settled(c: Claim, flips: float, best_flips: float, lacks: tuple[str, ...] = ()) -> Claim:
    """``c`` with each verdict as run its leaning and its share of flipping resamples (NaN for a
    verdict without data), the confidence rule deciding the verdict: a decided one that flips in
    more than :data:`FLIP_THRESHOLD` of them is ``"undecided"``, any other stays; ``lacks``:
    every verdict "not identifiable", without a confidence."""
    sides = {}
    for side, share in (("", flips), ("best_", best_flips)):
        said: Verdict = "not identifiable" if lacks else getattr(c, f"{side}verdict")
        share = math.nan if lacks or said in ("no data", "not run") else float(share)
        decided = said in ("agrees", "differs")
        sides |= {
            f"{side}verdict": "undecided" if decided and share > FLIP_THRESHOLD else said,
            f"{side}leaning": said,
            f"{side}flips": share,
        }
    return replace(c, **sides, lacks=lacks)


def identifiable(claims: Iterable[Claim], options: ModelOptions) -> list[Claim]:
    """The claims with the verdicts :data:`IDENTIFIABILITY_RULE` gives under the study's model
    ``options``: ``"not identifiable"``, without a confidence, where the model does not depend
    on a quantity of :attr:`Claim.depends_on` (the statistics stay)."""
    out = []
    for c in claims:
        lacks = tuple(dict.fromkeys(d.quantity for d in c.depends_on if not d.resolved(options)))
        out.append(_settled(c, math.nan, math.nan, lacks) if lacks else c)
    return out


def study_claims(
    rows: Sequence[Mapping[str, Any]],
    methods: Sequence[str],
    claims_of: Callable[[Rows, str, int], list[Claim]],
    *,
    options: ModelOptions,
) -> list[Claim]:
    """Every method's claims (``claims_of(rows, method, index)``), each method's bootstrap over
    its own rows (:func:`with_confidence`), judged identifiable under ``options``."""
    found: list[Claim] = []
    for i, m in enumerate(methods):
        own = [r for r in rows if r["method"] == m]
        found += with_confidence(lambda r, m=m, i=i: claims_of(r, m, i), own)
    return identifiable(found, options)
