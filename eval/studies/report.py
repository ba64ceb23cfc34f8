"""The reproduction report: every claim of the paper (docs/model.md §9) beside ours, plus figures;
no timestamps or timings (those are in ``manifest.json``), so the same command gives the same file.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict
from operator import attrgetter
from pathlib import Path
from typing import Any

from eval.studies.base import StudyOutput, StudyPlan
from eval.studies.claims import CONFIDENCE_RULE, IDENTIFIABILITY_RULE, RULES, Claim, VerdictCount
from eval.studies.tables import PINNED_SHARE, pinned_parameters
from tandem_env import BOUND_TOLERANCE, PARAMETER_NAMES
from tandem_env.io.files import write_json_atomic, write_text_atomic
from tandem_env.physics.insect import describe_insect

UNDERSTOOD = {
    "thrust_split": (
        '**Thrust and drag (`thrust_split="sign"`, the default).** The paper does not define T '
        "and D precisely. With the literal reading (T and D are the cycle means of the forward "
        "and rearward parts of each wing's horizontal force, docs/model.md §7) the level-flight "
        "constraint T = D fixes only the net force, and T measures the fore-aft swing of the "
        "wing force: an optimiser raises η = TV/P by raising that swing. Optimised η is "
        "therefore well above the paper's 12.7 %, and grows with the budget. At 1.5 m/s, 8 "
        "seeds of CMA-ES with 16 000 evaluations and the polish give a median η of 46.2 % "
        '(44.3-47.1 %), and the physically clean reading `thrust_split="body"` 3.3 % '
        "(2.1-3.7 %; both docs/efficiency.md, absolute power). Neither reproduces 12.7 %; the "
        "trend claims are the meaningful comparison."
    ),
    "spread": (
        "**Seed-to-seed spread.** The 28-parameter search has many separate basins (docs/model.md "
        "§9): runs from different seeds settle in different ones, so medians over seeds "
        "are noisy, and per-condition medians can break a trend the best seeds follow. The "
        "paper reports one optimum per condition; its numbers compare most directly with our "
        "*best* column. Where the searches warm-start from the reference table (*Against the "
        "reference table*), the seeds end on its optimum or above it and hardly spread: the "
        "median is then the best known optimum, not a cold search's typical result."
    ),
    "objective": (
        "**What is optimised.** Level flight maximises η only; power, frequency and φ_m at the "
        "η-optimum are by-products, so the paper's power minimum at 1.5 m/s (Fig. 5) need not "
        "appear. Accelerating flight maximises F̄_v and F̄_h in two separate optimisations "
        "(maximising F̄_a of one stroke is degenerate, docs/model.md §7)."
    ),
    "excess": (
        "**F̄_h above F̄_v.** Both accelerating optima spend the power on about the same total "
        "wing force |F| and only point it differently: F̄_v = |F|/W − 1 subtracts the whole "
        "weight, while the horizontal optimum carries the weight as a perpendicular component, "
        "F̄_h = sqrt((|F|/W)² − 1), which is larger for any |F| > W. The paper's F̄_v > F̄_h "
        "cannot come from this geometry; its F_h (Eq. 24) is not defined precisely enough to "
        "say what limited it. Our |F|/W at a given power is also lower than the paper's "
        "(not explained; candidates in docs/reproduction.md)."
    ),
    "phase": (
        "**Phases.** The weaving phase Φ_φ of each wing is free over ±180° (Table 4). Under the "
        'default mean slipstream (`slipstream="mean"`) the model does not depend on the '
        "fore/hind phase at all (docs/model.md §5.3, §5.7): every lag is an optimum, the lag a "
        "seed reports is what its search left, and K1-K3 are not identifiable. Under "
        '`slipstream="convected"` the hind-wing sees the fore-wing\'s wake over the cycle and '
        "the lag matters; even there the fore/hind difference is a property of the optimum only "
        "where the objective depends on it strongly, so with few seeds the median ΔΦ is noisy."
    ),
}


#: How every figure marks what it draws (the report's Figures section).
FIGURE_KEY = (
    "Per series: the median over the feasible seeds (line), the inter-quartile range (band), "
    "each seed (dot), the best seed (star). The paper's stated values are black markers named "
    "in the legend; a value derived from a statement of the paper is an open diamond whose "
    "legend says how it was derived; grey dashed lines are a stroke parameter's Table 4 bounds; "
    "the tip paths' arrowheads point the way the tip travels."
)


def table_row(cells: Iterable[object]) -> str:
    """One Markdown table row, each cell as text, escaped."""
    return "| " + " | ".join(str(x).replace("|", "\\|").replace("\n", " ") for x in cells) + " |"


def table_head(titles: Sequence[str]) -> list[str]:
    """A Markdown table's heading row and the rule under it, as wide as the titles."""
    return [table_row(titles), "|" + "---|" * len(titles)]


