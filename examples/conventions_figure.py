"""Draw the figure of the angles of measured kinematics (docs/figures/measured_conventions.png).

    python examples/conventions_figure.py [--out results/figures/measured_conventions.png]

The default writes under results/ (ignored); docs/measured.md's copy is this figure drawn with
``--out docs/figures/measured_conventions.png``.

Every direction in the figure comes from the model's own frame code
(``blade.fill_frame_coefficients``), so the figure shows what the model does.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from tandem_env.physics import blade


def chord(beta: float, phi: float = 0.0, theta: float = 0.0, eta: float = 0.0) -> dict[str, float]:
    """Chord direction e_c in stroke-plane (x_s, z_s) and earth (X, Z) components."""
    angles = np.array([[phi, 0.0, 0.0, theta, 0.0, 0.0, eta, 0.0, 0.0]])
    coef = np.empty((1, blade.N_COEF))
    blade.fill_frame_coefficients.py_func(angles, np.ones(1), beta, False, 1, coef)
    c = coef[0]
    return {
        "xs": c[blade.C_ECX],
        "zs": c[blade.C_ECZ],
        "X": c[blade.C_ECXE],
        "Z": c[blade.C_ECZE],
    }


def section(ax, center, direction, length=0.5, color="k", label=None) -> None:
    """A chord seen edge-on, the leading edge (+e_c end) as a dot."""
    d = np.asarray(direction) / np.hypot(*direction)
    a, b = np.asarray(center) - 0.5 * length * d, np.asarray(center) + 0.5 * length * d
    ax.plot([a[0], b[0]], [a[1], b[1]], color=color, lw=3, solid_capstyle="round")
    ax.plot(*b, "o", color=color, ms=7, label=label)


def arrow(ax, start, vector, color="k", text=None, offset=(0.0, 0.0), **kw) -> None:
    ax.annotate(
        "",
        xy=(start[0] + vector[0], start[1] + vector[1]),
        xytext=start,
        arrowprops={"arrowstyle": "-|>", "color": color, "lw": 1.4},
    )
    if text:
        ax.text(
            start[0] + vector[0] + offset[0], start[1] + vector[1] + offset[1], text, color=color,
            fontsize=8, **kw,
        )  # fmt: skip


def side_view(ax) -> None:
    beta, gamma = np.deg2rad(50.0), np.deg2rad(25.0)
    ax.add_patch(matplotlib.patches.Ellipse((-0.2, -0.05), 1.6, 0.28, color="0.85"))
    ax.text(-0.95, -0.3, "body, head →", fontsize=8, color="0.4")
    ax.plot([-1.2, 1.3], [0, 0], color="0.6", ls="--", lw=0.8)
    ax.text(1.0, 0.04, "horizontal", fontsize=7, color="0.5")
    arrow(ax, (0, 0), (1.1 * np.cos(gamma), 1.1 * np.sin(gamma)), "tab:green",
          "flight path\nγ > 0 climbing", (0.04, -0.22))  # fmt: skip
    x_s = np.array([np.cos(beta), -np.sin(beta)])
    z_s = np.array([np.sin(beta), np.cos(beta)])
    ax.plot(*np.stack([-1.0 * x_s, 1.0 * x_s]).T, color="tab:blue", lw=1.5)
    ax.text(*(1.02 * x_s + [0.02, 0.0]), "stroke plane", color="tab:blue", fontsize=8)
    arrow(ax, (0, 0), 0.7 * z_s, "tab:blue", "z_s (upper side)", (0.05, 0.0))
    start = -0.85 * x_s + 0.15 * z_s
    arrow(ax, start, 0.4 * x_s, "tab:red")
    ax.text(
        *np.add(start, (-0.05, 0.02)), "downstroke: φ̇ > 0", color="tab:red", fontsize=8, ha="right"
    )
    theta = np.linspace(-beta, 0.0, 30)
    ax.plot(0.45 * np.cos(theta), 0.45 * np.sin(theta), color="tab:blue", lw=0.8)
    ax.text(0.5, -0.22, "β", color="tab:blue", fontsize=10)
    g = np.linspace(0.0, gamma, 20)
    ax.plot(0.62 * np.cos(g), 0.62 * np.sin(g), color="tab:green", lw=0.8)
    ax.text(0.66, 0.1, "γ", color="tab:green", fontsize=10)
    ax.set_xlim(-1.7, 1.7)
    ax.set_ylim(-1.0, 1.0)
    ax.set_title("(a) side view from the left, earth axes (X forward, Z up)", fontsize=9)


def top_view(ax) -> None:
    # seen from the upper side of the stroke plane: x_s to the right, y_s (right wing) up
    ax.plot([-0.2, 1.1], [0, 0], color="0.6", lw=0.8)
    ax.text(1.12, -0.03, "x_s (forward\nand down)", fontsize=7, color="0.4")
    ax.add_patch(matplotlib.patches.Ellipse((0.3, 0.0), 1.0, 0.16, color="0.85"))
    for phi, color, text in ((0.0, "0.4", "φ = 0"), (np.deg2rad(35.0), "k", "φ = 35°")):
        span = np.array([np.sin(phi), np.cos(phi)])
        ax.plot([0, span[0]], [0, span[1]], color=color, lw=2)
        ax.text(*(1.05 * span + [0.03, 0.0]), text, fontsize=8, color=color)
    arc = np.linspace(0.0, np.deg2rad(35.0), 20)
    ax.plot(0.7 * np.sin(arc), 0.7 * np.cos(arc), color="tab:red", lw=1)
    ax.text(0.1, 0.42, "φ > 0:\nforward", color="tab:red", fontsize=8)
    ax.text(-0.5, 0.9, "right wing\n(span e_s)", fontsize=8)
    ax.text(-0.45, -0.3, "elevation θ > 0 lifts the tip out of the page (towards z_s)", fontsize=7)
    ax.set_xlim(-0.5, 1.6)
    ax.set_ylim(-0.5, 1.2)
    ax.set_title("(b) stroke plane seen from its upper side: sweep φ", fontsize=9)


def chord_view(ax) -> None:
    # seen from the wing root along the right wing: x_s to the right, z_s up
    beta = 0.0
    ax.plot([-1.3, 1.3], [0, 0], color="tab:blue", lw=1)
    ax.text(1.0, 0.04, "stroke plane", color="tab:blue", fontsize=7)
    cases = (
        (-1.0, 50.0, "η = +50°, forward\n(down)stroke,\nα = 90° − η = 40°", +1),
        (0.0, 0.0, "η = 0: chord\nnormal to\nthe plane", 0),
        (1.0, -50.0, "η = −50°, backward\n(up)stroke,\nα = 90° + η = 40°", -1),
    )
    for x, eta, text, motion in cases:
        c = chord(beta, eta=np.deg2rad(eta))
        section(ax, (x, 0.0), (c["xs"], c["zs"]), 0.55)
        ax.text(x, -0.6, text, fontsize=7, ha="center")
        if motion:
            arrow(ax, (x - 0.15 * motion, -0.35), (0.3 * motion, 0.0), "tab:red")
    ax.text(-1.45, 0.62, "● leading edge (+e_c); η > 0 turns it forward (towards x_s)", fontsize=7)
    ax.text(-1.45, 0.5, "red: the wing's motion", fontsize=7, color="tab:red")
    ax.set_xlim(-1.5, 1.5)
    ax.set_ylim(-0.8, 0.75)
    ax.set_title("(c) chord seen from the root along the span: pitch η", fontsize=9)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results/figures/measured_conventions.png")
    args = parser.parse_args()
    fig, axes = plt.subplots(1, 3, figsize=(14.0, 4.4))
    side_view(axes[0])
    top_view(axes[1])
    chord_view(axes[2])
    for ax in axes:
        ax.set_aspect("equal")
        ax.axis("off")
    fig.tight_layout()
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
