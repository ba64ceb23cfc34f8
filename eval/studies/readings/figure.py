"""The claims × readings matrix: one row per claim, one column per reading, each cell the
median's verdict by colour and glyph (:data:`VERDICT_STYLE`, readable without colour vision); a
black frame flags a verdict changed from the first (default) reading.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.colors import ListedColormap
from matplotlib.patches import Patch, Rectangle

from eval.figures import PALETTE, legend, save
from eval.studies.readings.plan import ReadingResult

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
    width = 3.6 + 0.42 * n_cols
    height = 1.6 + 0.24 * n_rows
    fig, ax = plt.subplots(figsize=(width, height))
    cmap = ListedColormap([color for color, _, _ in VERDICT_STYLE.values()])
    ax.imshow(grid, cmap=cmap, vmin=0, vmax=len(_CODE) - 1, aspect="auto", interpolation="nearest")
    styles = list(VERDICT_STYLE.values())
    reference = columns[0][1]
    for j, (_, verdicts) in enumerate(columns):
        for i in range(n_rows):
            _, glyph, ink = styles[grid[i][j]]
            ax.text(j, i, glyph, ha="center", va="center", fontsize=6.5, color=ink)
            if j and verdicts[i] != reference[i]:
                ax.add_patch(
                    Rectangle((j - 0.45, i - 0.42), 0.9, 0.84, fill=False, ec="black", lw=1.3)
                )
    labels = [
        f"{name} ({verdicts.count('agrees')} ✓, {verdicts.count('undecided')} ?)"
        for name, verdicts in columns
    ]
    ax.set_xticks(range(n_cols), labels, rotation=60, ha="right", fontsize=7)
    ax.set_yticks(
        range(n_rows),
        [f"{c.id}  {_clip(c.statement)}" for c in claims],
        fontsize=6.5,
    )
    ax.set_xticks([x - 0.5 for x in range(1, n_cols)], minor=True)
    ax.set_yticks([y - 0.5 for y in range(1, n_rows)], minor=True)
    ax.grid(which="minor", color="white", linewidth=0.8)
    ax.tick_params(which="minor", length=0)
    if split is not None and 0 < split < n_cols:
        ax.axvline(split - 0.5, color="black", linewidth=1.5)
    ax.set_title(title, fontsize=9)
    entries = [(Patch(color=color), f"{g} {v}") for v, (color, g, _) in VERDICT_STYLE.items()]
    changed = Patch(fill=False, ec="black", lw=1.3)
    legend(ax, [*entries, (changed, f"changed vs {columns[0][0]}")])
    fig.tight_layout()
    return save(fig, path)


def _clip(text: str, n: int = 38) -> str:
    return text if len(text) <= n else text[: n - 1] + "…"
