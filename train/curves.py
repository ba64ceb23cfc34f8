"""``python -m train.curves``: reward curves of one or more runs (one line per run / seed).

Left: the mean reward of the strokes the training env evaluated (from the Monitor CSVs, in
bins of env steps). Right: the objective (η or F̄) of the best *feasible* stroke seen so far
and, as markers, the deterministic policy's reward at each evaluation (evaluations.npz)::

    python -m train.curves --runs logs/ppo/TandemWing-LevelFlight-v0_{1,2,3} \\
        --out results/figures/ppo_level_v15.png --title "PPO, level flight, V = 1.5 m/s"
"""

from __future__ import annotations

import csv
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tandem_env.io.files import atomic_path, read_json
from train.entry import command, option
from train.run_folder import read_run_folder


def read_run(run_dir: str | Path) -> tuple[str, np.ndarray, np.ndarray, np.ndarray, Any, Any]:
    """What one run folder's Monitor CSVs (every segment, in order), ``evaluations.npz`` and
    ``result.json`` say: its label; per training stroke (n,) its reward and the objective of
    the best feasible stroke so far (NaN before the first); the env steps of the evaluations
    and the deterministic policy's mean reward over the evaluation conditions at each; and the
    wall time [s] (None if unknown)."""
    layout = read_run_folder(run_dir, "a run folder of python -m train")[0]
    rows = []
    for path in layout.monitor_files():
        with path.open() as stream:
            stream.readline()  # JSON header
            rows += [
                (float(r["r"]), float(r["objective"]), r["feasible"] == "True")
                for r in csv.DictReader(stream)
            ]
    reward, objective, feasible = np.array(rows, dtype=np.float64).reshape(-1, 3).T
    best = np.maximum.accumulate(np.where(feasible == 1.0, objective, -np.inf))
    best = np.where(np.isfinite(best), best, np.nan)
    eval_steps = eval_reward = np.zeros(0)
    if layout.evaluations.is_file():
        with np.load(layout.evaluations) as data:
            eval_steps, eval_reward = data["timesteps"], data["results"].mean(axis=1)
    wall = (
        read_json(layout.result_file).get("wall_time_s") if layout.result_file.is_file() else None
    )
    return layout.run_dir.name, reward, best, eval_steps, eval_reward, wall


def binned_mean(steps: np.ndarray, values: np.ndarray, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean of ``values`` in ``bins`` equal bins of ``steps`` (bin centres, means)."""
    edges = np.linspace(0, steps[-1], bins + 1)
    index = np.clip(np.searchsorted(edges, steps, side="left") - 1, 0, bins - 1)
    sums = np.bincount(index, values, minlength=bins)
    counts = np.bincount(index, minlength=bins)
    keep = counts > 0
    return 0.5 * (edges[:-1] + edges[1:])[keep], sums[keep] / counts[keep]


def plot(runs: Sequence[str | Path], out: str | Path, title: str, bins: int = 60) -> Path:
    """Write the two-panel figure (small PNG) for ``runs``."""
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curves = [read_run(r) for r in runs]
    fig, (left, right) = plt.subplots(1, 2, figsize=(8.0, 3.0), dpi=90)
    for k, (name, reward, best, eval_steps, eval_reward, wall) in enumerate(curves):
        color = f"C{k}"
        steps = np.arange(1, len(reward) + 1)  # env step of each training stroke (1-based)
        if len(steps):
            x, y = binned_mean(steps, reward, bins)
            label = name + ("" if wall is None else f" ({wall:.0f} s)")
            left.plot(x, y, color=color, lw=1.2, label=label)
            every = max(1, len(steps) // 400)
            right.plot(steps[::every], best[::every], color=color, lw=1.2)
        if len(eval_steps):
            right.plot(eval_steps, eval_reward, ".", color=color, ms=3)
    left.set_yscale("symlog", linthresh=1.0)
    # symlog's default ticks leave this range unlabelled; name the decades.
    left.set_yticks([-100, -30, -10, -3, -1, 0, 0.5])
    left.yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    left.set(xlabel="env steps (strokes evaluated)", ylabel="mean training reward")
    left.legend(fontsize=7)
    right.set_xlabel("env steps")
    if any(len(evaluation_steps) for _, _, _, evaluation_steps, _, _ in curves):
        right.set_ylabel("best feasible objective (line)\ndeterministic reward (dots)", fontsize=8)
        right.set_ylim(-0.5, None)  # deterministic rewards far below 0 are off the chart
    else:
        right.set_ylabel("best feasible objective seen", fontsize=8)
    for axes in (left, right):
        axes.grid(alpha=0.3)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    out = Path(out)
    with atomic_path(out) as tmp:  # its folder made, and no half-written PNG if killed
        fig.savefig(tmp)
    plt.close(fig)
    return out


@dataclass(frozen=True)
class CurvesOptions:
    """Reward curves of one or more runs (one line per run / seed)."""

    runs: tuple[str, ...] = option("--runs")
    """Run folders."""
    out: str = option("--out")
    """PNG to write."""
    title: str = option("--title", default="reward curves")
    """The figure's title."""


def main(argv: Sequence[str] | None = None) -> int:
    with command(CurvesOptions, argv) as args:
        path = plot(args.runs, args.out, args.title)
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} kB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
