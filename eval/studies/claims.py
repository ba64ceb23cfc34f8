"""The paper's claims (docs/model.md §9) as checkable rows, and the rules that decide agreement.

Agreement rules (stated in every report):

* ``number``: our median over seeds lies within ±20 % of the paper's number.
* ``range``: our median lies inside the paper's range widened by 20 % of its ends.
* ``trend``: Spearman's ρ between the condition and the per-condition medians is ≥ 0.5 in the
  claimed direction (ρ ≤ −0.5 for "falls"); the monotonic fraction (steps in the claimed
  direction / steps) is reported beside it.
* ``follows``: Spearman's ρ between two quantities' per-condition medians is ≥ 0.5.
* ``location``: the condition of the extremum of the per-condition medians is within one
  sweep step (±0.25 m/s) of the paper's.
* ``angle``: our median phase lies within ±15° of the paper's.
* ``phase``: "in phase" means a median |ΔΦ| < 15°, "out of phase" ≥ 15°.
* ``compare``: the claimed order holds between the medians at every condition compared.

"best" is the same statistic computed from the best seed of each condition (the seed with
the best objective), i.e. what a "take the best of N runs" protocol, like the paper's, gives.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from scipy.stats import spearmanr

from eval.studies.tables import Spread

Verdict = Literal["agrees", "differs", "not run", "no data"]
Rule = Literal["number", "range", "trend", "follows", "location", "angle", "phase", "compare"]

RELATIVE_TOLERANCE = 0.20
TREND_RHO = 0.5
LOCATION_TOLERANCE = 0.25  # m/s, one step of the paper's sweep
ANGLE_TOLERANCE = 15.0  # deg
IN_PHASE = 15.0  # deg

RULES: dict[str, str] = {
    "number": "median within ±20 % of the paper",
    "range": "median inside the paper's range widened by 20 %",
    "trend": "Spearman ρ(condition, medians) ≥ 0.5 in the claimed direction",
    "follows": "Spearman ρ between the two quantities' medians ≥ 0.5",
    "location": "extremum of the medians within ±0.25 m/s of the paper's",
    "angle": "median within ±15° of the paper's",
    "phase": "in phase: median |ΔΦ| < 15°; out of phase: ≥ 15°",
    "compare": "the claimed order holds between medians at every condition",
}


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
    detail: str = ""
    """Extra numbers behind the verdict (e.g. the monotonic fraction, n feasible)."""
    note: str = ""
    """Why a difference is understood, when it is."""

    def ours(self) -> str:
        if math.isnan(self.median):
            return "–"
        text = f"{_fmt(self.median)}"
        if not (math.isnan(self.q25) or math.isnan(self.q75)):
            text += f" [{_fmt(self.q25)}, {_fmt(self.q75)}]"
        return f"{text} {self.unit}".strip()

    def best_text(self) -> str:
        return "–" if math.isnan(self.best) else f"{_fmt(self.best)} {self.unit}".strip()


def _fmt(value: float) -> str:
    return f"{value:.3g}"


def claim_id(base: str, method_index: int, method: str) -> str:
    """A claim's id: ``base`` for the first method of a study, ``base/method`` for the others."""
    return base if method_index == 0 else f"{base}/{method}"


@dataclass(frozen=True)
class VerdictCount:
    """How many of some claims agree, differ, or have no verdict (no data)."""

    agree: int
    differ: int
    undecided: int

    @property
    def decided(self) -> int:
        return self.agree + self.differ

    @classmethod
    def of(cls, claims: Iterable[Claim]) -> VerdictCount:
        verdicts = [c.verdict for c in claims]
        agree, differ = verdicts.count("agrees"), verdicts.count("differs")
        return cls(agree, differ, len(verdicts) - agree - differ)


def verdict(ok: bool | None) -> Verdict:
    return "no data" if ok is None else ("agrees" if ok else "differs")


def judge(value: float, test: Callable[[float], Any]) -> bool | None:
    """``test(value)`` as the agreement, None (no data) for a NaN value."""
    return None if math.isnan(value) else bool(test(value))


def spread_fields(s: Spread) -> dict[str, float]:
    """A spread's median, quartiles and best seed as :class:`Claim` fields."""
    return {"median": s.median, "q25": s.q25, "q75": s.q75, "best": s.best}


def seeds_feasible(s: Spread) -> str:
    """How many of the seeds were feasible, e.g. ``"3/5 seeds feasible"``."""
    return f"{s.n_feasible}/{s.n} seeds feasible"


# --- rule helpers: each returns (statistic from medians, statistic from best seeds, ok) ------
def close(value: float, paper: float) -> bool | None:
    """Within ±20 % of the paper's number (None for NaN)."""
    return judge(value, lambda v: abs(v - paper) <= RELATIVE_TOLERANCE * abs(paper))


def number(s: Spread, paper: float) -> bool | None:
    return close(s.median, paper)


def phase(value: float, in_phase: bool) -> bool | None:
    """In phase: |ΔΦ| < 15°; out of phase: |ΔΦ| ≥ 15° [deg] (None for NaN)."""
    return judge(value, lambda v: (v < IN_PHASE) == in_phase)


def angle(value: float, paper: float) -> bool | None:
    """Within ±15° of the paper's angle [deg] (None for NaN)."""
    return judge(value, lambda v: abs(v - paper) <= ANGLE_TOLERANCE)


