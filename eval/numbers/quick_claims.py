"""The quick preset's paper-vs-ours table (docs/reproduction.md, "Paper vs ours: quick preset"):
``python -m eval study all --preset quick`` run under the machine's own OpenBLAS kernel and
under :data:`~eval.numbers.framework.OTHER_BLAS_KERNELS`, each run's claims merged into one
table whose differing cells name each kernel's value, and its Figs. 6, 7 and 11 copied."""

from __future__ import annotations

import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from eval.numbers import framework
from eval.numbers.framework import ROOT, kernel_views
from eval.studies.claims import Claim
from eval.studies.report import CLAIM_COLUMNS, CLAIMS_FILE, markdown_table, verdict_summary
from tandem_env.io.files import read_json

NAME = "quick-claims"
COMMAND = "python -m eval study all --preset quick --no-cache --quiet --out"
"""The documented study command, before its folder (the record cache off: a cached optimum may
come from another kernel)."""
FIGURES = {
    "speed/fig6_efficiency.png": ROOT / "docs" / "figures" / "quick_fig6_efficiency.png",
    "power/fig7_excess_forces.png": ROOT / "docs" / "figures" / "quick_fig7_excess_forces.png",
    "kinematics/fig11_weaving.png": ROOT / "docs" / "figures" / "quick_fig11_weaving.png",
}
"""The own kernel's figures (the run's file -> the docs' copy)."""
VERDICT_COLUMNS = {
    "verdict: median": ("median", "verdict"),
    "verdict: best seed": ("best seed", "best_verdict"),
}
"""The verdict columns of the claims table: the name the flip sentence gives each, and its
:class:`~eval.studies.claims.Claim` field."""


def read_claims(path: Path) -> list[dict[str, str]]:
    """The rows of a run's paper-vs-ours table from its ``claims.json``
    (``eval.studies.report.CLAIMS_FILE``), each as ``{column title: cell text}``."""
    return [claim["cells"] for claim in read_json(path)["claims"]]


def run_study(kernel: str | None) -> dict[str, Any]:
    """The quick preset's ``study all`` into a fresh folder under results/ (``kernel``: under
    ``OPENBLAS_CORETYPE=kernel``; None: the machine's own, whose figures are copied to docs);
    its claims and wall time [s]."""
    (ROOT / "results").mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory(dir=ROOT / "results", prefix="numbers-quick-") as out:
        environment = {"OPENBLAS_CORETYPE": kernel} if kernel else {}
        wall = framework.run_command([*COMMAND.split(), out], environment)
        rows = read_claims(Path(out) / CLAIMS_FILE)
        if kernel is None:
            framework.copy_outputs(Path(out), FIGURES)
    return {"rows": rows, "wall_time_s": round(wall, 1)}


def measure() -> dict[str, Any]:
    """:func:`run_study` under the machine's own kernel and under each other OpenBLAS kernel
    (:func:`~eval.numbers.framework.other_kernels`)."""
    own = {"blas_kernel": framework.blas_kernel(), **run_study(None)}
    return own | {"other_kernels": {k: run_study(k) for k in framework.other_kernels()}}


def joined(names: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    return " and ".join([", ".join(names[:-1]), names[-1]] if len(names) > 1 else names)


def by_text(texts: Mapping[str, str]) -> dict[str, list[str]]:
    """The kernels (keys of ``texts``, in order) that give each text."""
    groups: dict[str, list[str]] = {}
    for kernel, text in texts.items():
        groups.setdefault(text, []).append(kernel)
    return groups


def merged(texts: Mapping[str, str]) -> str:
    """One cell under every kernel: its text where all give the same, else each kernel's text
    named (``a under K1; b under K2 and K3``)."""
    if len(groups := by_text(texts)) == 1:
        return next(iter(groups))
    return "; ".join(f"{text} under {joined(kernels)}" for text, kernels in groups.items())


def verdicts(row: Mapping[str, str], field: bool = False) -> dict[str, str]:
    """A row's verdicts without their confidence (``undecided (leans ...)``: ``undecided``),
    by the column's name (``field``: by its Claim field)."""
    return {names[field]: row[title].partition(" (")[0] for title, names in VERDICT_COLUMNS.items()}


def summary_lines(views: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """The report's verdict counts (``eval.studies.report.verdict_summary``) of each kernel's
    run; a line that differs between kernels is given once per kernel group."""

    def claims(rows: Sequence[Mapping[str, str]]) -> list[Claim]:
        return [Claim(r["id"], "", "", "", "", r["rule"], **verdicts(r, field=True)) for r in rows]

    per_kernel = {k: verdict_summary(claims(view["rows"])) for k, view in views.items()}
    lines = []
    for i in range(len(next(iter(per_kernel.values())))):
        groups = by_text({k: text[i] for k, text in per_kernel.items()})
        for text, kernels in groups.items():
            head, _, tail = text.partition(":")
            lines.append(text if len(groups) == 1 else f"{head} under {joined(kernels)}:{tail}")
    return lines


def by_claim(views: Mapping[str, Mapping[str, Any]]) -> list[dict[str, dict[str, str]]]:
    """Each claim's row under every kernel (``{kernel: row}``), the runs' claims checked to be
    the same, in the same order."""
    ids = {k: [r["id"] for r in view["rows"]] for k, view in views.items()}
    if len({tuple(v) for v in ids.values()}) != 1:
        raise ValueError(f"the kernels' runs judged other claims: {ids}")
    rows = zip(*(view["rows"] for view in views.values()), strict=True)
    return [dict(zip(views, same, strict=True)) for same in rows]


def flips_sentence(claims: Sequence[Mapping[str, Mapping[str, str]]]) -> str:
    """Which claims' verdicts (:func:`verdicts`) differ between kernels, and in which column."""
    flips = []
    for same in claims:
        words = [verdicts(row) for row in same.values()]
        moved = [name for name in words[0] if len({w[name] for w in words}) > 1]
        if moved:
            where = "both columns" if len(moved) == len(VERDICT_COLUMNS) else moved[0]
            flips.append(f"{next(iter(same.values()))['id']} ({where})")
    if not flips:
        return "**No verdict flips with the BLAS kernel.**"
    return f"**Verdicts that flip with the BLAS kernel: {joined(flips)}.**"


def render(data: dict[str, Any]) -> str:
    """The verdict counts, the merged claims table, the flipping verdicts, the kernels, the
    runs' times and commands."""
    claims = by_claim(views := kernel_views(data))
    columns = [
        (title, lambda same, t=title: merged({k: row[t] for k, row in same.items()}))
        for title, _ in CLAIM_COLUMNS
    ]
    own, *others = views
    times = ", ".join(f"{framework.minutes(v['wall_time_s'])} ({k})" for k, v in views.items())
    named = joined([f"{own} (the measuring machine's own)", *others])
    kernels = (
        f"Run under the BLAS kernels {named}; a cell that differs between them names each kernel's value"
        if others
        else f"Run under the BLAS kernel {own} only (not OpenBLAS: no other can be chosen)"
    )
    lines = [
        *summary_lines(views),
        "",
        *markdown_table(columns, claims),
        "",
        *([flips_sentence(claims), ""] if others else []),
        f"{kernels}. Each run took {times}.",
    ]
    commands = [f"{COMMAND} DIR", *(f"OPENBLAS_CORETYPE={k} {COMMAND} DIR" for k in others)]
    heading = "Each kernel's command (DIR: a fresh folder under results/):"
    return "\n".join(lines + framework.footer(data, NAME, *commands, heading=heading)) + "\n"


MEASUREMENT = framework.Measurement(NAME, measure, render)
