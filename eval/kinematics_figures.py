"""The kinematics figures of the optimised strokes (paper Figs. 9-13), in the style of
:mod:`eval.figures`: wing-tip paths with the direction of travel (Figs. 9-10), angles of both
wings over the cycle with per-seed group panels (Figs. 11-12), flow at the wing (Fig. 13)."""

from __future__ import annotations

import textwrap
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.lines import Line2D
from matplotlib.patches import FancyArrowPatch

from eval import figures
from eval.figures import PALETTE, WING_COLORS, draw_bounds, legend, plt, text_entry


@dataclass(frozen=True)
class Trace:
    """One stroke's time history for the kinematics figures."""

    label: str
    """E.g. ``"seed 3 (best)"``."""
    best: bool
    cycle: np.ndarray
    """t/T [-]."""
    fore: Mapping[str, np.ndarray]
    """Quantity name -> (n,) or (n, 3) array of the fore-wing."""
    hind: Mapping[str, np.ndarray]


def _trace_style(trace: Trace) -> dict:
    return {"lw": 2.0, "alpha": 1.0} if trace.best else {"lw": 0.8, "alpha": 0.35}


#: Where along the cycle the tip paths' direction arrows sit [t/T]: one per quarter, so a
#: figure-of-eight shows its direction on both loops.
ARROW_PHASES: tuple[float, ...] = (0.125, 0.375, 0.625, 0.875)
#: The arrowheads: filled black with a white rim, above every path, 16 pt long.
ARROW_STYLE: dict = dict(
    arrowstyle="-|>", mutation_scale=16, fc="k", ec="white", lw=0.8, shrinkA=0, shrinkB=0, zorder=6
)
START_LABEL = "best seed at t = 0 (arrows: direction of travel)"


def draw_direction(ax: Axes, path: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Arrowheads along a closed path (n, 2) at :data:`ARROW_PHASES`, the way it is travelled;
    each arrow's (from, to): a sample of the path and the next one."""
    segments = [
        (path[k], path[k + 1])
        for k in (min(int(p * len(path)), len(path) - 2) for p in ARROW_PHASES)
    ]
    for start, end in segments:
        ax.add_patch(FancyArrowPatch(tuple(start), tuple(end), **ARROW_STYLE))
    return segments


def tip_path_figure(traces: Sequence[Trace], title: str, path: Path) -> Path:
    """Wing-tip paths relative to the wing base, side view (x forward, z up), a panel per wing,
    both at the same limits and equal scale."""
    fig, axes = plt.subplots(1, 2, figsize=(7.5, 3.8), sharex=True, sharey=True)
    for ax, wing in zip(axes, ("fore", "hind"), strict=True):
        for i, trace in enumerate(traces):
            tip = getattr(trace, wing)["tip_path"]
            # black for the best seed, else a palette colour fixed by the seed in the label
            digits = "".join(c for c in trace.label.split("(")[0] if c.isdigit())
            color = "k" if trace.best else PALETTE[(int(digits) if digits else i) % len(PALETTE)]
            loop = np.vstack([tip, tip[:1]])  # one period: the path closes on itself
            style = {"color": color, "label": trace.label, **_trace_style(trace)}
            ax.plot(loop[:, 0], loop[:, 2], "-", **style)
            if trace.best:
                # Start of the cycle, and the direction of travel above every path.
                ax.plot(tip[0, 0], tip[0, 2], "o", color="k", ms=5, zorder=5)
                draw_direction(ax, tip[:, [0, 2]])
        ax.plot(0, 0, "k+", ms=10)
        ax.set_title(f"{wing}-wing", fontsize=9)
        if wing == "hind":
            # What the markers mean (the paper's Figs. 9-10 have no markers to compare).
            ax.plot([], [], "o", color="k", ms=5, label=START_LABEL)
            ax.plot([], [], "k+", ms=10, label="wing base")
        ax.set_xlabel("x/R (forward) [-]")
        # the box adjusts, not the limits: limits shared by both panels stay the same
        ax.set_aspect("equal", adjustable="box")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("z/R (up) [-]")
    axes[1].legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)
    fig.suptitle(title, fontsize=10)
    return figures.save(fig, path)


