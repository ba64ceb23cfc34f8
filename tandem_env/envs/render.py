"""The stroke picture: wing-tip paths (side view) and the φ/θ/η histories of the last stroke.

``rgb_array`` frames are drawn on a private Agg canvas (no pyplot: the user's figures are left
alone); ``human`` mode redraws a pyplot window. Matplotlib is imported only when rendering.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..physics import Dragonfly, ModelOptions, stroke_history

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..physics import StrokeHistory

#: Frame size [px] of ``rgb_array`` renders (width, height) and its resolution [dpi].
FRAME_SIZE: tuple[int, int] = (720, 400)
FRAME_DPI = 80
_FIGURE_SIZE = (FRAME_SIZE[0] / FRAME_DPI, FRAME_SIZE[1] / FRAME_DPI)  # [in]
#: Uniform samples per cycle of the plotted histories (plotting only; metrics come from evaluate).
HISTORY_SAMPLES = 120

#: Line style of each wing in the frames.
WING_STYLE = {"fore": {"color": "tab:blue"}, "hind": {"color": "tab:red"}}
_NON_INTERACTIVE = {"agg", "cairo", "pdf", "pgf", "ps", "svg", "template"}


@dataclass(frozen=True)
class Frame:
    """What one picture shows."""

    title: str
    """Task and condition, e.g. "LevelFlight-v0  V = 1.5 m/s"."""
    subtitle: str
    """Reward and headline metrics, or why there is no stroke yet."""
    history: StrokeHistory | None
    """Histories of the stroke, or None before the first step (axes drawn empty)."""


def history_of(batch: Any, k: int, insect: Dragonfly, options: ModelOptions) -> StrokeHistory:
    """Histories of stroke ``k`` of a ``StepBatch`` in the condition it was flown in."""
    result = batch.result
    condition = (float(result.speed[k]), float(result.available_power[k]))
    gamma = float(result.flight_path_angle[k])
    model = {"insect": insect, "options": options, "n_samples": HISTORY_SAMPLES}
    return stroke_history(batch.physical[k], *condition, flight_path_angle=gamma, **model)


def draw(figure: Figure, frame: Frame) -> tuple[Axes, list[Axes]]:
    """Draw ``frame`` onto an empty ``figure``: side view left, angle histories right (φ, θ,
    η); returns those axes, e.g. to animate the stroke over them."""
    figure.clear()
    margins = {"left": 0.07, "right": 0.98, "top": 0.84, "bottom": 0.11}
    grid = figure.add_gridspec(3, 2, width_ratios=(1.0, 1.25), wspace=0.22, hspace=0.12, **margins)
    side = figure.add_subplot(grid[:, 0])
    angle_axes = [figure.add_subplot(grid[i, 1]) for i in range(3)]
    figure.suptitle(f"{frame.title}\n{frame.subtitle}", fontsize=10)

    side.set_title("wing-tip paths, side view", fontsize=9)
    side.set_xlabel("X forward [R]", fontsize=8)
    side.set_ylabel("Z up [R]", fontsize=8)
    side.set(xlim=(-1.15, 1.15), ylim=(-1.15, 1.15), aspect="equal")
    side.axhline(0.0, color="0.85", lw=0.8, zorder=0)
    side.axvline(0.0, color="0.85", lw=0.8, zorder=0)
    side.plot([0.0], [0.0], "k+", ms=8)
    arrow = {"arrowstyle": "->", "color": "0.4"}
    side.annotate("", xy=(1.05, -1.0), xytext=(0.55, -1.0), arrowprops=arrow)
    side.text(0.55, -0.93, "flight", fontsize=7, color="0.4")

    labels = (("sweep", "φ [deg]"), ("elevation", "θ [deg]"), ("pitch", "η [deg]"))
    for axis, (_, label) in zip(angle_axes, labels, strict=True):
        axis.set_ylabel(label, fontsize=8)
        axis.set_xlim(0.0, 1.0)
        axis.tick_params(labelsize=7, labelbottom=axis is angle_axes[-1])
        axis.grid(True, color="0.9")
    angle_axes[-1].set_xlabel("t / T [-] (each wing over its own cycle)", fontsize=8)
    side.tick_params(labelsize=7)

    if frame.history is None:
        centred = {"ha": "center", "va": "center", "fontsize": 10, "color": "0.5"}
        side.text(0.0, 0.35, "no stroke yet\n(call step)", **centred)
        return side, angle_axes
    for name in ("fore", "hind"):
        wing = getattr(frame.history, name)
        style = WING_STYLE[name]
        tip = wing.tip_path
        side.plot(tip[:, 0], tip[:, 2], lw=1.6, label=f"{name}-wing", **style)
        side.plot(tip[0, 0], tip[0, 2], "o", ms=4, **style)
        for axis, (field_name, _) in zip(angle_axes, labels, strict=True):
            axis.plot(wing.cycle_fraction, getattr(wing, field_name), lw=1.4, **style)
    side.legend(loc="upper left", fontsize=7, frameon=False)
    return side, angle_axes


def metrics_line(reward: float, info: dict[str, Any], objective_label: str) -> str:
    """The subtitle: "reward … | objective … | L/W … | F̄_h … | P/m … | feasible"."""
    infeasible = f"infeasible (violation {info['constraint_violation']:.3g})"
    feasible = "feasible" if info["feasible"] else infeasible
    return (
        f"reward {reward:.4g} | {objective_label} {info['objective']:.4g} | "
        f"L/W {info['lift_to_weight']:.3f} | F̄_h {info['excess_horizontal']:+.3f} | "
        f"P/m {info['power_per_mass']:.1f} W/kg | {feasible}"
    )


# --- the envs' side: what a sub-env shows, and the window an env owns ---------------------------
class LastStep(NamedTuple):
    """What the picture of a sub-env shows: its last evaluated step, or None."""

    batch: Any
    index: int


class RenderWindow:
    """The human-mode window of an env: a pyplot figure opened at its first render and redrawn
    in place at each, closed by ``close``, never pickled (a copy opens its own); with a
    non-interactive backend it is drawn but not shown, so headless runs do not block."""

    _window: Any = None

    def _show(self, frame: Frame) -> np.ndarray | None:
        """``frame`` as an RGB array (``render_mode="rgb_array"``) or in the window (``"human"``)."""
        if self.render_mode == "rgb_array":  # type: ignore[attr-defined]  # drawn off-screen
            from matplotlib.backends.backend_agg import FigureCanvasAgg
            from matplotlib.figure import Figure

            canvas = FigureCanvasAgg(Figure(figsize=_FIGURE_SIZE, dpi=FRAME_DPI))
            draw(canvas.figure, frame)
            canvas.draw()
            return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()
        import matplotlib
        import matplotlib.pyplot as plt

        if self._window is None or not plt.fignum_exists(self._window.number):
            self._window = plt.figure(figsize=_FIGURE_SIZE, dpi=FRAME_DPI)
        draw(self._window, frame)
        if matplotlib.get_backend().lower() in _NON_INTERACTIVE:
            self._window.canvas.draw()
        else:
            self._window.canvas.draw_idle()
            plt.pause(1.0 / self.metadata["render_fps"])  # type: ignore[attr-defined]
        return None

    def _close_window(self) -> None:
        if self._window is not None:
            import matplotlib.pyplot as plt

            plt.close(self._window)
            self._window = None

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_window": None}