def in_range(value: float, low: float, high: float) -> bool | None:
    if math.isnan(value):
        return None
    return (1.0 - RELATIVE_TOLERANCE) * low <= value <= (1.0 + RELATIVE_TOLERANCE) * high


def _finite(conditions: Sequence[float], values: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    x, y = np.asarray(conditions, float), np.asarray(values, float)
    keep = np.isfinite(y)
    return x[keep], y[keep]


def rho(x: Sequence[float], y: Sequence[float]) -> float:
    """Spearman's ρ of finite pairs (NaN with fewer than 3 pairs or a constant series)."""
    xa, ya = _finite(x, y)
    keep = np.isfinite(xa)
    xa, ya = xa[keep], ya[keep]
    if xa.size < 3 or np.ptp(ya) == 0.0 or np.ptp(xa) == 0.0:
        return math.nan
    return float(spearmanr(xa, ya).statistic)


def monotonic_fraction(x: Sequence[float], y: Sequence[float], direction: int) -> float:
    """Share of consecutive steps (in x order) that move in ``direction`` (+1 rise, −1 fall)."""
    xa, ya = _finite(x, y)
    order = np.argsort(xa)
    steps = np.diff(ya[order])
    return math.nan if steps.size == 0 else float(np.mean(np.sign(steps) == direction))


def trend(series: Mapping[float, Spread], direction: int) -> tuple[float, float, bool | None, str]:
    """ρ of the medians, ρ of the best seeds, agreement, detail text."""
    x = list(series)
    medians = [s.median for s in series.values()]
    bests = [s.best for s in series.values()]
    r, r_best = rho(x, medians), rho(x, bests)
    frac = monotonic_fraction(x, medians, direction)
    ok = None if math.isnan(r) else direction * r >= TREND_RHO
    return r, r_best, ok, f"monotonic fraction {frac:.2f}" if not math.isnan(frac) else ""


def location(
    series: Mapping[float, Spread], paper: float, kind: Literal["min", "max"]
) -> tuple[float, float, bool | None]:
    """Condition of the extremum of the medians and of the best seeds; within one step?"""

    def where(values: list[float]) -> float:
        xa, ya = _finite(list(series), values)
        if ya.size == 0:
            return math.nan
        return float(xa[np.argmin(ya) if kind == "min" else np.argmax(ya)])

    at = where([s.median for s in series.values()])
    at_best = where([s.best for s in series.values()])
    ok = None if math.isnan(at) else abs(at - paper) <= LOCATION_TOLERANCE + 1e-9
    return at, at_best, ok


# --- claim builders: a row's rule, statistics and agreement as ClaimBuilder.claim's arguments --
@dataclass(frozen=True)
class ClaimBuilder:
    """Builds one study's claims for one method: the id gets the method's suffix
    (:func:`claim_id`) and the verdict comes from the rule's agreement ``ok`` (None: no data)."""

    study: str
    method: str
    index: int
    """The method's place in the study's methods (0: ids without a suffix)."""

    def claim(
        self,
        cid: str,
        figure: str,
        statement: str,
        paper: str,
        *,
        rule: Rule,
        ok: bool | None = None,
        **fields: Any,
    ) -> Claim:
        """One row; ``fields`` are the other :class:`Claim` fields. The ``*_row`` functions
        below give a rule's arguments, e.g. ``claim(..., **trend_row(series, +1))``."""
        return Claim(
            id=claim_id(cid, self.index, self.method),
            study=self.study,
            figure=figure,
            statement=statement,
            paper=paper,
            rule=rule,
            verdict=verdict(ok),
            **fields,
        )


def trend_row(series: Mapping[float, Spread], direction: int, **fields: Any) -> dict[str, Any]:
    """``trend``: ρ between the condition and the medians (and the best seeds)."""
    r, r_best, ok, detail = trend(series, direction)
    return dict(rule="trend", ok=ok, median=r, best=r_best, unit="(ρ)", detail=detail, **fields)


def location_row(
    series: Mapping[float, Spread], paper: float, kind: Literal["min", "max"], **fields: Any
) -> dict[str, Any]:
    """``location``: the speed [m/s] of the extremum of the medians (and the best seeds)."""
    at, at_best, ok = location(series, paper, kind)
    return dict(rule="location", ok=ok, median=at, best=at_best, unit="m/s", **fields)


def spread_row(rule: Rule, s: Spread, ok: bool | None, **fields: Any) -> dict[str, Any]:
    """A row of one spread over seeds: its median, quartiles and best seed, and how many seeds
    were feasible as the detail (``fields`` override any of these)."""
    return {"rule": rule, "ok": ok, **spread_fields(s), "detail": seeds_feasible(s), **fields}


def number_row(s: Spread, paper: float, **fields: Any) -> dict[str, Any]:
    """``number``: the spread's median against the paper's number (see :func:`spread_row`)."""
    return spread_row("number", s, number(s, paper), **fields)


def compare_row(
    median: float, best: float, holds: Callable[[float], Any], **fields: Any
) -> dict[str, Any]:
    """``compare``: the claimed order ``holds(median)`` between medians."""
    return dict(rule="compare", ok=judge(median, holds), median=median, best=best, **fields)
