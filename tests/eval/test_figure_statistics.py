"""Figures: circular statistics of phases, the paper's statements drawn, legends that name the
wing and list only drawn series, fixed colour-blind-safe colours, the figure formats."""

from __future__ import annotations

import math
import re
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.patches import FancyArrowPatch
from matplotlib.text import Text

from eval import figures
from eval import kinematics_figures as kf
from eval.studies import kinematics, power, speed, wing_shape
from eval.studies.base import StudyPlan
from eval.studies.presets import TINY
from eval.studies.tables import Spread, circular_median, circular_quartiles, spread
from tandem_env import LOWER, PARAMETER_NAMES, UPPER, stroke_history


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
    assert {"paper, tear-drop", "paper: both peak at 1.5 m/s", "paper: falls with V"} <= set(labels)
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
    # The two series of a pair (F̄_v/F̄_h, tear-drop/real) differ in hue, each an Okabe-Ito
    # colour; the defaults' four never share one.
    pairs = [figures.series_style(m, v)["color"] for m in ("cmaes", "pso") for v in (0, 1)]
    assert len(set(pairs)) == 4 and set(pairs) <= set(figures.LINE_HUES)
    assert figures.method_color("policy:runs/a") == figures.method_color("policy:runs/a")
    assert set(figures.METHOD_COLORS.values()) <= set(figures.PALETTE)


def test_method_specs_are_labelled_readably() -> None:
    assert figures.method_label("cmaes") == "CMA-ES"
    assert figures.method_label("pso") == "PSO"
    assert figures.method_label("policy:logs/ppo/level_3/best_model.zip") == (
        "policy level_3/best_model"
    )
    assert figures.method_label("something") == "something"


def test_paper_values_are_named_in_the_legend_not_over_the_data(
    kept: list[plt.Figure], tmp_path: Path
) -> None:
    s = figures.Series("CMA-ES", {50.0: _spread([1, 2]), 90.0: _spread([2, 3])}, method="cmaes")
    derived = "derived: our median × 1.12 (the paper's gain)"
    panel = figures.Panel(
        "F",
        [s],
        paper=[(50.0, 2.7, "paper F̄_v"), (90.0, 4.4, "paper F̄_v"), (50.0, 2.4, "paper F̄_h")],
        derived=[(90.0, 3.1, derived)],
    )
    figures.sweep_figure([panel], "P", "t", tmp_path / "f.png")
    [ax] = kept[0].axes
    assert not ax.texts  # no label inside the axes, where it would cover the data
    legend = ax.get_legend()
    entries = dict(
        zip([t.get_text() for t in legend.get_texts()], legend.legend_handles, strict=True)
    )
    assert {"paper F̄_v", "paper F̄_h", derived} <= set(entries)
    markers = {label: entries[label].get_marker() for label in ("paper F̄_v", "paper F̄_h", derived)}
    assert len(set(markers.values())) == 3  # each quantity its own marker, the derived apart
    # only the paper's own values are labelled "paper"
    assert not any(label.startswith("paper") for label in [derived])


def test_parameter_panels_draw_the_table_4_bounds(kept: list[plt.Figure], tmp_path: Path) -> None:
    s = figures.Series("CMA-ES", {1.0: _spread([31, 40]), 2.0: _spread([30, 35])}, method="cmaes")
    figures.sweep_figure(
        [figures.Panel("φ_m", [s], bounds=(30.0, 60.0))], "V", "t", tmp_path / "f.png"
    )
    [ax] = kept[0].axes
    lines = [ln for ln in ax.lines if ln.get_linestyle() == "--" and len(set(ln.get_ydata())) == 1]
    assert sorted(ln.get_ydata()[0] for ln in lines) == [30.0, 60.0]
    assert figures.BOUND_LABEL in _legend_texts(ax)


