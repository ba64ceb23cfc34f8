"""Paper-style figures of the studies (matplotlib, Agg; PNG, SVG or PDF: :data:`FORMATS`).

Every sweep figure shows the spread over seeds the same way: the median over feasible seeds as
a line, the inter-quartile range as a band, each feasible seed as a small dot and the best seed
(best objective) as a star. What the paper states in its text is drawn the same way in every
figure: its numbers are black crosses, a condition it names (e.g. "peaks at 1.5 m/s") is a
black dotted vertical line, and a trend it states only in words is quoted in the legend
("paper: ..."). Legends sit outside the axes, so they cover nothing, and list only what is
drawn. Colours are Okabe & Ito's colour-blind-safe palette, fixed per method
(:func:`series_style`), so a series keeps its colour when another is added.
"""

from __future__ import annotations

import zlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import to_rgb
from matplotlib.legend_handler import HandlerTuple
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from tandem_env.io.files import atomic_path

if TYPE_CHECKING:  # annotations only: eval.studies imports this module
    from eval.studies.tables import Spread

DPI = 90
#: The figure formats the studies write (``--format``); the first is the default.
FORMATS: tuple[str, ...] = ("png", "svg", "pdf")

#: Okabe & Ito's colour-blind-safe palette, black left out (it marks the paper's statements).
PALETTE: tuple[str, ...] = (
    "#0072B2",  # blue
    "#D55E00",  # vermillion
    "#009E73",  # bluish green
    "#CC79A7",  # reddish purple
    "#E69F00",  # orange
    "#56B4E9",  # sky blue
    "#F0E442",  # yellow
)
#: Fixed colour of each method family (the spec's name before ':'); other specs get a colour
#: from their name's checksum, so no colour depends on which other series a figure has.
METHOD_COLORS: dict[str, str] = {
    "cmaes": PALETTE[0],
    "pso": PALETTE[1],
    "random": PALETTE[2],
    "policy": PALETTE[3],
    "ppo": PALETTE[4],
    "sac": PALETTE[5],
}
#: Readable names of the method families for legends.
METHOD_NAMES: dict[str, str] = {
    "cmaes": "CMA-ES",
    "pso": "PSO",
    "random": "random search",
    "policy": "policy",
    "ppo": "PPO",
    "sac": "SAC",
}
#: Line style of a series' variant (0: e.g. F̄_v or the tear-drop; 1: F̄_h or the real wing).
VARIANT_LINES: tuple[str, ...] = ("-", "--", ":")
#: The fore- and hind-wing in the kinematics figures.
WING_COLORS: dict[str, str] = {"fore": PALETTE[0], "hind": PALETTE[1]}


def method_label(spec: str) -> str:
    """A method spec as a legend names it: ``cmaes`` -> ``CMA-ES``, ``policy:logs/ppo/run_3``
    -> ``policy ppo/run_3`` (the last two parts of the run's path)."""
    name, _, argument = spec.partition(":")
    label = METHOD_NAMES.get(name, name)
    if argument:
        label += " " + "/".join(PurePath(argument).with_suffix("").parts[-2:])
    return label


def method_color(spec: str) -> str:
    """The method's fixed colour: its family's for a plain name, else by checksum of the spec."""
    name, _, argument = spec.partition(":")
    if name in METHOD_COLORS and not argument:
        return METHOD_COLORS[name]
    return PALETTE[zlib.crc32(spec.encode()) % len(PALETTE)]


def series_style(method: str, variant: int = 0) -> dict[str, Any]:
    """Colour and line style of a series: the method's colour (lightened for variant 1) and
    the variant's line style."""
    color = np.array(to_rgb(method_color(method)))
    if variant % 2:
        color = 0.55 * color + 0.45  # the same hue, lighter
    return {"color": tuple(float(c) for c in color), "ls": VARIANT_LINES[variant % 3]}


def figure_path(folder: Path, stem: str, fmt: str = FORMATS[0]) -> Path:
    """``folder/stem.fmt``; ValueError for a format not in :data:`FORMATS`."""
    if fmt not in FORMATS:
        raise ValueError(f"figure format {fmt!r}; allowed: {', '.join(FORMATS)}")
    return folder / f"{stem}.{fmt}"


@dataclass(frozen=True)
class Series:
    """One line of a sweep panel: {condition: Spread} with a label."""

    label: str
    points: Mapping[float, Spread]
    scale: float = 1.0
    """Multiplies every value (e.g. 100 for a percentage)."""
    method: str = ""
    """The method spec whose fixed colour the series has (:func:`series_style`); empty: the
    label's."""
    variant: int = 0
    """Which of a method's series this is (line style, shade): 0, 1, ..."""


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


