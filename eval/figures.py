"""Paper-style figures of the studies (matplotlib, Agg; PNG, SVG or PDF: :data:`FORMATS`).

Every sweep figure draws the spread over seeds, the paper's statements and the values derived
from them the same way (docs/reproduction.md, "Every figure shows ..."), legends outside the
axes, in Okabe & Ito's colour-blind-safe palette fixed per method and variant
(:func:`series_style`). The kinematics figures (Figs. 9-13): :mod:`eval.kinematics_figures`.
"""

from __future__ import annotations

import textwrap
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.legend_handler import HandlerTuple
from matplotlib.patches import Patch

from tandem_env.io.files import atomic_path

#: Resolution of every PNG the project writes (studies, compare, speed-change) [dots per inch].
DPI = 200
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
#: The palette's hues that read as lines on white (yellow left out), a variant's hue.
LINE_HUES: tuple[str, ...] = PALETTE[:6]
#: Steps along :data:`LINE_HUES` from a method's hue to its variant 1's (2 for variant 2, ...):
#: blue -> orange for CMA-ES, vermillion -> sky blue for PSO, so the defaults' pairs never share
#: a hue with each other.
VARIANT_HUE_STEP = 4
#: Readable names of the method families for legends.
METHOD_NAMES: dict[str, str] = dict(
    cmaes="CMA-ES", pso="PSO", random="random search", policy="policy", ppo="PPO", sac="SAC"
)
#: Fixed colour of each method family (the spec's name before ':'), the palette in this order;
#: other specs get one by checksum, so no colour depends on the figure's other series.
METHOD_COLORS: dict[str, str] = dict(zip(METHOD_NAMES, PALETTE, strict=False))
#: Line style of a series' variant (0: e.g. F̄_v or the tear-drop; 1: F̄_h or the real wing).
VARIANT_LINES: tuple[str, ...] = ("-", "--", ":")
#: The fore- and hind-wing in the kinematics figures.
WING_COLORS: dict[str, str] = {"fore": PALETTE[0], "hind": PALETTE[1]}
#: The paper's stated values, one marker per quantity in a panel (black, in this order).
PAPER_MARKERS: tuple[dict[str, Any], ...] = (
    {"marker": "x", "ms": 8, "mew": 2},
    {"marker": "+", "ms": 10, "mew": 2},
    {"marker": "^", "ms": 7, "mew": 1.5, "mfc": "none"},
)
#: A value derived from a paper's statement (never labelled "paper" alone).
DERIVED_MARKER: dict[str, Any] = {"marker": "D", "ms": 7, "mew": 1.5, "mfc": "none"}
#: The Table 4 bounds of a stroke parameter's panel.
BOUND_STYLE: dict[str, Any] = {"color": "0.45", "ls": "--", "lw": 1.0, "zorder": 1}
BOUND_LABEL = "Table 4 bounds"
#: Appended to the axis label of a quantity that averages the fore and hind pairs.
PAIR_MEAN = "(mean of fore and hind pairs)"


def pair_mean(label: str) -> str:
    """``label`` on two lines, the second saying the pairs are averaged (:data:`PAIR_MEAN`)."""
    return f"{label}\n{PAIR_MEAN}"


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
    """Colour and line style of a method's variant: variant 0 in the method's colour, variant k
    :data:`VARIANT_HUE_STEP` · k steps along :data:`LINE_HUES` from it."""
    color = method_color(method)
    if variant:
        start = LINE_HUES.index(color) if color in LINE_HUES else 0
        color = LINE_HUES[(start + VARIANT_HUE_STEP * variant) % len(LINE_HUES)]
    return {"color": color, "ls": VARIANT_LINES[variant % len(VARIANT_LINES)]}


def figure_path(folder: Path, stem: str, fmt: str = FORMATS[0]) -> Path:
    """``folder/stem.fmt``; ValueError for a format not in :data:`FORMATS`."""
    if fmt not in FORMATS:
        raise ValueError(f"figure format {fmt!r}; allowed: {', '.join(FORMATS)}")
    return folder / f"{stem}.{fmt}"


@dataclass(frozen=True)
class Series:
    """One line of a sweep panel: {condition: spread over seeds} with a label."""

    label: str
    points: Mapping[float, Any]
    """Each condition's ``eval.studies.tables.Spread``: its ``values`` (one per seed),
    ``median``, ``q25``, ``q75`` and ``best``."""
    scale: float = 1.0
    """Multiplies every value (e.g. 100 for a percentage)."""
    method: str = ""
    """The method spec whose fixed colour the series has (:func:`series_style`); empty: the
    label's."""
    variant: int = 0
    """Which of a method's series this is (line style, hue): 0, 1, ..."""