@pytest.mark.parametrize("fmt", figures.FORMATS)
def test_figures_are_written_in_each_format(tmp_path: Path, fmt: str) -> None:
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    path = figures.save(fig, figures.figure_path(tmp_path, "f", fmt))
    head = path.read_bytes()[:8]
    assert {"png": b"\x89PNG", "svg": b"<?xml", "pdf": b"%PDF"}[fmt] in head
    # a rerun writes the same file: no timestamp, and SVG's element ids from a fixed salt
    again = plt.figure()
    again.add_subplot().plot([0, 1], [0, 1])
    assert figures.save(again, tmp_path / f"again.{fmt}").read_bytes() == path.read_bytes()


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
    absolute = kf.GroupPanel(
        "(c)", {"level 1.25 m/s": [170.0, 170.0, 5.0]}, "|ΔΦ|", best={"level 1.25 m/s": 5.0}
    )
    signed = kf.GroupPanel(
        "(d)",
        {"level 2 m/s": [136.0, -170.0]},
        "ΔΦ",
        statistic=circular_median,
        statistic_label="circular median",
        paper={"level 2 m/s": 30.0},
    )
    kf.cycle_figure([], "sweep", "φ", "title", tmp_path / "f.png", extras=(absolute, signed))
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
    trace = kf.Trace(
        "seed 0 (best)", True, np.linspace(0, 1, 20), {"tip_path": loop}, {"tip_path": loop}
    )
    kf.tip_path_figure([trace], "Fig. 9", tmp_path / "f.png")
    labels = kept[0].axes[1].get_legend_handles_labels()[1]
    assert kf.START_LABEL in labels and "wing base" in labels
    # The direction: one arrowhead per quarter of the cycle on each wing's best path, above
    # every path and large enough to be seen over a bold line.
    for ax in kept[0].axes:
        arrows = [p for p in ax.patches if isinstance(p, FancyArrowPatch)]
        assert len(arrows) == len(kf.ARROW_PHASES)
        assert all(a.get_zorder() > max(ln.get_zorder() for ln in ax.lines) for a in arrows)
        assert all(a.get_mutation_scale() >= 12 for a in arrows)
    # Each arrow points the way the path runs: from a sample to the next one.
    fig, ax = plt.subplots()
    segments = kf.draw_direction(ax, loop[:, [0, 2]])
    plt.close(fig)
    for (start, end), phase in zip(segments, kf.ARROW_PHASES, strict=True):
        k = min(int(phase * len(loop)), len(loop) - 2)
        assert np.array_equal(start, loop[k, [0, 2]]) and np.array_equal(end, loop[k + 1, [0, 2]])


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


def _ylabels(figs: list[plt.Figure]) -> dict[str, list[str]]:
    """{"Fig. 4": [y-label per panel], ...} of the figures drawn."""
    return {f.get_suptitle().split(":")[0]: [ax.get_ylabel() for ax in f.axes] for f in figs}


def test_sweep_labels_say_what_is_averaged_and_give_the_excess_force_one_unit(
    kept: list[plt.Figure], tmp_path: Path
) -> None:
    for study in (speed, power, wing_shape):  # no records: the figures' axes, without data
        study.analyse(StudyPlan(TINY), {}, tmp_path)
    labels = _ylabels(kept)
    # Figs. 4-5: the means of the fore and hind pairs say so, the totals (T/W, P/m) do not.
    averaged = ("mean angle of attack", "stroke-plane angle", "frequency", "weaving amplitude")
    for label in labels["Fig. 4"] + labels["Fig. 5"]:
        assert (figures.PAIR_MEAN in label) == label.startswith(averaged), label
    # Figs. 7, 8, 16: F̄ (a force over the body weight) has one unit.
    excess = [label for fig in ("Fig. 7", "Fig. 8", "Fig. 16") for label in labels[fig]]
    assert len(excess) == 3 and all("F̄" in label for label in excess)
    assert {re.findall(r"\[[^]]*\]", label)[-1] for label in excess} == {power.EXCESS_UNIT}


def test_tip_paths_of_both_wings_share_limits_and_scale(
    kept: list[plt.Figure], tmp_path: Path
) -> None:
    t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    fore = np.stack([np.cos(t), np.zeros_like(t), 0.3 * np.sin(t)], 1)
    hind = np.stack([0.4 * np.cos(t) + 0.5, np.zeros_like(t), 2.0 * np.sin(t)], 1)
    trace = kf.Trace("seed 0 (best)", True, t / (2 * np.pi), {"tip_path": fore}, {"tip_path": hind})
    kf.tip_path_figure([trace], "Fig. 9", tmp_path / "f.png")
    fig = kept[0]
    fig.canvas.draw()
    ax_fore, ax_hind = fig.axes
    assert ax_fore.get_xlim() == ax_hind.get_xlim() and ax_fore.get_ylim() == ax_hind.get_ylim()
    (x0, x1), (y0, y1) = ax_fore.get_xlim(), ax_fore.get_ylim()
    assert x0 <= -1.0 and x1 >= 1.0 and y0 <= -2.0 and y1 >= 2.0  # both paths in view
    for ax in (ax_fore, ax_hind):  # 1 x/R is as long as 1 z/R
        box = ax.get_window_extent()
        assert box.width / (x1 - x0) == pytest.approx(box.height / (y1 - y0), rel=1e-3)