#: Legend entry explaining how every sweep series is drawn.
SERIES_KEY = "line: median, band: IQR, dots: seeds, ★: best seed"


def draw_series(ax: plt.Axes, series: Series) -> tuple | None:
    """Median line, IQR band, seeds as dots, best as a star (conditions with data only).

    Returns the series' legend handle (band, line and star together), or None when nothing
    of it could be drawn (no feasible seed anywhere): such a series gets no legend entry.
    """
    style = series_style(series.method or series.label, series.variant)
    color = style["color"]
    x = np.array(sorted(series.points))
    k = series.scale
    stats = [series.points[c] for c in x]
    med = np.array([k * s.median for s in stats], float)
    if not np.isfinite(med).any():
        return None
    lo = np.array([k * s.q25 for s in stats])
    hi = np.array([k * s.q75 for s in stats])
    band = ax.fill_between(x, lo, hi, color=color, alpha=0.2, linewidth=0)
    (line,) = ax.plot(x, med, color=color, ls=style["ls"], lw=1.6)
    for c, s in zip(x, stats, strict=True):
        if s.values:
            jitter = np.linspace(-1, 1, len(s.values)) * 0.01 * max(np.ptp(x), 1.0)
            ax.plot(c + jitter, k * np.array(s.values), ".", color=color, alpha=0.6, ms=4)
    best = [(c, k * s.best) for c, s in zip(x, stats, strict=True) if np.isfinite(s.best)]
    bx, by = zip(*best, strict=True)
    (star,) = ax.plot(bx, by, "*", color=color, ms=9, mec="k", mew=0.5)
    return (band, line, star)


def _legend(
    ax: plt.Axes, entries: Sequence[tuple[Any, str]], below: bool = False, **kwargs: Any
) -> None:
    """A legend of ``entries`` (handle, label) outside ``ax``: to its right, or below it."""
    if not entries:
        return
    handles, labels = zip(*entries, strict=True)
    where = (
        {"loc": "upper center", "bbox_to_anchor": (0.5, -0.2)}
        if below
        else {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0)}
    )
    ax.legend(
        handles,
        labels,
        **where,
        fontsize=7,
        frameon=False,
        handler_map={tuple: HandlerTuple(ndivide=1)},
        **kwargs,
    )


def _text_entry(text: str) -> tuple[Any, str]:
    """A legend entry of text only (an invisible handle)."""
    return (Patch(visible=False), text)


def sweep_figure(
    panels: Sequence[Panel], xlabel: str, title: str, path: Path, width: float = 6.0
) -> Path:
    """Stacked panels over one condition axis, like the paper's Figs. 4-8 and 15-16.

    Each panel's legend (outside, right) lists its drawn series (the first panel's only, when
    every panel has the same ones) and what the paper states for it.
    """
    fig, axes = plt.subplots(
        len(panels), 1, figsize=(width + 2.6, 2.4 * len(panels) + 0.8), sharex=True
    )
    axes = np.atleast_1d(axes)
    shown: list[list[tuple[Any, str]]] = []
    for ax, panel in zip(axes, panels, strict=True):
        drawn = [(h, s.label) for s in panel.series if (h := draw_series(ax, s)) is not None]
        shown.append(drawn)
        paper = draw_paper(ax, panel)
        ax.set_ylabel(panel.ylabel)
        if panel.title:
            ax.set_title(panel.title, fontsize=9)
        ax.grid(alpha=0.3)
        same = [label for _, label in drawn] == [label for _, label in shown[0]]
        series = drawn if (ax is axes[0] or not same) else []
        _legend(ax, [*series, *([_text_entry(SERIES_KEY)] if series else []), *paper])
    axes[-1].set_xlabel(xlabel)
    fig.suptitle(title, fontsize=10)
    return save(fig, path)


def draw_paper(ax: plt.Axes, panel: Panel) -> list[tuple[Any, str]]:
    """What the paper states for this panel: crosses (labelled inside the axes), dotted
    lines and a quoted trend. Returns their legend entries."""
    entries: list[tuple[Any, str]] = []
    if panel.paper:
        px, py = [p[0] for p in panel.paper], [p[1] for p in panel.paper]
        (cross,) = ax.plot(px, py, "kx", ms=8, mew=2)
        entries.append((cross, "paper"))
        _label_inside(ax, [p for p in panel.paper if len(p) == 3])
    for k, (condition, label) in enumerate(panel.paper_at):
        line = ax.axvline(condition, color="k", ls=":", lw=1.2)
        if k == 0:
            entries.append((line, label))
        else:
            ax.annotate(label, (condition, 0.97), xycoords=("data", "axes fraction"), fontsize=7)
    if panel.paper_note:
        entries.append(_text_entry(panel.paper_note))
    return entries


