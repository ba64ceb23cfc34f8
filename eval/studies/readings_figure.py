"""The claims × readings matrix: which reading of the paper reproduces which claim.

One row per claim (paper order), one column per reading; a cell is green where the claim
agrees, red where it differs and grey where it has no data. Column labels carry the reading's
count of agreeing claims out of all claims; a marker in a cell flags a verdict that changed
from the first (default) reading; a black line separates the single readings from the
combinations derived from them.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.colors import ListedColormap
from matplotlib.patches import Patch

from eval.figures import save

#: Cell colour of each verdict.
VERDICT_COLORS: dict[str, str] = {
    "agrees": "#4daf4a",
    "differs": "#e41a1c",
    "no data": "#bdbdbd",
}
_CODE = {"agrees": 0, "differs": 1}


def matrix_figure(
    claim_ids: Sequence[str],
    statements: Sequence[str],
    columns: Sequence[tuple[str, Sequence[str]]],
    path: Path,
    title: str,
    split: int | None = None,
) -> Path:
    """Draw the matrix: ``columns`` are (reading name, verdict per claim in ``claim_ids`` order).

    The first column is the reference: a dot marks every other cell whose verdict differs
    from it. A vertical line goes before column ``split`` (the first combination reading).
    """
    n_rows, n_cols = len(claim_ids), len(columns)
    grid = [[_CODE.get(verdicts[i], 2) for _, verdicts in columns] for i in range(n_rows)]
    width = 3.6 + 0.42 * n_cols
    height = 1.6 + 0.24 * n_rows
    fig, ax = plt.subplots(figsize=(width, height))
    cmap = ListedColormap([VERDICT_COLORS["agrees"], VERDICT_COLORS["differs"], "#bdbdbd"])
    ax.imshow(grid, cmap=cmap, vmin=0, vmax=2, aspect="auto", interpolation="nearest")
    reference = columns[0][1] if columns else []
    for j, (_, verdicts) in enumerate(columns[1:], start=1):
        for i in range(n_rows):
            if verdicts[i] != reference[i]:
                ax.plot(j, i, "o", color="white", markersize=3.5, markeredgecolor="black")
    labels = []
    for name, verdicts in columns:
        agree = sum(v == "agrees" for v in verdicts)
        labels.append(f"{name} ({agree}/{len(verdicts)})")
    ax.set_xticks(range(n_cols), labels, rotation=60, ha="right", fontsize=7)
    ax.set_yticks(
        range(n_rows),
        [f"{cid}  {_clip(s)}" for cid, s in zip(claim_ids, statements, strict=True)],
        fontsize=6.5,
    )
    ax.set_xticks([x - 0.5 for x in range(1, n_cols)], minor=True)
    ax.set_yticks([y - 0.5 for y in range(1, n_rows)], minor=True)
    ax.grid(which="minor", color="white", linewidth=0.8)
    ax.tick_params(which="minor", length=0)
    if split is not None and 0 < split < n_cols:
        ax.axvline(split - 0.5, color="black", linewidth=1.5)
    ax.set_title(title, fontsize=9)
    ax.legend(
        handles=[
            Patch(color=VERDICT_COLORS["agrees"], label="agrees"),
            Patch(color=VERDICT_COLORS["differs"], label="differs"),
            Patch(color=VERDICT_COLORS["no data"], label="no data"),
            plt.Line2D(
                [],
                [],
                marker="o",
                linestyle="",
                color="white",
                markeredgecolor="black",
                label=f"changed vs {columns[0][0] if columns else 'first'}",
            ),
        ],
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=7,
        frameon=False,
    )
    fig.tight_layout()
    return save(fig, path)


def _clip(text: str, n: int = 38) -> str:
    return text if len(text) <= n else text[: n - 1] + "…"