#: A column of a Markdown table: its title and its cell's text in a row.
Column = tuple[str, Callable[[Any], str]]


def markdown_table(columns: Sequence[Column], rows: Iterable[Any]) -> list[str]:
    """A Markdown table (lines): the titles, the rule under them and one line per row."""
    cells = [[cell(row) for _, cell in columns] for row in rows]
    return [*table_head([t for t, _ in columns]), *map(table_row, cells)]


#: The paper-vs-ours table's columns, one row per claim.
CLAIM_COLUMNS: tuple[Column, ...] = (
    ("id", attrgetter("id")),
    ("figure", attrgetter("figure")),
    ("claim", attrgetter("statement")),
    ("paper", attrgetter("paper")),
    ("ours: median [IQR]", Claim.ours),
    ("best seed", Claim.best_text),
    ("rule", attrgetter("rule")),
    ("verdict: median", Claim.verdict_text),
    ("verdict: best seed", lambda c: c.verdict_text(best=True)),
)


def claims_table(claims: Sequence[Claim]) -> str:
    """The paper-vs-ours Markdown table, one row per claim."""
    return "\n".join(markdown_table(CLAIM_COLUMNS, claims))


#: The claims as data beside report.md (:func:`write_report`; ``eval/numbers/quick_claims.py``).
CLAIMS_FILE = "claims.json"


def claims_data(claims: Sequence[Claim]) -> dict[str, Any]:
    """The claims as JSON: each claim's fields (statistics, verdicts before and after the
    bootstrap, its flips; NaN as null) and its ``cells`` in the paper-vs-ours table, by title."""
    nan = lambda v: None if isinstance(v, float) and math.isnan(v) else v  # noqa: E731
    cells = lambda c: {t: cell(c) for t, cell in CLAIM_COLUMNS}  # noqa: E731
    rows = [{**{k: nan(v) for k, v in asdict(c).items()}, "cells": cells(c)} for c in claims]
    return {"claims": rows}


def verdict_summary(claims: Sequence[Claim]) -> list[str]:
    """The verdict counts on the median and on the best seed, with the undecided by id."""
    lines = []
    for best, name in ((False, "the median"), (True, "the best seed")):
        counts = VerdictCount.of(claims, best=best)

        def ids(verdict: str, best: bool = best) -> str:
            found = [c.id for c in claims if (c.best_verdict if best else c.verdict) == verdict]
            return f" ({', '.join(found)})" if found else ""

        lines.append(
            f"- on {name}: {counts.agree} of {counts.decided} decided claims agree; "
            f"{counts.undecided} undecided{ids('undecided')}, "
            f"{counts.not_identifiable} not identifiable{ids('not identifiable')}, "
            f"{counts.no_data} without data"
        )
    return lines


def agreement_rules() -> list[str]:
    """The agreement rules and the confidence rule (Markdown lines)."""
    return [
        *[f"- `{name}`: {text}" for name, text in RULES.items()],
        f"- confidence: {CONFIDENCE_RULE}.",
        f"- identifiability: {IDENTIFIABILITY_RULE}.",
    ]


def insect_line(plan: StudyPlan) -> str:
    """Which insect every job of the plan flies (``--insect``)."""
    return f"- insect: {describe_insect(plan.insect)}"


def settings_lines(plan: StudyPlan) -> list[str]:
    p, search = plan.preset, plan.reading.search
    if search is None:
        batch = f"; PSO swarm {p.swarm_size}" if "pso" in plan.methods else ""
    else:  # the reading's search replaces the preset's method, budgets and batch
        batch = f"; search of the reading: {search.describe()}"
    return [
        f"- preset `{p.name}`: {p.description}",
        f"- methods: {', '.join(f'`{m}`' for m in plan.methods)}; seeds {list(p.seeds)}; "
        f"budgets {plan.budget('level')} (level) and {plan.budget('accelerate')} (accelerating) "
        f"model evaluations per optimisation{batch}",
        f"- speeds {list(p.speeds)} m/s, powers {list(p.powers)} W/kg; wing shape at "
        f"{list(p.shape_speeds)} m/s and {list(p.shape_powers)} W/kg; kinematics at "
        f"{p.kinematics_speed:g} m/s and {p.kinematics_power:g} W/kg ({p.kinematics_objective})",
        (
            '- model: defaults of `tandem_env.ModelOptions` (thrust_split = "sign", coupled '
            "induction, absolute power)"
            if not plan.reading.changes()
            else f"- model: reading `{plan.reading.name}` ({plan.reading.describe_changes()}; "
            f"defaults otherwise): {plan.reading.description}"
        )
        + (f", env kwargs {dict(p.env_kwargs)}" if p.env_kwargs else ""),
        insect_line(plan),
        "- statistics over the feasible seeds of each condition; *best seed* = the seed with the "
        "best objective",
    ]


