"""SpeedChange's random and steady baselines (deterministic given the optima)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from eval import speed_change
from eval.numbers import framework
from tandem_env.envs.speed_change_config import SpeedChangeConfig

SPEED_CHANGE_EPISODES = 32
SPEED_CHANGE_COMMAND = f"python -m eval speed-change --episodes {SPEED_CHANGE_EPISODES}"
#: The optima's metrics the table shows: info keys of a level-flight step (docs/envs.md).
OPTIMUM_METRICS = ("efficiency", "power_per_mass", "lift_to_weight", "thrust", "drag")


def speed_change_optima(speeds: Sequence[float] | None = None) -> list[dict[str, Any]]:
    """The steady schedule's level-flight optima as ``eval speed-change`` makes them (its
    defaults: optimiser, budget, seed), one ``{speed, objective, feasible, ...}`` per speed,
    computed now (the record cache off: a cached optimum may come from another BLAS kernel)."""
    grid = speed_change.STEADY_GRID if speeds is None else speeds
    records = speed_change.optima_records(
        SpeedChangeConfig.from_kwargs(), speeds=grid, progress=False, cache=False
    )
    return [
        {
            "speed": r.job.condition,
            **{k: getattr(r, k) for k in ("method", "budget", "seed", "objective")},
            "feasible": bool(r.feasible),
            **{name: r.metrics[name] for name in OPTIMUM_METRICS},
            "normalised_stroke": list(r.normalised_stroke),
        }
        for r in sorted(records, key=lambda r: r.job.condition)
    ]


def speed_change_rows(optima: Sequence[dict[str, Any]], first_seed: int) -> list[dict[str, Any]]:
    """``policy_summary_rows`` of the random and steady policies over the evaluation episodes, the
    steady one playing ``optima``."""
    column = lambda key: np.array([o[key] for o in optima], dtype=np.float64)  # noqa: E731
    steady = speed_change.SteadyPolicy(column("speed"), column("normalised_stroke"))
    seeds = range(first_seed, first_seed + SPEED_CHANGE_EPISODES)
    episodes = [
        speed_change.episode_metrics(log)
        for policy in (speed_change.RandomPolicy(seed=0), steady)
        for log in speed_change.run_episodes(policy, list(seeds))
    ]
    return speed_change.policy_summary_rows(episodes)


def measure() -> dict[str, Any]:
    optima = speed_change_optima()
    return {
        "command": SPEED_CHANGE_COMMAND,
        "first_seed": speed_change.FIRST_SEED,
        "optima": optima,
        "rows": speed_change_rows(optima, speed_change.FIRST_SEED),
    }


def render(data: dict[str, Any]) -> str:
    optima = data["optima"]
    first = data["optima"][0]
    random = next(r for r in data["rows"] if r["policy"] == "random")
    by_kernel = [view["optima"] for view in framework.kernel_views(data).values()]
    lines = [
        speed_change.policy_summary_markdown(data["rows"]).rstrip("\n"),
        "",
        f"Random strokes end their episodes after {random['flight_time_mean_s']:.2f} s on "
        f"average. The steady schedule's level-flight optima ({first['method']}, "
        f"{framework.spaced(first['budget'])} evaluations, seed {first['seed']}; "
        f"{sum(o['feasible'] for o in optima)} of {len(optima)} level-feasible):",
        "",
        "| V [m/s] | η | P/m [W/kg] | L/W | T − D [mN] | feasible |",
        "|---|---|---|---|---|---|",
        *(
            f"| {o[0]['speed']:g} | {framework.agreed([k['efficiency'] for k in o], '{:.3f}')} | "
            f"{framework.agreed([k['power_per_mass'] for k in o], '{:.1f}')} | "
            f"{framework.agreed([k['lift_to_weight'] for k in o], '{:.3f}')} | "
            f"{framework.agreed([1e3 * (k['thrust'] - k['drag']) for k in o], '{:+.3f}')} | "
            f"{'yes' if all(k['feasible'] for k in o) else 'no'} |"
            for o in zip(*by_kernel, strict=True)
        ),
        "",
        framework.kernels_line(data),
        *framework.footer(data, "speed-change", data["command"]),
    ]
    return "\n".join(lines) + "\n"


MEASUREMENT = framework.Measurement("speed-change", measure, render, blas_dependent=True)
