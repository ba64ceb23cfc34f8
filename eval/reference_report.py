"""The reference table as people read it: a Markdown table and a figure of the optima against
the condition, every seed's optimum beside the best (``python -m eval reference``)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from tandem_env.envs.registration import config_class

# Okabe-Ito colours, one per objective (readable in colour-blind vision and in grey).
_COLOURS = {"efficiency": "#0072B2", "vertical": "#0072B2", "horizontal": "#D55E00",
            "resultant": "#009E73"}  # fmt: skip
_LINES = {"tear-drop": "-", "real": "--"}


def _condition_header(env_id: str) -> str:
    condition = config_class(env_id).CONDITION
    assert condition is not None
    return f"{condition.symbol} [{condition.unit}]"


def _spread(point: Mapping[str, Any]) -> str:
    values = [v for v in point["seed_objectives"] if v is not None]
    if not values:
        return "none feasible"
    return f"{min(values):.4g}-{max(values):.4g} ({len(values)}/{len(point['seed_objectives'])})"


def reference_markdown(table: Mapping[str, Any]) -> str:
    """One table per task: the optimum of each objective and planform at each condition, with
    the range of the search's seeds' feasible optima (how many seeds found a feasible stroke)."""
    by_env: dict[str, list[Mapping[str, Any]]] = {}
    for series in table["series"]:
        by_env.setdefault(series["env_id"], []).append(series)
    parts = []
    for env_id, series_list in by_env.items():
        columns = [f"{s['objective']}, {s['planform']}" for s in series_list]
        head = f"| {_condition_header(env_id)} | " + " | ".join(f"{c} | seeds" for c in columns)
        rule = "|---" * (1 + 2 * len(columns)) + "|"
        rows = []
        for i, point in enumerate(series_list[0]["points"]):
            cells = [f"{point['condition']:g}"]
            for s in series_list:
                p = s["points"][i]
                cells += [f"{p['objective']:.4g}" if p["feasible"] else "-", _spread(p)]
            rows.append("| " + " | ".join(cells) + " |")
        parts.append(f"**{env_id}**\n\n{head} |\n{rule}\n" + "\n".join(rows) + "\n")
    provenance = table["provenance"]
    budgets = ", ".join(
        f"{env_id.split('/')[-1]} {budget:,}" for env_id, budget in provenance["budgets"].items()
    )
    hours = provenance["optimisation_seconds"] / 3600
    parts.append(
        f"Made by `{provenance['command']}` on {provenance['date']} (tandem_env "
        f"{provenance['versions']['tandem_env']}): {provenance['method']}, seeds "
        f"{provenance['seeds']}, budgets {budgets} evaluations, then continuation: "
        f"{provenance['continuation']}; {provenance['optimisations']} optimisations, "
        f"{hours:.2f} h of one core's time in all (their records' wall times summed). "
        + " ".join(
            f"Continuation round {c['round']} raised {c['points_raised']} of the points by more "
            f"than {provenance['raised_percent']:g} %, by at most {c['largest_gain_percent']:.2f} % (median "
            f"{c['median_gain_percent']:.3f} %)."
            for c in provenance["convergence"]
        )
        + "\n"
    )
    return "\n".join(parts)


def write_reference_figure(table: Mapping[str, Any], path: Path) -> None:
    """The optima against the condition: one panel per task, a line per objective and
    planform (solid tear-drop, dashed real), every seed's feasible optimum as a faint dot."""
    import matplotlib.pyplot as plt

    from eval.figures import save

    env_ids = list(dict.fromkeys(s["env_id"] for s in table["series"]))
    fig, axes = plt.subplots(1, len(env_ids), figsize=(5.2 * len(env_ids), 3.8), squeeze=False)
    for ax, env_id in zip(axes[0], env_ids, strict=True):
        objectives = config_class(env_id).OBJECTIVES
        assert objectives is not None
        for series in (s for s in table["series"] if s["env_id"] == env_id):
            colour = _COLOURS.get(series["objective"], "#000000")
            points = [p for p in series["points"] if p["feasible"]]
            ax.plot(
                [p["condition"] for p in points],
                [p["objective"] for p in points],
                _LINES.get(series["planform"], ":"),
                color=colour,
                marker="o",
                markersize=3,
                label=f"{series['objective']}, {series['planform']}",
            )
            for p in series["points"]:
                seeds = [v for v in p["seed_objectives"] if v is not None]
                ax.plot([p["condition"]] * len(seeds), seeds, ".", color=colour, alpha=0.25)
        ax.set_xlabel(_condition_header(env_id))
        ax.set_ylabel(f"reference objective [{objectives.unit}]")
        ax.set_title(env_id.split("/")[-1])
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    save(fig, path)  # atomically, its folder created