def section(title: str, *lines: str, level: int = 2) -> list[str]:
    """A Markdown section (lines): its heading of ``level``, a blank line, ``lines``, a blank."""
    return [f"{'#' * level} {title}", "", *lines, ""]


def write_report(
    path: Path, plan: StudyPlan, outputs: Sequence[StudyOutput], all_studies: Sequence[str]
) -> Path:
    """Write the report to ``path`` (atomically) and return it: settings, rules, every claim
    beside ours, the pinned parameters, the studies not run and the figures; and the claims as
    data beside it (:data:`CLAIMS_FILE`)."""
    base = path.parent
    claims = [c for o in outputs for c in o.claims]
    rows = [r for o in outputs for r in o.rows]
    parts = [
        '# Reproduction report: Faisal & Filippone, "Aerodynamic Model for Tandem Flapping Wings"',
        "",
        *settings_lines(plan),
        "",
        *section("Agreement rules", *agreement_rules()),
        *section("Paper vs ours", *verdict_summary(claims), "", claims_table(claims)),
    ]
    if notes := [c for c in claims if c.detail or c.note]:
        texts = [f"- **{c.id}**: {'; '.join(t for t in (c.detail, c.note) if t)}" for c in notes]
        parts += section("Notes on the rows", *texts, level=3)
    parts += section("Against the reference table", *plan.table_lines(rows))
    parts += section("Understood differences", *[f"- {t}" for t in UNDERSTOOD.values()])
    parts += pinned_section(rows)
    preset = plan.preset.name
    if missing := [n for n in all_studies if n not in {o.name for o in outputs}]:
        rerun = [f"- `{n}`: `python -m eval study {n} --preset {preset}`" for n in missing]
        parts += section("Not run", *rerun)
    parts += section("Figures", FIGURE_KEY)
    for o in outputs:
        data = ", ".join(file_link(f, base) for f in o.files)
        parts += section(o.title, f"Data: {data}", level=3)
        for caption, figure in o.figures:
            parts += [figure_markdown(caption, figure, base), ""]
    write_text_atomic(path, "\n".join(parts))
    write_json_atomic(base / CLAIMS_FILE, claims_data(claims))
    return path


def pinned_section(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The parameters pinned at a Table 4 bound, one line per parameter and bound (Markdown)."""
    found = pinned_parameters(rows)
    text = (
        f"A parameter is pinned at a condition when more than {PINNED_SHARE:.0%} of the feasible "
        f"seeds put it within {BOUND_TOLERANCE:.0%} of its Table 4 range of a bound "
        "(`pinned` in the summary CSVs, `at_bounds` per seed in the tidy CSVs); a bound the "
        "optimum presses against is a limit of Table 4, not of the flyer."
    )
    lines = section("Parameters pinned at Table 4 bounds", text)
    places: dict[tuple[str, str, float], dict[tuple[str, str], list[str]]] = {}
    for r in sorted(found, key=lambda r: (PARAMETER_NAMES.index(r["parameter"]), r["bound"])):
        series = f"{r['task']} {r['objective']}, {r['planform']} ({r['method']})"
        at = places.setdefault((r["parameter"], r["bound"], r["value"]), {})
        where = f"{r['condition']:g} ({r['share']:.0%})"
        at.setdefault((series, r["condition_unit"]), []).append(where)
    for (name, bound, value), series in places.items():
        where = "; ".join(f"{s} at {', '.join(c)} {unit}" for (s, unit), c in series.items())
        lines.append(f"- `{name}` at its {bound} bound {value:g}: {where}")
    return [*lines, *([] if found else ["- none"]), ""]


def figure_markdown(caption: str, path: Path, base: Path) -> str:
    """A figure in the report: embedded, or linked for a PDF (Markdown viewers cannot show it)."""
    target = Path(os.path.relpath(path, base)).as_posix()
    return f"[{caption} (PDF)]({target})" if path.suffix == ".pdf" else f"![{caption}]({target})"


def file_link(path: Path, base: Path) -> str:
    """A Markdown link to ``path``, named by its path relative to ``base``."""
    target = Path(os.path.relpath(path, base)).as_posix()
    return f"[`{target}`]({target})"