@dataclass(frozen=True)
class Panel:
    """One panel of a sweep figure."""

    ylabel: str
    series: Sequence[Series]
    paper: Sequence[tuple[float, float] | tuple[float, float, str]] = field(default=())
    """(condition, value) or (condition, value, label) values the paper states; one black
    marker per label, named in the legend (no label: "paper")."""
    title: str = ""
    paper_at: Sequence[tuple[float, str]] = field(default=())
    """(condition, label): conditions the paper names, e.g. (1.5, "paper: peak")."""
    paper_note: str = ""
    """A trend the paper states in words only, e.g. "paper: falls with V"."""
    derived: Sequence[tuple[float, float, str]] = field(default=())
    """(condition, value, label): values derived from a paper's statement and our data; the
    label says how (e.g. "our tear-drop median × 1.12: the paper's gain"), drawn apart from
    :attr:`paper`."""
    bounds: tuple[float, float] | None = None
    """The Table 4 (low, high) of the stroke parameter drawn (``tables.table4_bounds``)."""


#: Legend entry explaining how every sweep series is drawn.
SERIES_KEY = "line: median, band: IQR, dots: seeds, ★: best seed"


def draw_series(ax: Axes, series: Series) -> tuple | None:
    """Median line, IQR band, seeds as dots, best as a star (conditions with data only); the
    legend handle (band, line and star), or None where no seed is feasible (no entry)."""
    style = series_style(series.method or series.label, series.variant)
    color = style["color"]
    x = np.array(sorted(series.points))
    k = series.scale
    stats = [series.points[c] for c in x]
    med = np.array([k * s.median for s in stats], float)
    if not np.isfinite(med).any():
        return None
    lo, hi = (np.array([k * getattr(s, q) for s in stats]) for q in ("q25", "q75"))
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


def legend(
    ax: Axes,
    entries: Sequence[tuple[Any, str]],
    below: bool = False,
    wrap: int = 0,
    gap: float = 4.0,
    **kwargs: Any,
) -> None:
    """A legend of ``entries`` (handle, label) outside ``ax``: to its right, or below it,
    ``gap`` font sizes under the axes (4: clear of two lines of tick labels, or one and an
    axis label, whatever the axes' height); ``wrap``: labels broken into lines of at most
    this many characters (0: not)."""
    if not entries:
        return
    handles, labels = zip(*entries, strict=True)
    if wrap:
        labels = tuple(textwrap.fill(label, wrap) for label in labels)
    where = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0)}
    if below:
        where = {"loc": "upper center", "bbox_to_anchor": (0.5, 0.0), "borderaxespad": gap}
    handler = {tuple: HandlerTuple(ndivide=1)}
    ax.legend(handles, labels, **where, fontsize=7, frameon=False, handler_map=handler, **kwargs)


def text_entry(text: str) -> tuple[Any, str]:
    """A legend entry of text only (an invisible handle)."""
    return (Patch(visible=False), text)


def draw_bounds(ax: Axes, bounds: tuple[float, float] | None) -> list[tuple[Any, str]]:
    """A stroke parameter's Table 4 bounds as two grey dashed lines; their legend entry."""
    if bounds is None:
        return []
    for value in bounds:
        line = ax.axhline(value, **BOUND_STYLE)
    return [(line, BOUND_LABEL)]


def sweep_figure(panels: Sequence[Panel], xlabel: str, title: str, path: Path) -> Path:
    """Stacked panels over one condition axis (the paper's Figs. 4-8 and 15-16), each legend
    its drawn series (the first panel's only, when all have the same), the paper and bounds."""
    fig, axes = plt.subplots(len(panels), 1, figsize=(8.6, 2.4 * len(panels) + 0.8), sharex=True)
    axes = np.atleast_1d(axes)
    shown: list[list[tuple[Any, str]]] = []
    for ax, panel in zip(axes, panels, strict=True):
        drawn = [(h, s.label) for s in panel.series if (h := draw_series(ax, s)) is not None]
        shown.append(drawn)
        paper = draw_paper(ax, panel)
        bounds = draw_bounds(ax, panel.bounds)
        ax.set_ylabel(panel.ylabel)
        if panel.title:
            ax.set_title(panel.title, fontsize=9)
        ax.grid(alpha=0.3)
        same = [label for _, label in drawn] == [label for _, label in shown[0]]
        series = drawn if (ax is axes[0] or not same) else []
        key = [text_entry(SERIES_KEY)] if series else []
        legend(ax, [*series, *key, *paper, *bounds])
    axes[-1].set_xlabel(xlabel)
    fig.suptitle(title, fontsize=10)
    return save(fig, path)