@dataclass(frozen=True)
class GroupPanel:
    """Per-seed values in groups (e.g. Fig. 11c's phase differences): seeds as dots, the
    statistic judged as a bar, the best seed a star, the paper's values crosses, a band."""

    title: str
    groups: Mapping[str, Sequence[float]]
    """Group label -> the feasible seeds' values."""
    ylabel: str
    statistic: Callable[[Sequence[float]], float] = np.median
    statistic_label: str = "median"
    best: Mapping[str, float] = field(default_factory=dict)
    """Group -> the best seed's value (a star)."""
    paper: Mapping[str, float] = field(default_factory=dict)
    """Group -> the paper's value (a cross)."""
    paper_label: str = "paper"
    """The crosses' legend entry: what the paper states there."""
    band: tuple[float, float, str] | None = None
    """(low, high, label): a range the rule names, e.g. (0, 15, "in phase: |ΔΦ| < 15°")."""
    ylim: tuple[float, float] | None = None
    bounds: tuple[float, float] | None = None
    """The insect's (low, high) bounds of the stroke parameter drawn (``tables.table4_bounds``)."""
    paper_note: str = ""
    """What the paper states in words only (a legend line)."""


def draw_groups(ax: Axes, panel: GroupPanel, wrap: int = 0) -> None:
    """Draw one :class:`GroupPanel`, its legend below (``wrap``: labels and title wrapped)."""
    names = list(panel.groups)
    entries: list[tuple[Any, str]] = []
    if panel.band is not None:
        low, high, label = panel.band
        entries.append((ax.axhspan(low, high, color="0.85", zorder=0), label))
    for i, name in enumerate(names):
        v = np.asarray(panel.groups[name], float)
        color = PALETTE[i % len(PALETTE)]
        ax.plot(i + np.linspace(-0.1, 0.1, v.size), v, "o", color=color, alpha=0.7, ms=5)
        if v.size:
            ax.plot([i - 0.25, i + 0.25], [panel.statistic(v)] * 2, "k-", lw=2)
        if name in panel.best and np.isfinite(panel.best[name]):
            ax.plot(i + 0.2, panel.best[name], "*", color=color, ms=10, mec="k", mew=0.5)
    entries.append((Line2D([], [], color="k", lw=2), panel.statistic_label))
    if panel.best:
        entries.append((Line2D([], [], marker="*", ls="", color="0.5", mec="k", ms=9), "best seed"))
    for k, (name, value) in enumerate(panel.paper.items()):
        (cross,) = ax.plot(names.index(name) + 0.3, value, "kx", ms=8, mew=2)
        if k == 0:
            entries.append((cross, panel.paper_label))
    if panel.paper_note:
        entries.append(text_entry(panel.paper_note))
    entries += draw_bounds(ax, panel.bounds)
    ax.set_xlim(-0.5, len(names) - 0.5)
    if panel.ylim is not None:
        ax.set_ylim(*panel.ylim)
    # a group's name on two lines; on a line per word where the panel is narrow (``wrap``)
    ticks = [n.replace(" ", "\n", -1 if wrap else 1) for n in names]
    ax.set_xticks(range(len(names)), ticks, fontsize=7)
    ax.set_ylabel(panel.ylabel)
    ax.set_title(textwrap.fill(panel.title, wrap) if wrap else panel.title)
    ax.grid(alpha=0.3)
    lines = max((t.count("\n") + 1 for t in ticks), default=1)
    legend(ax, entries, below=True, wrap=wrap, gap=1.6 + 1.2 * lines)  # below the ticks


#: The paper's division of the cycle (Fig. 12 text): the down-stroke is 0 < t/T < 0.5.
PAPER_DOWNSTROKE_END = 0.5


def _cycle_panel(
    ax: Axes, traces: Sequence[Trace], quantity: str, ylabel: str, first: bool
) -> None:
    """``quantity`` over the cycle per seed, fore-wing solid, hind-wing dashed, with the paper's
    end of the down-stroke (named in the legend of the ``first`` panel)."""
    for trace in traces:
        style = _trace_style(trace)
        ax.plot(trace.cycle, trace.fore[quantity], "-", color=WING_COLORS["fore"], **style)
        ax.plot(trace.cycle, trace.hind[quantity], "--", color=WING_COLORS["hind"], **style)
    ax.plot([], [], "-", color=WING_COLORS["fore"], label="fore-wing")
    ax.plot([], [], "--", color=WING_COLORS["hind"], label="hind-wing")
    label = "paper: down-stroke ends (t/T = 0.5)" if first else None
    ax.axvline(PAPER_DOWNSTROKE_END, color="k", ls=":", lw=1.0, label=label)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)


