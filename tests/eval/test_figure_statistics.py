"""Figures: circular statistics of phases, the paper's statements drawn, legends that name the
wing and list only drawn series, fixed colour-blind-safe colours, the figure formats."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest

from eval import figures
from eval.studies import wing_shape
from eval.studies.base import StudyPlan
from eval.studies.presets import TINY
from eval.studies.tables import Spread, circular_median, circular_quartiles, spread


@pytest.mark.parametrize(
    ("angles", "median"),
    [
        ([136.0, -170.0], 163.0),  # the seeds: a linear median gives -17
        ([170.0, -170.0, 175.0], 175.0),
        ([10.0, 20.0, 30.0], 20.0),  # within a half circle: the ordinary median
        ([10.0, 20.0, 30.0, 40.0], 25.0),
        ([-20.0, 0.0, 10.0, 180.0, 5.0], 5.0),
        ([], math.nan),
    ],
)
def test_circular_median(angles: list[float], median: float) -> None:
    got = circular_median(angles)
    if math.isnan(median):
        assert math.isnan(got)
    else:
        assert got == pytest.approx(median)
        # invariant: rotating every angle rotates the median (the wrap point is irrelevant)
        rotated = circular_median([a + 100.0 for a in angles])
        assert ((rotated - got - 100.0 + 180.0) % 360.0 - 180.0) == pytest.approx(0.0, abs=1e-9)


def test_circular_quartiles_bracket_the_median() -> None:
    q25, q75 = circular_quartiles([136.0, -170.0], 163.0)
    assert q25 == pytest.approx(149.5) and q75 == pytest.approx(176.5)
    assert circular_quartiles([10.0, 20.0, 30.0], 20.0) == pytest.approx((15.0, 25.0))


def _row(seed: int, phase: float, objective: float) -> dict:
    return {
        "seed": seed,
        "feasible": True,
        "objective_value": objective,
        "phase_difference": phase,
        "phase_difference_abs": abs(phase),
    }


def test_phase_spread_is_circular_and_other_quantities_are_not() -> None:
    rows = [_row(0, 136.0, 0.2), _row(1, -170.0, 0.3)]
    phase = spread(rows, "phase_difference")
    assert phase.median == pytest.approx(163.0)
    assert (phase.q25, phase.q75) == pytest.approx((149.5, 176.5))
    assert phase.best == -170.0 and phase.best_seed == 1
    assert spread(rows, "phase_difference_abs").median == pytest.approx(153.0)


@pytest.fixture
def kept(monkeypatch: pytest.MonkeyPatch) -> list[plt.Figure]:
    """Figures as drawn, kept open instead of saved."""
    figs: list[plt.Figure] = []

    def keep(fig: plt.Figure, path: Path) -> Path:
        figs.append(fig)
        return path

    monkeypatch.setattr(figures, "save", keep)
    yield figs
    for fig in figs:
        plt.close(fig)


def _spread(values: list[float]) -> Spread:
    return Spread(tuple(values), tuple(range(len(values))), *np.percentile(values, [50, 25, 75]),
                  max(values), 0, len(values), len(values))  # fmt: skip


def _legend_texts(ax: plt.Axes) -> list[str]:
    legend = ax.get_legend()
    return [] if legend is None else [t.get_text() for t in legend.get_texts()]


def test_sweep_panels_draw_what_the_paper_states(kept: list[plt.Figure], tmp_path: Path) -> None:
    series = figures.Series("PSO, tear-drop wing", {1.0: _spread([1, 2]), 2.0: _spread([2, 3])})
    panel = figures.Panel(
        "η [%]",
        [series],
        paper=[(1.5, 12.7, "paper, tear-drop")],
        paper_at=[(1.5, "paper: both peak at 1.5 m/s")],
        paper_note="paper: falls with V",
    )
    figures.sweep_figure([panel], "V", "title", tmp_path / "f.png")
    [ax] = kept[0].axes
    labels = _legend_texts(ax)
    assert {"paper", "paper: both peak at 1.5 m/s", "paper: falls with V"} <= set(labels)
    assert "PSO, tear-drop wing" in labels and figures.SERIES_KEY in labels
    [vertical] = [line for line in ax.lines if list(line.get_xdata()) == [1.5, 1.5]]
    assert vertical.get_linestyle() == ":"


def test_legends_list_only_drawn_series_outside_the_axes(
    kept: list[plt.Figure], tmp_path: Path
) -> None:
    nan = math.nan
    empty = Spread((), (), nan, nan, nan, nan, None, 2, 0)  # no feasible seed
    drawn = figures.Series("CMA-ES", {1.0: _spread([1, 2]), 2.0: _spread([2, 3])}, method="cmaes")
    missing = figures.Series("PSO", {1.0: empty, 2.0: empty}, method="pso")
    figures.sweep_figure([figures.Panel("y", [drawn, missing])], "V", "t", tmp_path / "f.png")
    [ax] = kept[0].axes
    labels = _legend_texts(ax)
    assert "CMA-ES" in labels and "PSO" not in labels
    # The legend sits right of the axes (anchored beyond x = 1 in axes coordinates): it
    # covers no data and no paper mark.
    legend = ax.get_legend()
    assert legend.get_bbox_to_anchor().transformed(ax.transAxes.inverted()).x0 > 1.0


def test_colours_are_fixed_per_series_and_colour_blind_safe() -> None:
    # A series' colour depends on its method and variant only, not on its place in a figure.
    assert figures.series_style("cmaes") == figures.series_style("cmaes", 0)
    assert figures.series_style("pso")["color"] != figures.series_style("cmaes")["color"]
    assert figures.series_style("cmaes", 1)["ls"] != figures.series_style("cmaes", 0)["ls"]
    assert figures.method_color("policy:runs/a") == figures.method_color("policy:runs/a")
    assert set(figures.METHOD_COLORS.values()) <= set(figures.PALETTE)


def test_method_specs_are_labelled_readably() -> None:
    assert figures.method_label("cmaes") == "CMA-ES"
    assert figures.method_label("pso") == "PSO"
    assert figures.method_label("policy:logs/ppo/level_3/best_model.zip") == (
        "policy level_3/best_model"
    )
    assert figures.method_label("something") == "something"


def test_paper_labels_stay_inside_the_axes(kept: list[plt.Figure], tmp_path: Path) -> None:
    s = figures.Series("CMA-ES", {50.0: _spread([1, 2]), 90.0: _spread([2, 3])}, method="cmaes")
    panel = figures.Panel("F", [s], paper=[(50.0, 2.7, "paper F̄_v"), (90.0, 4.4, "paper F̄_v")])
    figures.sweep_figure([panel], "P", "t", tmp_path / "f.png")
    [ax] = kept[0].axes
    kept[0].canvas.draw()
    box = ax.get_window_extent()
    for text in ax.texts:
        extent = text.get_window_extent()
        assert box.x0 <= extent.x0 and extent.x1 <= box.x1, text.get_text()


@pytest.mark.parametrize("fmt", figures.FORMATS)
def test_figures_are_written_in_each_format(tmp_path: Path, fmt: str) -> None:
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    path = figures.save(fig, figures.figure_path(tmp_path, "f", fmt))
    head = path.read_bytes()[:8]
    assert {"png": b"\x89PNG", "svg": b"<?xml", "pdf": b"%PDF"}[fmt] in head


def test_an_unknown_format_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="format 'jpg'; allowed: png, svg, pdf"):
        figures.figure_path(tmp_path, "f", "jpg")
    fig = plt.figure()
    with pytest.raises(ValueError, match="allowed: png, svg, pdf"):
        figures.save(fig, tmp_path / "f.gif")
    with pytest.raises(ValueError, match="figure_format = 'jpg'"):
        StudyPlan(TINY, figure_format="jpg")
    assert StudyPlan(TINY, figure_format="svg").figure(tmp_path, "fig6") == tmp_path / "fig6.svg"


def test_phase_panels_show_the_statistic_the_report_judges(
    kept: list[plt.Figure], tmp_path: Path
) -> None:
    # K1/K3 judge the median of |ΔΦ|; K2 the circular median of ΔΦ.
    absolute = figures.GroupPanel(
        "(c)", {"level 1.25 m/s": [170.0, 170.0, 5.0]}, "|ΔΦ|", best={"level 1.25 m/s": 5.0}
    )
    signed = figures.GroupPanel(
        "(d)",
        {"level 2 m/s": [136.0, -170.0]},
        "ΔΦ",
        statistic=circular_median,
        statistic_label="circular median",
        paper={"level 2 m/s": 30.0},
    )
    figures.cycle_figure([], "sweep", "φ", "title", tmp_path / "f.png", extras=(absolute, signed))
    for ax, expected in zip(kept[0].axes, (170.0, 163.0), strict=True):
        bars = [
            line for line in ax.lines if line.get_linewidth() == 2 and len(line.get_xdata()) == 2
        ]
        assert [list(bar.get_ydata()) for bar in bars] == [[expected, expected]]
    assert "paper" in _legend_texts(kept[0].axes[1])
    assert "best seed" in _legend_texts(kept[0].axes[0])


def test_tip_path_markers_are_explained(kept: list[plt.Figure], tmp_path: Path) -> None:
    loop = np.stack(
        [np.cos(np.linspace(0, 6.3, 20)), np.zeros(20), np.sin(np.linspace(0, 6.3, 20))], 1
    )
    trace = figures.Trace(
        "seed 0 (best)", True, np.linspace(0, 1, 20), {"tip_path": loop}, {"tip_path": loop}
    )
    figures.tip_path_figure([trace], "Fig. 9", tmp_path / "f.png")
    labels = kept[0].axes[1].get_legend_handles_labels()[1]
    assert "best seed at t = 0 (arrow: direction)" in labels and "wing base" in labels


def test_wing_shape_legends_name_both_wings() -> None:
    assert wing_shape._label("pso", "tear-drop") == "PSO, tear-drop wing"
    assert wing_shape._label("pso", "real") == "PSO, real wing"


def test_planforms_are_drawn_at_equal_aspect(kept: list[plt.Figure], tmp_path: Path) -> None:
    figures.planform_figure(wing_shape.planform_outlines(20), tmp_path / "f.png")
    fig = kept[0]
    fig.canvas.draw()
    for ax in fig.axes[:2]:
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        box = ax.get_window_extent()
        # 1 mm spans as many pixels along the span as along the chord
        assert (box.width / (x1 - x0)) == pytest.approx(box.height / (y1 - y0), rel=1e-3)