def draw_paper(ax: Axes, panel: Panel) -> list[tuple[Any, str]]:
    """The paper's values (a black marker per label), named conditions (dotted) and trend, then
    the values derived from it (open diamonds); the legend entries (no text inside the axes)."""

    def marks(points: Sequence[tuple], color: str, styles: Sequence[dict]) -> list[tuple]:
        """A marker style per label of (condition, value[, label]) points; legend entries."""
        labelled = [(p[0], p[1], p[2] if len(p) == 3 else "paper") for p in points]
        entries = []
        for k, label in enumerate(dict.fromkeys(p[2] for p in labelled)):
            x, y = zip(*[(c, v) for c, v, name in labelled if name == label], strict=True)
            (mark,) = ax.plot(x, y, ls="", color=color, zorder=4, **styles[k % len(styles)])
            entries.append((mark, label))
        return entries

    entries = marks(panel.paper, "k", PAPER_MARKERS)
    for k, (condition, label) in enumerate(panel.paper_at):
        line = ax.axvline(condition, color="k", ls=":", lw=1.2)
        if k == 0:
            entries.append((line, label))
        else:
            ax.annotate(label, (condition, 0.97), xycoords=("data", "axes fraction"), fontsize=7)
    if panel.paper_note:
        entries.append(text_entry(panel.paper_note))
    return entries + marks(panel.derived, "0.3", (DERIVED_MARKER,))


def save(fig: plt.Figure, path: Path, crop: bool = True) -> Path:
    """Write ``fig`` to ``path`` (atomically; format from the suffix, :data:`FORMATS`; PNG at
    :data:`DPI`; ``crop``: laid out and cropped to what is drawn, else at the figure's own size
    and layout), close it and return ``path``."""
    fmt = path.suffix.lstrip(".")
    if fmt not in FORMATS:
        plt.close(fig)
        raise ValueError(f"figure {path}: format {fmt!r}; allowed: {', '.join(FORMATS)}")
    if crop and fig.get_layout_engine() is None:  # a figure with its own layout keeps it
        fig.tight_layout()
    try:
        # A killed run never leaves half a figure. A rerun writes the same file: vector formats
        # carry no timestamp (metadata), and SVG's element ids hash a fixed salt, not a random one.
        with atomic_path(path) as tmp, plt.rc_context({"svg.hashsalt": "tandem_env"}):
            metadata = {"png": None, "svg": {"Date": None}, "pdf": {"CreationDate": None}}[fmt]
            bbox = "tight" if crop else None
            fig.savefig(tmp, dpi=DPI, format=fmt, bbox_inches=bbox, metadata=metadata)
    finally:
        plt.close(fig)
    return path


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
        # the hues and line styles of the planforms' series in Figs. 15-16 (of CMA-ES, blue)
        style = series_style("cmaes", PLANFORM_VARIANT.get(planform, 2))
        ax.plot(r, upper, label=f"{planform} wing", **style)
        ax.plot(r, lower, **style)
    for ax, wing in zip(axes, ("fore-wing", "hind-wing"), strict=True):
        ax.set_title(wing, fontsize=9)
        ax.set_ylabel("chordwise [mm]")
        ax.set_aspect("equal", adjustable="box")  # 1 mm is 1 mm on both axes
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    axes[-1].set_xlabel("span r [mm]")
    fig.suptitle("Fig. 14: tear-drop and real wing planforms (equal area and span)", fontsize=10)
    return save(fig, path)


def convergence_figure(
    panels: Sequence[
        tuple[str, Sequence[tuple[str, np.ndarray, np.ndarray]], Sequence[tuple[str, int]]]
    ],
    path: Path,
) -> Path:
    """Best-so-far over evaluations per condition (label, [(method, evaluations (n,), values
    (seeds, n))], [(preset name, budget)]): per method the median, IQR band and each seed thin,
    the presets' budgets dotted; the y-axis from the worst seed after 5 % of the run."""
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
            label = f"{method_label(method)}: median (IQR)"
            ax.plot(evaluations, med, "-", color=color, lw=2, label=label)
            later = shown[:, evaluations >= 0.05 * evaluations[-1]]
            if np.isfinite(later).any():
                lows.append(np.nanmin(later))
                highs.append(np.nanmax(later))
        for name, budget in budgets:
            ax.axvline(budget, color="grey", ls=":", lw=1)
            at = ("data", "axes fraction")
            ax.annotate(name, (budget, 0.02), xycoords=at, fontsize=7, rotation=90)
        if lows:
            low, high = min(lows), max(highs)
            pad = 0.05 * max(high - low, 1e-9)
            ax.set_ylim(low - pad, high + pad)
        ax.set_title(label, fontsize=9)
        # The search's penalised reward, not a record's objective (the best feasible stroke's).
        ax.set(xlabel="model evaluations [-]", ylabel="best reward so far (penalised) [-]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    fig.suptitle("Budget study: best-so-far over seeds (dotted: preset budgets)", fontsize=10)
    return save(fig, path)