#: Width of a journal's single column [mm]: Figs. 11-12 are drawn for it.
COLUMN_WIDTH_MM = 85.0
#: Smallest text size a figure drawn for :data:`COLUMN_WIDTH_MM` has, printed at that width [pt].
COLUMN_FONT_PT = 7.0
#: The text sizes of a single-column figure: every text at :data:`COLUMN_FONT_PT`, the title
#: a point larger.
COLUMN_RC: dict[str, Any] = dict.fromkeys(
    ("font.size", "axes.titlesize", "axes.labelsize", "xtick.labelsize", "ytick.labelsize"),
    COLUMN_FONT_PT,
) | {"legend.fontsize": COLUMN_FONT_PT, "figure.titlesize": COLUMN_FONT_PT + 1}
#: Characters per line of a single-column figure's panel titles and legends (two panels
#: side by side at :data:`COLUMN_FONT_PT`).
COLUMN_WRAP = 22


def cycle_figure(
    rows: Sequence[tuple[str, Sequence[Trace]]],
    quantity: str,
    ylabel: str,
    title: str,
    path: Path,
    extras: Sequence[GroupPanel] = (),
) -> Path:
    """``quantity`` of fore (solid) and hind (dashed) over t/T, a panel per flight mode side by
    side, below them a :class:`GroupPanel` per ``extras`` (e.g. Fig. 11c's phase differences),
    for a journal column (:data:`COLUMN_RC`; titles and legends wrapped, legends below)."""
    with plt.rc_context(COLUMN_RC):
        parts = [len(part) for part in (rows, extras) if part]
        # constrained: it lays out each row's subfigure with its legend below it
        # the saved figure adds a margin on each side (``figures.save``: cropped, padded)
        width = COLUMN_WIDTH_MM / 25.4 - 2 * plt.rcParams["savefig.pad_inches"]
        fig = plt.figure(figsize=(width, 3.4 * len(parts)), layout="constrained")
        subfigs = np.atleast_1d(fig.subfigures(len(parts), 1))
        if rows:
            axes = np.atleast_1d(subfigs[0].subplots(1, len(rows), sharey=True))
            for k, (ax, (name, traces)) in enumerate(zip(axes, rows, strict=True)):
                _cycle_panel(ax, traces, quantity, ylabel if k == 0 else "", first=k == 0)
                ax.set_title(textwrap.fill(name, COLUMN_WRAP))
                ax.set_xlabel("cycle t/T [-]")
                ax.set_xticks([0.0, 0.5, 1.0])
            handles, labels = axes[0].get_legend_handles_labels()
            key, text = text_entry("bold: best seed")
            subfigs[0].legend(
                [*handles, key], [*labels, text], loc="outside lower center", ncols=2, frameon=False
            )
        if extras:
            axes = np.atleast_1d(subfigs[-1].subplots(1, len(extras)))
            for ax, extra in zip(axes, extras, strict=True):
                draw_groups(ax, extra, wrap=COLUMN_WRAP)
        fig.suptitle(title)
    return figures.save(fig, path)


#: The panels of Fig. 13: (quantity of a :class:`Trace`'s wing, axis label).
FLOW_PANELS: tuple[tuple[str, str], ...] = (
    ("angle_of_attack", "angle of attack [deg]"),
    ("relative_speed", "relative speed at 0.75R [m/s]"),
)


def flow_figure(traces: Sequence[Trace], title: str, path: Path, note: str = "") -> Path:
    """Angle of attack and relative speed at 0.75 R over the cycle (Fig. 13), the paper's end
    of the down-stroke dotted; ``note``: a last legend line."""
    fig, axes = plt.subplots(2, 1, figsize=(8.4, 5.2), sharex=True)
    for k, (ax, (quantity, ylabel)) in enumerate(zip(axes, FLOW_PANELS, strict=True)):
        _cycle_panel(ax, traces, quantity, ylabel, first=k == 0)
    handles, labels = axes[0].get_legend_handles_labels()
    notes = [text_entry(note)] if note else []
    entries = [*zip(handles, labels, strict=True), *notes]
    legend(axes[0], entries, title="bold: best seed", title_fontsize=6)
    axes[-1].set_xlabel("cycle t/T [-]")
    fig.suptitle(title, fontsize=10)
    return figures.save(fig, path)