def _label_inside(ax: plt.Axes, points: Sequence[tuple[float, float, str]]) -> None:
    """Label points so the text stays inside the axes: to the left of points in the right
    half, below points in the top fifth."""
    if not points:
        return
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    for x, y, text in points:
        right = x > 0.5 * (x0 + x1)
        top = y > y0 + 0.8 * (y1 - y0)
        ax.annotate(
            text,
            (x, y),
            xytext=(-7 if right else 7, -5 if top else 4),
            textcoords="offset points",
            ha="right" if right else "left",
            va="top" if top else "bottom",
            fontsize=7,
        )


def save(fig: plt.Figure, path: Path) -> Path:
    """Write ``fig`` to ``path`` (atomically; format from the suffix, :data:`FORMATS`), close
    it and return ``path``."""
    fmt = path.suffix.lstrip(".")
    if fmt not in FORMATS:
        plt.close(fig)
        raise ValueError(f"figure {path}: format {fmt!r}; allowed: {', '.join(FORMATS)}")
    fig.tight_layout()
    try:
        with atomic_path(path) as tmp:  # a killed run never leaves half a figure
            # Vector formats carry no timestamp (metadata), so a rerun writes the same file.
            metadata = {"png": None, "svg": {"Date": None}, "pdf": {"CreationDate": None}}[fmt]
            fig.savefig(tmp, dpi=DPI, format=fmt, bbox_inches="tight", metadata=metadata)
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
    """``quantity`` over the cycle per seed: fore-wing solid, hind-wing dashed, with one
    legend entry each."""
    for trace in traces:
        style = _trace_style(trace)
        ax.plot(trace.cycle, trace.fore[quantity], "-", color=WING_COLORS["fore"], **style)
        ax.plot(trace.cycle, trace.hind[quantity], "--", color=WING_COLORS["hind"], **style)
    ax.plot([], [], "-", color=WING_COLORS["fore"], label="fore-wing")
    ax.plot([], [], "--", color=WING_COLORS["hind"], label="hind-wing")


def _seed_color(trace: Trace, i: int) -> str:
    """Black for the best seed, else a palette colour fixed by the seed in the label."""
    if trace.best:
        return "k"
    digits = "".join(c for c in trace.label.split("(")[0] if c.isdigit())
    return PALETTE[(int(digits) if digits else i) % len(PALETTE)]


def tip_path_figure(traces: Sequence[Trace], title: str, path: Path) -> Path:
    """Wing-tip paths relative to the wing base, side view (x forward, z up), per wing."""
    fig, axes = plt.subplots(1, 2, figsize=(7.5, 3.8))
    for ax, wing in zip(axes, ("fore", "hind"), strict=True):
        for i, trace in enumerate(traces):
            tip = getattr(trace, wing)["tip_path"]
            color = _seed_color(trace, i)
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
    axes[1].legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)
    fig.suptitle(title, fontsize=10)
    return save(fig, path)


@dataclass(frozen=True)
class GroupPanel:
    """A panel of per-seed values in groups (e.g. Fig. 11c's phase differences): each seed a
    dot, the statistic the report judges as a bar, the best seed a star, the paper's values
    as crosses and the rule's band shaded."""

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
    band: tuple[float, float, str] | None = None
    """(low, high, label): a range the rule names, e.g. (0, 15, "in phase: |ΔΦ| < 15°")."""
    ylim: tuple[float, float] | None = None
    paper_note: str = ""
    """What the paper states in words only (a legend line)."""


def draw_groups(ax: plt.Axes, panel: GroupPanel) -> None:
    """Draw one :class:`GroupPanel` with its legend (outside the axes, right)."""
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
            entries.append((cross, "paper"))
    if panel.paper_note:
        entries.append(_text_entry(panel.paper_note))
    ax.set_xlim(-0.5, len(names) - 0.5)
    if panel.ylim is not None:
        ax.set_ylim(*panel.ylim)
    ax.set_xticks(range(len(names)), [n.replace(" ", "\n", 1) for n in names], fontsize=7)
    ax.set_ylabel(panel.ylabel)
    ax.set_title(panel.title, fontsize=9)
    ax.grid(alpha=0.3)
    _legend(ax, entries, below=True)


#: The paper's division of the cycle (Fig. 12 text): the down-stroke is 0 < t/T < 0.5.
PAPER_DOWNSTROKE_END = 0.5


def _mark_downstroke(ax: plt.Axes, label: bool) -> None:
    ax.axvline(
        PAPER_DOWNSTROKE_END,
        color="k",
        ls=":",
        lw=1.0,
        label="paper: down-stroke ends (t/T = 0.5)" if label else None,
    )