def test_fig13_names_the_triangle_waves_whose_speed_steps(
    kept: list[plt.Figure], tmp_path: Path
) -> None:
    # The fore-wing's weaving shape K at its upper bound 1 (a triangle wave): φ̇ reverses
    # within one sample, so its relative speed steps there; K = 0.5 (smooth) does not.
    stroke = dict(zip(PARAMETER_NAMES, (0.5 * (LOWER + UPPER)).tolist(), strict=True))
    stroke.update(fore_sweep_shape=1.0, hind_sweep_shape=0.5)
    stroke.update(fore_elevation_harmonic=1.0, hind_elevation_harmonic=1.0)
    h = stroke_history(np.array(list(stroke.values())), 1.25, n_samples=120)

    def largest_step(speed: np.ndarray) -> float:
        """The largest change between neighbouring samples, as a share of the range."""
        return float(np.abs(np.diff(np.r_[speed, speed[:1]])).max() / np.ptp(speed))

    assert largest_step(h.fore.relative_speed) > 0.5
    assert largest_step(h.hind.relative_speed) < 0.1
    # Fig. 13's legend names the wing and seed, and only where K sits at the bound.
    note = kinematics.triangle_note([{"seed": 3, **stroke}])
    assert "fore-wing of seed 3" in note and "hind" not in note
    assert kinematics.triangle_note([{"seed": 3, **stroke, "fore_sweep_shape": 0.9}]) == ""
    fore, hind = ({k: getattr(w, k) for k in kinematics.TRACED} for w in (h.fore, h.hind))
    trace = kf.Trace("seed 3 (best)", True, h.fore.cycle_fraction, fore, hind)
    kf.flow_figure([trace], "Fig. 13", tmp_path / "f.png", note)
    assert note in _legend_texts(kept[0].axes[0])


def _printed_font_sizes(fig: plt.Figure, width_mm: float) -> list[float]:
    """Each visible text's size [pt] once the figure, cropped as ``figures.save`` crops it
    (tight, with the save's padding), is printed ``width_mm`` wide."""
    if fig.get_layout_engine() is None:
        fig.tight_layout()  # as figures.save lays it out
    fig.canvas.draw()
    cropped = fig.get_tightbbox(fig.canvas.get_renderer()).width  # [in]
    printed = width_mm / 25.4 / (cropped + 2 * plt.rcParams["savefig.pad_inches"])
    texts = [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]
    return [t.get_fontsize() * printed for t in texts]


@pytest.mark.parametrize("n_extras", [2, 1])  # Fig. 11 (c, d), Fig. 12 (c)
def test_figs_11_12_are_readable_in_a_journal_column(
    kept: list[plt.Figure], tmp_path: Path, n_extras: int
) -> None:
    # Printed 85 mm wide (a journal's single column), every text is at least 7 pt: the
    # figure is no wider than the column once cropped, its texts no smaller.
    t = np.linspace(0.0, 1.0, 60, endpoint=False)
    wave = {"sweep": 40.0 * np.sin(2 * np.pi * t)}
    traces = [kf.Trace(f"seed {k}" + (" (best)" if k == 0 else ""), k == 0, t, wave, wave)
              for k in range(3)]  # fmt: skip
    long = "circular median (not judged: the model does not depend on ΔΦ)"
    extras = [
        kf.GroupPanel(
            f"({'cd'[k]}) ΔΦ at 2 m/s (K2; > 0: hind leads)",
            {"level 1.25 m/s": [36.0, 40.0, 22.0], "accel. 60 W/kg": [124.0, 78.0, 52.0]},
            "ΔΦ = Φ_hind − Φ_fore [deg]",
            statistic_label=long,
            paper={"level 1.25 m/s": 30.0},
            paper_label="paper: hind leads by ≈ 30°",
            band=(15.0, 45.0, "paper ± 15° (rule)"),
            paper_note="paper: larger in accelerating flight",
            bounds=(1.0, 90.0),
        )
        for k in range(n_extras)
    ]
    rows = [("(a) level flight, V = 1.25 m/s", traces),
            ("(b) accelerating (vertical), 60 W/kg", traces)]  # fmt: skip
    kf.cycle_figure(rows, "sweep", "weaving angle φ [deg]", "Fig. 11: title", tmp_path / "f.png",
                    extras=extras)  # fmt: skip
    sizes = _printed_font_sizes(kept[0], kf.COLUMN_WIDTH_MM)
    assert len(sizes) > 20  # titles, labels, ticks, legends
    assert min(sizes) >= kf.COLUMN_FONT_PT - 1e-9
