"""Paper-style figures of the studies (matplotlib, Agg, small PNGs).

Every sweep figure shows the spread over seeds the same way: the median over feasible seeds as
a line, the inter-quartile range as a band, each feasible seed as a small dot and the best seed
(best objective) as a star. What the paper states in its text is drawn the same way in every
figure: its numbers are black crosses, a condition it names (e.g. "peaks at 1.5 m/s") is a
black dotted vertical line, and a trend it states only in words is quoted in the panel's lower
corner ("paper: ...").
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from agents.fileio import atomic_path
from eval.studies.tables import Spread

DPI = 90
COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")


@dataclass(frozen=True)
class Series:
    """One line of a sweep panel: {condition: Spread} with a label."""

    label: str
    points: Mapping[float, Spread]
    scale: float = 1.0
    """Multiplies every value (e.g. 100 for a percentage)."""


@dataclass(frozen=True)
class Panel:
    """One panel of a sweep figure."""

    ylabel: str
    series: Sequence[Series]
    paper: Sequence[tuple[float, float] | tuple[float, float, str]] = field(default=())
    """(condition, value) or (condition, value, label) points the paper states."""
    title: str = ""
    paper_at: Sequence[tuple[float, str]] = field(default=())
    """(condition, label): conditions the paper names, e.g. (1.5, "paper: peak")."""
    paper_note: str = ""
    """A trend the paper states in words only, e.g. "paper: falls with V"."""


def draw_series(ax: plt.Axes, series: Series, color: str, offset: float = 0.0) -> None:
    """Median line, IQR band, seeds as dots, best as a star (conditions with data only)."""
    x = np.array(sorted(series.points))
    k = series.scale
    stats = [series.points[c] for c in x]
    med = np.array([k * s.median for s in stats])
    lo = np.array([k * s.q25 for s in stats])
    hi = np.array([k * s.q75 for s in stats])
    ax.fill_between(x, lo, hi, color=color, alpha=0.2, linewidth=0)
    ax.plot(x, med, "-", color=color, label=f"{series.label} (median, IQR)")
    for c, s in zip(x, stats, strict=True):
        if s.values:
            jitter = offset + np.linspace(-1, 1, len(s.values)) * 0.01 * max(np.ptp(x), 1.0)
            ax.plot(c + jitter, k * np.array(s.values), ".", color=color, alpha=0.5, ms=4)
    best = [(c, k * s.best) for c, s in zip(x, stats, strict=True) if np.isfinite(s.best)]
    if best:
        bx, by = zip(*best, strict=True)
        ax.plot(
            bx, by, "*", color=color, ms=9, mec="k", mew=0.5, label=f"{series.label} (best seed)"
        )


def sweep_figure(
    panels: Sequence[Panel], xlabel: str, title: str, path: Path, width: float = 6.0
) -> Path:
    """Stacked panels over one condition axis, like the paper's Figs. 4-8 and 15-16."""
    fig, axes = plt.subplots(len(panels), 1, figsize=(width, 2.4 * len(panels) + 0.8), sharex=True)
    axes = np.atleast_1d(axes)
    for ax, panel in zip(axes, panels, strict=True):
        for i, s in enumerate(panel.series):
            draw_series(ax, s, COLORS[i % len(COLORS)], offset=0.0)
        draw_paper(ax, panel)
        ax.set_ylabel(panel.ylabel)
        if panel.title:
            ax.set_title(panel.title, fontsize=9)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel(xlabel)
    axes[0].legend(fontsize=7, loc="best")
    fig.suptitle(title, fontsize=10)
    return save(fig, path)


def draw_paper(ax: plt.Axes, panel: Panel) -> None:
    """What the paper states for this panel: crosses, dotted lines and a quoted trend."""
    if panel.paper:
        px, py = [p[0] for p in panel.paper], [p[1] for p in panel.paper]
        ax.plot(px, py, "kx", ms=8, mew=2, label="paper")
        for point in panel.paper:
            if len(point) == 3:
                ax.annotate(
                    point[2], point[:2], xytext=(6, 2), textcoords="offset points", fontsize=7
                )
    for k, (condition, label) in enumerate(panel.paper_at):
        ax.axvline(condition, color="k", ls=":", lw=1.2, label=label if k == 0 else None)
        if k:
            ax.annotate(label, (condition, 0.97), xycoords=("data", "axes fraction"), fontsize=7)
    if panel.paper_note:
        ax.text(
            0.98,
            0.04,
            panel.paper_note,
            transform=ax.transAxes,
            ha="right",
            va="bottom",
            fontsize=7,
            style="italic",
            bbox={"boxstyle": "round", "fc": "white", "ec": "0.6", "alpha": 0.8},
        )


