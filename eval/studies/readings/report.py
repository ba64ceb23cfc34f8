"""The readings study's report (:mod:`eval.studies.readings`), from the generic report's pieces
(:mod:`eval.studies.report`), and the claims × readings matrix it shows: one row per claim, one
column per reading, each cell the median's verdict by colour and glyph (:data:`VERDICT_STYLE`,
readable without colour vision); a black frame flags a verdict changed from the first (default)
reading."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.colors import ListedColormap
from matplotlib.patches import Patch, Rectangle

from eval.figures import PALETTE, legend, save
from eval.studies import report as study_report
from eval.studies.readings.plan import COUNTS, HEADLINES, ReadingResult
from eval.studies.tables import Row
from tandem_env.io.files import write_text_atomic

#: The readings study's goal: a reading under which this many of the paper's claims agree.
READINGS_GOAL = 16


def _num(value: float, fmt: str = ".3g") -> str:
    return "–" if math.isnan(value) else f"{value:{fmt}}"


#: The readings table's columns, one row per reading.
READING_COLUMNS: tuple[study_report.Column, ...] = (
    ("reading", lambda r: f"`{r.reading.name}`"),
    ("changes from the default", lambda r: r.reading.describe_changes()),
    *((title, lambda r, k=k: str(getattr(r.counts, k))) for k, title in COUNTS.items()),
    *((k, lambda r, k=k: _num(r.headline()[k])) for k in HEADLINES),
)


def reading_moves(default: ReadingResult, other: ReadingResult) -> list[str]:
    """One line per claim whose verdict differs from the default's, with the statistic before
    and after (``*``: each median inside the other's inter-quartile range)."""
    mine = {c.id: c for c in other.claims}
    inside = lambda a, b: b.q25 <= a.median <= b.q75  # noqa: E731  (a's median in b's IQR)
    lines = []
    for before in default.claims:
        after = mine.get(before.id)
        if after is None or after.verdict == before.verdict:
            continue
        sign = "+" if after.verdict == "agrees" else ("−" if before.verdict == "agrees" else "·")
        noise = "*" if inside(after, before) and inside(before, after) else ""
        lines.append(
            f"{sign}{before.id}{noise} ({before.verdict} → {after.verdict}: "
            f"{_num(before.median)} → {_num(after.median)} {after.unit})".replace(" )", ")")
        )
    return lines


def write_readings_report(
    path: Path, study: Any, table: Path, figure: Path, check: Sequence[Mapping[str, Any]]
) -> Path:
    """Write the readings study's report to ``path`` (atomically) and return it: the results of
    the readings of ``study`` (a :class:`~eval.studies.readings.run.ReadingsPlan` that ran), the
    best, which decision moves which claim, the matrix ``figure`` (data: ``table``); its
    combination rule, its continuation (or None), the bias ``check`` (``check_summary`` rows)
    and the tasks run in full."""
    plan, results, base = study.plan, study.results, path.parent
    default, best = results[0], max(results, key=lambda r: r.agree)
    n_claims, base_head, counts = len(default.claims), default.headline(), best.counts
    # every reading as good as the best, which is the first of them (max keeps the first)
    ties = [f", tied with `{r.reading.name}`" for r in results if r.agree == best.agree]
    reached = "reached" if best.agree >= READINGS_GOAL else "not reached"
    moves: list[study_report.Column] = [
        READING_COLUMNS[0],
        ("claims moved", lambda r: "; ".join(reading_moves(default, r)) or "none"),
        ("Δ agree", lambda r: f"{r.agree - default.agree:+d}"),
        *(
            (f"Δ {k}", lambda r, k=k: _num(r.headline()[k] - base_head[k], "+.3g"))
            for k in HEADLINES
        ),
    ]
    parts = [
        "# Readings of the paper: which reading reproduces which claim",
        "",
        *study_report.settings_lines(plan)[:3],
        study_report.insect_line(plan),
        "- every reading runs the four paper studies (speed, power, kinematics, wing shape) with "
        "these settings; a job two readings share runs once",
        "",
        "## Readings",
        "",
        *study_report.markdown_table(READING_COLUMNS, results),
        "",
        "Headline columns: " + "; ".join(f"{k}: {text}" for k, (_, text) in HEADLINES.items()),
        "",
        f"Combination rule (combinations derived from the singles' results, not chosen by "
        f"hand): {study.words}.",
        "",
        *_continuation_section(study.continuation, check, study.full),
        "## Best reading",
        "",
        f"`{best.reading.name}`{''.join(ties[1:])}: {best.agree} of {n_claims} claims agree "
        f"({best.differ} differ, {counts.undecided} undecided, {counts.not_identifiable} not "
        f"identifiable, {counts.no_data} without data); the default: {default.agree}. Goal: "
        f"{READINGS_GOAL} or more of {n_claims} ({reached}).",
        "",
        f"{best.reading.description}.",
        "",
        "## Which decision moves which claim",
        "",
        "Claims whose verdict (on the median) differs from the default's (+ now agrees, − no "
        "longer agrees, · between differs, undecided, not identifiable and no data), with our "
        "statistic under the default → under the reading. `*` marks a flip where both medians "
        "lie inside the other's inter-quartile range over seeds: within the seed-to-seed "
        "spread, i.e. possibly search noise.",
        "",
        *study_report.markdown_table(moves, results[1:]),
        "",
        "## Claims × readings",
        "",
        study_report.figure_markdown("claims × readings matrix", figure, base),
        "",
        f"Data: {study_report.file_link(table, base)}. Each reading's full report "
        "(paper vs ours, figures): "
        + ", ".join(f"[`{r.reading.name}`]({r.reading.name}/report.md)" for r in results)
        + ".",
        "",
        "## Readings in full",
        "",
        *[f"- `{r.reading.name}`: {r.reading.description}" for r in results],
        "",
        *study_report.section("Agreement rules", *study_report.agreement_rules()),
    ]
    write_text_atomic(path, "\n".join(parts))
    return path


def _continuation_section(
    continuation: Any, check: Sequence[Mapping[str, Any]], full: Mapping[str, Mapping[str, str]]
) -> list[str]:
    """The report's account of the continuation, its measured bias and what ran in full."""
    if continuation is None:
        return ["Every reading ran in full (no continuation).", ""]
    text = (
        f"The default reading ran in full; every other single reading's job that differs from "
        f"the default's continued from the default's optimum of the same job: "
        f"{100 * continuation.share:g} % of the budget, {100 * continuation.initial_share:g} % "
        f"of that for polishing that stroke under the reading and the rest for "
        f"{continuation.starts} short search(es) of the method, each polished; the best "
        "feasible stroke is reported. A combination continued likewise from the optima of its "
        "parts. Bias check, first: the "
        f"{', '.join(f'`{name}`' for name in continuation.check_studies)} studies' jobs at seeds "
        f"{', '.join(map(str, continuation.check_seeds))} of every single reading also ran "
        "in full (continuation_check.csv); difference = (continued − full) / |full|. A single "
        "reading's task whose check falls short (median below "
        f"{100 * continuation.full_median:+g} %, one pair below "
        f"{100 * continuation.full_lowest:+g} %, or a continued optimum infeasible where the full "
        "run's is feasible) then ran in full."
    )
    none = ["No checked pairs (no single reading besides the default)."]
    table = check_table(check, full) if check else none
    return study_report.section("Continuation and its bias", text, "", *table)


def check_table(check: Sequence[Row], full: Mapping[str, Mapping[str, str]]) -> list[str]:
    """The bias check as a Markdown table, one row per reading and task with whether it ran in
    full and why, the overall row in bold."""

    def runs(row: Mapping[str, Any]) -> str:
        why = full.get(row["reading"], {}).get(row["task"])
        return "" if row["reading"] == "all" else (f"in full ({why})" if why else "continued")

    columns: list[study_report.Column] = [
        ("reading", lambda row: "**all**" if row["reading"] == "all" else f"`{row['reading']}`"),
        ("task", lambda row: "" if row["reading"] == "all" else row["task"]),
        ("pairs", lambda row: str(row["pairs"])),
        *((k, lambda row, k=k: f"{100 * row[k]:+.2f} %") for k in ("median", "lowest", "highest")),
        ("within 0.5 % or above", lambda row: f"{row['within_0.5%']} of {row['pairs']}"),
        ("infeasible", lambda row: str(row["infeasible"])),
        ("runs", runs),
    ]
    return study_report.markdown_table(columns, check)


#: Cell colour and glyph of each verdict (any other verdict is drawn as "no data").
VERDICT_STYLE: dict[str, tuple[str, str, str]] = {
    # verdict: (cell colour, glyph, glyph colour)
    "agrees": (PALETTE[0], "✓", "white"),
    "differs": (PALETTE[1], "✗", "white"),
    "undecided": (PALETTE[6], "?", "black"),
    "not identifiable": ("#e6e6e6", "∅", "black"),
    "no data": ("#bbbbbb", "–", "black"),
}
_CODE = {verdict: k for k, verdict in enumerate(VERDICT_STYLE)}
#: The frame around a verdict changed from the first reading's.
FRAME: dict[str, Any] = {"fill": False, "ec": "black", "lw": 1.3}


def matrix_figure(results: Sequence[ReadingResult], path: Path, title: str) -> Path:
    """Draw the matrix of the readings' verdicts on the first's claims, the first reading the
    reference, a line before the first combination."""
    claims = results[0].claims
    columns = [
        (r.reading.name, [r.verdicts().get(c.id, "no data") for c in claims]) for r in results
    ]
    split = next((k for k, r in enumerate(results) if r.reading.derived_from), None)
    n_rows, n_cols = len(claims), len(columns)
    no_data = _CODE["no data"]
    grid = [[_CODE.get(verdicts[i], no_data) for _, verdicts in columns] for i in range(n_rows)]
    fig, ax = plt.subplots(figsize=(3.6 + 0.42 * n_cols, 1.6 + 0.24 * n_rows))
    cmap = ListedColormap([color for color, _, _ in VERDICT_STYLE.values()])
    ax.imshow(grid, cmap=cmap, vmin=0, vmax=len(_CODE) - 1, aspect="auto", interpolation="nearest")
    styles, reference = list(VERDICT_STYLE.values()), columns[0][1]
    for j, (_, verdicts) in enumerate(columns):
        for i in range(n_rows):
            _, glyph, ink = styles[grid[i][j]]
            ax.text(j, i, glyph, ha="center", va="center", fontsize=6.5, color=ink)
            if j and verdicts[i] != reference[i]:
                ax.add_patch(Rectangle((j - 0.45, i - 0.42), 0.9, 0.84, **FRAME))
    labels = [f"{name} ({v.count('agrees')} ✓, {v.count('undecided')} ?)" for name, v in columns]
    ax.set_xticks(range(n_cols), labels, rotation=60, ha="right", fontsize=7)
    clip = lambda s: s if len(s) <= 38 else s[:37] + "…"  # noqa: E731
    ax.set_yticks(range(n_rows), [f"{c.id}  {clip(c.statement)}" for c in claims], fontsize=6.5)
    ax.set_xticks([x - 0.5 for x in range(1, n_cols)], minor=True)
    ax.set_yticks([y - 0.5 for y in range(1, n_rows)], minor=True)
    ax.grid(which="minor", color="white", linewidth=0.8)
    ax.tick_params(which="minor", length=0)
    if split is not None and 0 < split < n_cols:
        ax.axvline(split - 0.5, color="black", linewidth=1.5)
    ax.set_title(title, fontsize=9)
    entries = [(Patch(color=color), f"{g} {v}") for v, (color, g, _) in VERDICT_STYLE.items()]
    changed = Patch(**FRAME)
    legend(ax, [*entries, (changed, f"changed vs {columns[0][0]}")])
    fig.tight_layout()
    return save(fig, path)