def cycle_figure(
    rows: Sequence[tuple[str, Sequence[Trace]]],
    quantity: str,
    ylabel: str,
    title: str,
    path: Path,
    extras: Sequence[GroupPanel] = (),
) -> Path:
    """One panel per flight mode: ``quantity`` of fore (solid) and hind (dashed) over t/T,
    then one :class:`GroupPanel` per ``extras`` (e.g. Fig. 11c's phase differences, Fig. 12c's
    pitch amplitudes)."""
    n = len(rows) + len(extras)
    fig, axes = plt.subplots(1, n, figsize=(3.6 * n, 4.4))
    axes = np.atleast_1d(axes)
    for k, (ax, (name, traces)) in enumerate(zip(axes, rows, strict=False)):
        _plot_wings(ax, traces, quantity)
        _mark_downstroke(ax, label=k == 0)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("cycle t/T [-]")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if k == 0:
            handles, labels = ax.get_legend_handles_labels()
            _legend(
                ax,
                [*zip(handles, labels, strict=True), _text_entry("bold: best seed")],
                below=True,
            )
    for ax, extra in zip(axes[len(rows) :], extras, strict=True):
        draw_groups(ax, extra)
    fig.suptitle(title, fontsize=10)
    return save(fig, path)


def flow_figure(traces: Sequence[Trace], title: str, path: Path) -> Path:
    """Angle of attack and relative speed at 0.75 R over the cycle (Fig. 13); the dotted line
    is the paper's end of the down-stroke (t/T = 0.5: the paper's cycles start with it)."""
    fig, axes = plt.subplots(2, 1, figsize=(8.4, 5.2), sharex=True)
    for k, (ax, (quantity, ylabel)) in enumerate(
        zip(
            axes,
            (
                ("angle_of_attack", "angle of attack [deg]"),
                ("relative_speed", "relative speed at 0.75R [m/s]"),
            ),
            strict=True,
        )
    ):
        _plot_wings(ax, traces, quantity)
        _mark_downstroke(ax, label=k == 0)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[0].legend(
        fontsize=7,
        title="bold: best seed",
        title_fontsize=6,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        frameon=False,
    )
    axes[-1].set_xlabel("cycle t/T [-]")
    fig.suptitle(title, fontsize=10)
    return save(fig, path)


# --- wing shape (Fig. 14) ----------------------------------------------------------------------
#: Line style of each planform (Fig. 14) and its series' variant in Figs. 15-16.
PLANFORM_VARIANT: dict[str, int] = {"tear-drop": 0, "real": 1}


def planform_figure(
    outlines: Sequence[tuple[str, np.ndarray, np.ndarray, np.ndarray]], path: Path
) -> Path:
    """Planforms: (label ``"<wing>, <planform>"``, r [mm], leading edge [mm], trailing edge
    [mm]) per wing and shape; one panel per wing, both at equal aspect and the same scale."""
    fig, axes = plt.subplots(2, 1, figsize=(7.5, 4.6), sharex=True, sharey=True)
    for label, r, upper, lower in outlines:
        wing, _, planform = label.partition(", ")
        ax = axes[0] if wing == "fore" else axes[1]
        color = PALETTE[PLANFORM_VARIANT.get(planform, 2)]
        ls = VARIANT_LINES[PLANFORM_VARIANT.get(planform, 2)]
        ax.plot(r, upper, color=color, ls=ls, label=f"{planform} wing")
        ax.plot(r, lower, color=color, ls=ls)
    for ax, wing in zip(axes, ("fore-wing", "hind-wing"), strict=True):
        ax.set_title(wing, fontsize=9)
        ax.set_ylabel("chordwise [mm]")
        ax.set_aspect("equal", adjustable="box")  # 1 mm is 1 mm on both axes
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    axes[-1].set_xlabel("span r [mm]")
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
        for method, evaluations, values in methods:
            color = method_color(method)
            shown = np.where(np.isfinite(values), values, np.nan)
            for row in shown:
                ax.plot(evaluations, row, "-", color=color, lw=0.5, alpha=0.3)
            with np.errstate(all="ignore"):
                lo, med, hi = np.nanpercentile(shown, [25, 50, 75], axis=0)
            ax.fill_between(evaluations, lo, hi, color=color, alpha=0.2, linewidth=0)
            ax.plot(
                evaluations,
                med,
                "-",
                color=color,
                lw=2,
                label=f"{method_label(method)}: median (IQR)",
            )
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
        # The search's penalised reward, not a record's objective (the best feasible stroke's).
        ax.set_ylabel("best reward so far (penalised) [-]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    fig.suptitle("Budget study: best-so-far over seeds (dotted: preset budgets)", fontsize=10)
    return save(fig, path)
