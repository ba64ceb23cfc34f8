"""The quick preset's paper-vs-ours table under each BLAS kernel (docs/reproduction.md)."""

from __future__ import annotations

import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from eval.numbers import framework as fw
from eval.numbers.framework import kernel_views
from eval.studies.claims import Claim
from eval.studies.report import CLAIM_COLUMNS, CLAIMS_FILE, markdown_table, verdict_summary
from tandem_env.io.files import read_json

NAME = "quick-claims"
COMMAND = "python -m eval study all --preset quick --no-cache --quiet --out"
"""The documented study command, before its folder (no cache: an optimum of another kernel)."""
FIGURES = {
    "speed/fig6_efficiency.png": fw.ROOT / "docs" / "figures" / "quick_fig6_efficiency.png",
    "power/fig7_excess_forces.png": fw.ROOT / "docs" / "figures" / "quick_fig7_excess_forces.png",
    "kinematics/fig11_weaving.png": fw.ROOT / "docs" / "figures" / "quick_fig11_weaving.png",
}
"""The own kernel's figures (the run's file -> the docs' copy)."""
VERDICT_COLUMNS = {
    "verdict: median": ("median", "verdict"),
    "verdict: best seed": ("best seed", "best_verdict"),
}
"""The claims table's verdict columns: their name in the flip sentence, their Claim field."""


def read_claims(path: Path) -> list[dict[str, str]]:
    """The rows of a run's paper-vs-ours table from its ``claims.json``, as ``{title: cell}``."""
    return [claim["cells"] for claim in read_json(path)["claims"]]


def run_study(kernel: str | None) -> dict[str, Any]:
    """The quick preset's ``study all`` under ``kernel``: its claims and wall time [s]."""
    (fw.ROOT / "results").mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory(dir=fw.ROOT / "results", prefix="numbers-quick-") as out:
        environment = {"OPENBLAS_CORETYPE": kernel} if kernel else {}
        wall = fw.run_command([*COMMAND.split(), out], environment)
        rows = read_claims(Path(out) / CLAIMS_FILE)
        if kernel is None:
            fw.copy_outputs(Path(out), FIGURES)
    return {"rows": rows, "wall_time_s": round(wall, 1)}


def measure() -> dict[str, Any]:
    """:func:`run_study` under the machine's own kernel and each other OpenBLAS kernel."""
    data = {"blas_kernel": fw.blas_kernel(), **run_study(None)}
    return {**data, "other_kernels": {kernel: run_study(kernel) for kernel in fw.other_kernels()}}


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
    """One cell under every kernel: one text, else each kernel's (``a under K1; b under K2``)."""
    if len(groups := by_text(texts)) == 1:
        return next(iter(groups))
    return "; ".join(f"{text} under {joined(kernels)}" for text, kernels in groups.items())


def verdicts(row: Mapping[str, str], field: bool = False) -> dict[str, str]:
    """A row's verdicts without their confidence, by column name (``field``: Claim field)."""
    return {names[field]: row[title].partition(" (")[0] for title, names in VERDICT_COLUMNS.items()}


def summary_lines(views: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """Each kernel's verdict counts; a line that differs given once per kernel group."""

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
    """Each claim's row under every kernel (``{kernel: row}``); the runs' claims must match."""
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
    """The counts, the merged claims table, the flips, the kernels, the times and commands."""
    claims = by_claim(views := kernel_views(data))
    columns = [
        (title, lambda same, t=title: merged({k: row[t] for k, row in same.items()}))
        for title, _ in CLAIM_COLUMNS
    ]
    own, *others = views
    times = ", ".join(f"{fw.minutes(v['wall_time_s'])} ({k})" for k, v in views.items())
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
    return "\n".join(lines + fw.footer(data, NAME, *commands, heading=heading)) + "\n"


MEASUREMENT = fw.Measurement(NAME, measure, render)
