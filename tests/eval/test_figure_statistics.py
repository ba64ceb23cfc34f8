"""Figures: circular statistics of phases, the paper's statements drawn, legends that name the wing."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest

from eval import figures
from eval.studies import wing_shape
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


def test_sweep_panels_draw_what_the_paper_states(kept: list[plt.Figure], tmp_path: Path) -> None:
    series = figures.Series("pso, tear-drop wing", {1.0: _spread([1, 2]), 2.0: _spread([2, 3])})
    panel = figures.Panel(
        "η [%]",
        [series],
        paper=[(1.5, 12.7, "paper, tear-drop")],
        paper_at=[(1.5, "paper: both peak at 1.5 m/s")],
        paper_note="paper: falls with V",
    )
    figures.sweep_figure([panel], "V", "title", tmp_path / "f.png")
    [ax] = kept[0].axes
    labels = ax.get_legend_handles_labels()[1]
    assert "paper" in labels and "paper: both peak at 1.5 m/s" in labels
    assert "pso, tear-drop wing (median, IQR)" in labels
    assert "paper: falls with V" in [t.get_text() for t in ax.texts]
    [vertical] = [line for line in ax.lines if line.get_label() == "paper: both peak at 1.5 m/s"]
    assert list(vertical.get_xdata()) == [1.5, 1.5]


def test_phase_panel_bar_is_the_circular_median(kept: list[plt.Figure], tmp_path: Path) -> None:
    groups = {"level 2 m/s": [136.0, -170.0]}
    figures.cycle_figure(
        [],
        "sweep",
        "φ",
        "title",
        tmp_path / "f.png",
        extra=("(c)", groups, "ΔΦ [deg]"),
        extra_median=circular_median,
        extra_median_label="circular median",
        extra_paper={"level 2 m/s": 30.0},
    )
    [ax] = kept[0].axes
    bars = [line for line in ax.lines if line.get_linewidth() == 2 and len(line.get_xdata()) == 2]
    assert [list(bar.get_ydata()) for bar in bars] == [[163.0, 163.0]]
    assert {"circular median", "paper"} <= set(ax.get_legend_handles_labels()[1])


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
    assert wing_shape._label("pso", "tear-drop") == "pso, tear-drop wing"
    assert wing_shape._label("pso", "real") == "pso, real wing"