def save(fig: plt.Figure, path: Path) -> Path:
    fig.tight_layout()
    try:
        with atomic_path(path) as tmp:  # a killed run never leaves half a PNG
            fig.savefig(tmp, dpi=DPI)
    finally:
        plt.close(fig)
    return path


# --- kinematics (Figs. 9-13) -------------------------------------------------------------------
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


def _plot_wings(ax: plt.Axes, traces: Sequence[Trace], quantity: str) -> None:
    """``quantity`` over the cycle per seed: fore-wing solid blue, hind-wing dashed red, with
    one legend entry each."""
    for trace in traces:
        style = _trace_style(trace)
        ax.plot(trace.cycle, trace.fore[quantity], "-", color="tab:blue", **style)
        ax.plot(trace.cycle, trace.hind[quantity], "--", color="tab:red", **style)
    ax.plot([], [], "-", color="tab:blue", label="fore-wing")
    ax.plot([], [], "--", color="tab:red", label="hind-wing")


def tip_path_figure(traces: Sequence[Trace], title: str, path: Path) -> Path:
    """Wing-tip paths relative to the wing base, side view (x forward, z up), per wing."""
    fig, axes = plt.subplots(1, 2, figsize=(7.5, 3.8))
    for ax, wing in zip(axes, ("fore", "hind"), strict=True):
        for i, trace in enumerate(traces):
            tip = getattr(trace, wing)["tip_path"]
            color = "k" if trace.best else COLORS[i % len(COLORS)]
            ax.plot(
                tip[:, 0], tip[:, 2], "-", color=color, label=trace.label, **_trace_style(trace)
            )
            if trace.best:
                # Start of the cycle and the direction of travel.
                ax.plot(tip[0, 0], tip[0, 2], "o", color="k", ms=5)
                ax.annotate(
                    "",
                    xy=(tip[3, 0], tip[3, 2]),
                    xytext=(tip[0, 0], tip[0, 2]),
                    arrowprops={"arrowstyle": "->", "color": "k"},
                )
        ax.plot(0, 0, "k+", ms=10)
        ax.set_title(f"{wing}-wing", fontsize=9)
        if wing == "hind":
            # What the markers mean (the paper's Figs. 9-10 have no markers to compare).
            ax.plot([], [], "o", color="k", ms=5, label="best seed at t = 0 (arrow: direction)")
            ax.plot([], [], "k+", ms=10, label="wing base")
        ax.set_xlabel("x/R (forward) [-]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("z/R (up) [-]")
    axes[1].legend(fontsize=6, loc="best")
    fig.suptitle(title, fontsize=10)
    return save(fig, path)


def cycle_figure(
    rows: Sequence[tuple[str, Sequence[Trace]]],
    quantity: str,
    ylabel: str,
    title: str,
    path: Path,
    extra: tuple[str, Mapping[str, Sequence[float]], str] | None = None,
    extra_median: Callable[[Sequence[float]], float] = np.median,
    extra_median_label: str = "median",
    extra_paper: Mapping[str, float] | None = None,
) -> Path:
    """One panel per flight mode: ``quantity`` of fore (solid) and hind (dashed) over t/T.

    ``extra`` adds a last panel (label, {group: values}, ylabel) of per-seed values as dots with
    ``extra_median`` of each group as a bar (a circular median for phases), e.g. the phase
    differences (Fig. 11c) or pitch amplitudes (Fig. 12c); ``extra_paper`` {group: value} draws
    the paper's stated values as black crosses.
    """
    n = len(rows) + (extra is not None)
    fig, axes = plt.subplots(1, n, figsize=(3.6 * n, 3.4))
    axes = np.atleast_1d(axes)
    for ax, (name, traces) in zip(axes, rows, strict=False):
        _plot_wings(ax, traces, quantity)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("cycle t/T [-]")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, title="bold: best seed", title_fontsize=6)
    if extra is not None:
        label, groups, extra_ylabel = extra
        ax = axes[-1]
        for i, (_group, values) in enumerate(groups.items()):
            v = np.asarray(values, float)
            ax.plot(np.full(v.size, i) + np.linspace(-0.1, 0.1, v.size), v, "o", alpha=0.6)
            if v.size:
                ax.plot([i - 0.25, i + 0.25], [extra_median(v)] * 2, "k-", lw=2)
        ax.plot([], [], "k-", lw=2, label=extra_median_label)
        for k, (group, value) in enumerate((extra_paper or {}).items()):
            i = list(groups).index(group)
            ax.plot(i + 0.3, value, "kx", ms=8, mew=2, label="paper" if k == 0 else None)
        ax.legend(fontsize=7, loc="best")
        ax.axhline(0.0, color="grey", lw=0.8)
        ax.set_xlim(-0.5, len(groups) - 0.5)
        ax.set_xticks(range(len(groups)), list(groups), fontsize=7)
        ax.set_ylabel(extra_ylabel)
        ax.set_title(label, fontsize=9)
        ax.grid(alpha=0.3)
    fig.suptitle(title, fontsize=10)
    return save(fig, path)


def flow_figure(traces: Sequence[Trace], title: str, path: Path) -> Path:
    """Angle of attack and relative speed at 0.75 R over the cycle (Fig. 13)."""
    fig, axes = plt.subplots(2, 1, figsize=(6.0, 5.2), sharex=True)
    for ax, (quantity, ylabel) in zip(
        axes,
        (
            ("angle_of_attack", "angle of attack [deg]"),
            ("relative_speed", "relative speed at 0.75R [m/s]"),
        ),
        strict=True,
    ):
        _plot_wings(ax, traces, quantity)
        ax.axvline(0.5, color="grey", lw=0.8)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, title="bold: best seed", title_fontsize=6)
    axes[-1].set_xlabel("cycle t/T [-]")
    fig.suptitle(title, fontsize=10)
    return save(fig, path)


# --- wing shape (Fig. 14) ----------------------------------------------------------------------
def planform_figure(
    outlines: Sequence[tuple[str, np.ndarray, np.ndarray, np.ndarray]], path: Path
) -> Path:
    """Planforms: (label, r [mm], leading edge [mm], trailing edge [mm]) per wing shape."""
    fig, axes = plt.subplots(1, 2, figsize=(7.5, 2.8), sharey=True)
    for i, (label, r, upper, lower) in enumerate(outlines):
        ax = axes[0] if label.startswith("fore") else axes[1]
        color = COLORS[i // 2 % len(COLORS)]
        ax.plot(r, upper, "-", color=color, label=label)
        ax.plot(r, lower, "-", color=color)
    for ax, wing in zip(axes, ("fore-wing", "hind-wing"), strict=True):
        ax.set_title(wing, fontsize=9)
        ax.set_xlabel("span r [mm]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("chordwise position [mm]")
    fig.suptitle("Fig. 14: tear-drop and real wing planforms (equal area and span)", fontsize=10)
    return save(fig, path)


# --- convergence -------------------------------------------------------------------------------
def convergence_figure(
    panels: Sequence[
        tuple[str, Sequence[tuple[str, np.ndarray, np.ndarray]], Sequence[tuple[str, int]]]
    ],
    path: Path,
) -> Path:
    """Best-so-far over evaluations: per condition (label, [(method, evaluations (n,), values
    (seeds, n))], [(preset name, budget)]).

    Per method a median line, an IQR band and each seed thin; vertical lines mark the presets'
    budgets. The y-axis starts at the worst seed after 5 % of the run: the first batches'
    penalised rewards would squash the rest.
    """
    fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 3.8))
    axes = np.atleast_1d(axes)
    for ax, (label, methods, budgets) in zip(axes, panels, strict=True):
        lows, highs = [], []
        for i, (method, evaluations, values) in enumerate(methods):
            color = COLORS[i % len(COLORS)]
            shown = np.where(np.isfinite(values), values, np.nan)
            for row in shown:
                ax.plot(evaluations, row, "-", color=color, lw=0.5, alpha=0.3)
            with np.errstate(all="ignore"):
                lo, med, hi = np.nanpercentile(shown, [25, 50, 75], axis=0)
            ax.fill_between(evaluations, lo, hi, color=color, alpha=0.2, linewidth=0)
            ax.plot(evaluations, med, "-", color=color, lw=2, label=f"{method}: median (IQR)")
            later = shown[:, evaluations >= 0.05 * evaluations[-1]]
            if np.isfinite(later).any():
                lows.append(np.nanmin(later))
                highs.append(np.nanmax(later))
        for name, budget in budgets:
            ax.axvline(budget, color="grey", ls=":", lw=1)
            ax.annotate(
                name, (budget, 0.02), xycoords=("data", "axes fraction"), fontsize=7, rotation=90
            )
        if lows:
            low, high = min(lows), max(highs)
            pad = 0.05 * max(high - low, 1e-9)
            ax.set_ylim(low - pad, high + pad)
        ax.set_title(label, fontsize=9)
        ax.set_xlabel("model evaluations [-]")
        ax.set_ylabel("best reward so far [-]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    fig.suptitle("Budget study: best-so-far over seeds (dotted: preset budgets)", fontsize=10)
    return save(fig, path)
