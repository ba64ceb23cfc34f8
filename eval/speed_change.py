"""``python -m eval speed-change``: policies flown through whole ``TandemWing/SpeedChange-v0``
episodes (:data:`DESCRIPTION`). Every :class:`Policy` flies the same episodes, the native vector
env reset with the fixed evaluation seeds, one batched model call per cycle for all of them.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

import tandem_env  # noqa: F401  (registers the ids)
from agents.records import Record
from tandem_env.envs.registration import SPEED_CHANGE_ID
from tandem_env.envs.speed_change import Flight
from tandem_env.envs.speed_change_config import LEVEL_FLIGHT_ENVELOPE, SpeedChangeConfig
from tandem_env.io.files import atomic_path, output_directory, write_csv_atomic, write_text_atomic
from tandem_env.physics.checks import shown
from tandem_env.physics.model import MAX_BATCH_STROKES

NAME = "speed-change"
HELP = "fly random, steady-optimum, PPO and SAC policies through SpeedChange-v0 episodes"
DESCRIPTION = """\
Fly every policy through the same TandemWing/SpeedChange-v0 episodes (fixed evaluation seeds:
sub-env i is reset with seed FIRST_SEED + i, so every policy gets the same start and target
speeds) and compare them. Policies: random strokes; the steady-optimum schedule (the
level-flight optimum at the grid speed nearest the target, from the harness, played every
cycle); and PPO / SAC runs of `python -m train` given by --ppo / --sac. Writes into --out:
  episodes.csv             one row per policy and episode (return, time to reach the target
                           within 5 %, energy per metre, mean |altitude error|, ...);
  summary.csv, summary.md  one row per policy: means over the episodes;
  optima/                  the record store of the level-flight optima (records/<key>.json,
                           reused when method, budget, seed and model options match).
--figure draws speed, altitude and power against time of one episode for every policy."""
EPILOG = """\
examples:
  python -m train --algo ppo --env TandemWing/SpeedChange-v0 -f logs --seed 0 -n 100000
  python -m train --algo ppo --env TandemWing/SpeedChange-v0 -f logs --seed 0
  python -m train --algo sac --env TandemWing/SpeedChange-v0 -f logs --seed 0
  python -m eval speed-change --episodes 32 --out results/speed-change \\
      --ppo logs/ppo/TandemWing-SpeedChange-v0_1 logs/ppo/TandemWing-SpeedChange-v0_2 \\
      --sac logs/sac/TandemWing-SpeedChange-v0_1 \\
      --figure results/speed-change/episode.png --figure-episode 5"""

#: Speeds [m/s] of the level-flight optima the steady schedule chooses from: the envelope in
#: steps of 0.25 m/s (the training sweep's grid).
STEADY_GRID: tuple[float, ...] = tuple(
    float(v) for v in np.arange(LEVEL_FLIGHT_ENVELOPE[0], LEVEL_FLIGHT_ENVELOPE[1] + 1e-9, 0.25)
)
#: The reward's parts, summed per episode: the ``info["reward_<term>"]`` terms and the penalty.
REWARD_PARTS: tuple[str, ...] = tuple("progress speed altitude energy termination penalty".split())
#: Relative speed error counted as "at the target" [-].
TARGET_WITHIN = 0.05
FIRST_SEED = 1000
"""Default first evaluation seed (training runs use small seeds)."""


class Policy(Protocol):
    """Chooses the next stroke of B episodes from their observations and states."""

    name: str

    def act(self, observations: np.ndarray, flight: Flight) -> np.ndarray:
        """(B, 28) normalised strokes in [-1, 1]."""
        ...


class RandomPolicy:
    """Uniform random strokes, a fresh one each cycle, from a seeded generator."""

    name = "random"

    def __init__(self, seed: int = 0) -> None:
        self._rng = np.random.default_rng(seed)

    def act(self, observations: np.ndarray, flight: Flight) -> np.ndarray:
        return self._rng.uniform(-1.0, 1.0, (observations.shape[0], 28))


@dataclass(frozen=True)
class SteadyPolicy:
    """The level-flight optimum at the grid speed nearest each episode's target, every cycle."""

    speeds: np.ndarray
    """(G,) grid speeds [m/s]."""
    actions: np.ndarray
    """(G, 28) normalised level-flight optimum at each grid speed."""
    name: str = "steady"

    def act(self, observations: np.ndarray, flight: Flight) -> np.ndarray:
        nearest = np.argmin(np.abs(flight.target_speed[:, None] - self.speeds[None, :]), axis=1)
        return self.actions[nearest]


@dataclass(frozen=True)
class SB3Policy:
    """A Stable-Baselines3 model's deterministic action (clipped to the action box)."""

    model: Any
    name: str

    @classmethod
    def load(cls, run_dir: str | os.PathLike[str], name: str, which: str = "final") -> SB3Policy:
        """The model of a ``python -m train`` run folder (``which``: "final" or "best")."""
        from train.trained_policy import TrainedPolicy

        policy = TrainedPolicy.load(run_dir, which)  # type: ignore[arg-type]
        if policy.algo != name:
            raise ValueError(
                f"--{name} {run_dir} is a {policy.algo.upper()} run; allowed: a "
                f"{name.upper()} run (or give it with --{policy.algo})"
            )
        if policy.env_id != SPEED_CHANGE_ID:
            msg = f"{run_dir} was trained on {policy.env_id}; allowed: a run on {SPEED_CHANGE_ID}"
            raise ValueError(msg)
        if policy.normalizer_path is not None:
            raise ValueError(
                f"{run_dir} normalised its observations (VecNormalize); allowed here: runs with "
                "normalize: false, as in train/hyperparams"
            )
        steps = int(policy.model.num_timesteps)
        return cls(policy.model, f"{name} ({steps / 1000:.0f}k steps)")

    def act(self, observations: np.ndarray, flight: Flight) -> np.ndarray:
        actions, _ = self.model.predict(observations, deterministic=True)
        return np.clip(actions, -1.0, 1.0)


#: The harness method of the level-flight optima (registered with the harness, as pso is).
DEFAULT_OPTIMISER = "cmaes"


def level_kwargs(config: SpeedChangeConfig) -> dict[str, Any]:
    """The level-flight env keywords of the SpeedChange env's insect and model options: only
    what differs from the defaults, so records stay readable and their keys stable."""
    from tandem_env import Dragonfly, ModelOptions
    from tandem_env.envs.config import MODEL_OPTION_KWARGS

    kwargs: dict[str, Any] = {}
    insect = config.insect
    if insect != Dragonfly():  # a planform's specimen as the planform, any other insect whole
        plain = insect.planform != "mixed" and insect == Dragonfly().with_planform(insect.planform)
        kwargs = {"planform": insect.planform} if plain else {"insect": insect}
    default = ModelOptions()
    for kwarg, name in MODEL_OPTION_KWARGS.items():
        if getattr(config.options, name) != getattr(default, name):
            kwargs[kwarg] = getattr(config.options, name)
    return kwargs


def optima_records(
    config: SpeedChangeConfig,
    *,
    speeds: Sequence[float] = STEADY_GRID,
    method: str = DEFAULT_OPTIMISER,
    budget: int = 12000,
    seed: int = 0,
    cache_dir: str | os.PathLike[str] | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    cache: bool = True,
    rerun: bool = False,
) -> list[Record]:
    """The records of the level-flight optima at ``speeds`` [m/s] for the env's insect and
    model options, in that order (one infeasible is said on stderr): a harness job each on the
    ``level`` task, run by :func:`agents.runner.run_jobs` into the record store ``cache_dir`` (a
    temporary one if None; ``cache``: ``--no-cache``, ``rerun``: ``--rerun``)."""
    import tempfile

    from agents.jobs import Job
    from agents.runner import run_jobs

    kwargs = level_kwargs(config)
    jobs = [Job(method, "level", float(v), budget, seed, env_kwargs=kwargs) for v in speeds]
    with tempfile.TemporaryDirectory() as scratch:
        where = scratch if cache_dir is None else cache_dir
        summary = run_jobs(
            jobs, where, scheduler=scheduler, progress=progress, cache=cache, rerun=rerun
        )
    records = [summary.records[job.key] for job in jobs]  # every job's: else run_jobs raises
    for speed, record in zip(speeds, records, strict=True):
        if not record.feasible:
            print(
                f"steady: the {method} optimum at {speed:g} m/s is not level-feasible "
                f"(budget {budget}); it is used anyway",
                file=sys.stderr,
            )
    return records


def steady_optima(config: SpeedChangeConfig, **run: Any) -> SteadyPolicy:
    """The steady schedule of the level-flight optima of :func:`optima_records` (``run``)."""
    records = optima_records(config, **run)
    speeds = np.array([r.job.condition for r in records], dtype=np.float64)
    return SteadyPolicy(speeds, np.array([r.normalised_stroke for r in records], dtype=np.float64))


#: The most evaluation episodes [-]: they are flown as one vector env, one model call of that
#: many strokes per cycle (``MAX_BATCH_STROKES``).
MAX_EPISODES = MAX_BATCH_STROKES


@dataclass(frozen=True)
class EpisodeLog:
    """One episode: the state after each cycle (the start state first) and what each cost."""

    policy: str
    seed: int
    target_speed: float
    time: np.ndarray
    """(K + 1,) [s], 0 first."""
    forward_speed: np.ndarray
    """(K + 1,) u [m/s]."""
    altitude: np.ndarray
    """(K + 1,) h [m]."""
    distance: np.ndarray
    """(K + 1,) [m]."""
    power_per_mass: np.ndarray
    """(K,) P/m of each cycle [W/kg]."""
    energy: np.ndarray
    """(K,) [J]."""
    reward: np.ndarray
    """(K,) [-]."""
    terminated: bool
    terms: Mapping[str, float] = field(default_factory=dict)
    """Each reward term summed over the episode (``progress``, ..., ``penalty``) [-]."""


def run_episodes(
    policy: Policy, seeds: Sequence[int], env_kwargs: Mapping[str, Any] | None = None
) -> list[EpisodeLog]:
    """Fly one episode per seed with ``policy``: sub-env i of the native vector env reset with
    ``seeds[i]``, one batched model call per cycle; each sub-env's first episode."""
    n = len(seeds)
    mode = "vector_entry_point"  # the native vector env: one model call for all sub-envs
    envs = gym.make_vec(SPEED_CHANGE_ID, num_envs=n, vectorization_mode=mode, **(env_kwargs or {}))
    states = ("time", "forward_speed", "altitude", "distance")  # the start state, then each cycle's
    try:
        observations, info = envs.reset(seed=[int(s) for s in seeds])
        history = {key: [np.asarray(info[key], np.float64)] for key in states}
        history |= {key: [] for key in ("power_per_mass", "energy", "reward")}  # each cycle's
        parts = {key: np.zeros(n) for key in REWARD_PARTS}
        targets = np.asarray(info["target_speed"], dtype=np.float64)
        running = np.ones(n, dtype=bool)
        terminated = np.zeros(n, dtype=bool)
        cycles_run = np.zeros(n, dtype=int)  # each episode's cycles: later steps are another's
        while running.any():
            actions = policy.act(observations, envs.unwrapped.flight)
            observations, rewards, term, trunc, info = envs.step(actions.astype(np.float32))
            info = {**info, "reward": rewards}
            cycles_run += running
            for key, values in history.items():
                values.append(np.asarray(info[key], np.float64))
            for key in REWARD_PARTS:  # the penalty is subtracted from the reward
                value = -info[key] if key == "penalty" else info[f"reward_{key}"]
                parts[key] += np.where(running, np.asarray(value, np.float64), 0.0)
            terminated |= running & term
            running &= ~(term | trunc)
    finally:
        envs.close()
    return [
        EpisodeLog(
            policy=policy.name,
            seed=int(seeds[i]),
            target_speed=float(targets[i]),
            **{k: np.array(v)[: cycles_run[i] + (k in states), i] for k, v in history.items()},
            terminated=bool(terminated[i]),
            terms={key: float(parts[key][i]) for key in REWARD_PARTS},
        )
        for i in range(n)
    ]


def episode_metrics(log: EpisodeLog) -> dict[str, Any]:
    """The comparison's numbers of one episode (units in the keys)."""
    error = np.abs(log.forward_speed - log.target_speed)
    within = np.flatnonzero(error <= TARGET_WITHIN * log.target_speed)
    distance = float(log.distance[-1])
    energy = float(log.energy.sum())
    return {
        "policy": log.policy,
        "seed": log.seed,
        "start_speed_m_s": float(log.forward_speed[0]),
        "target_speed_m_s": log.target_speed,
        "return": float(log.reward.sum()),
        "cycles": int(log.reward.size),
        "flight_time_s": float(log.time[-1]),
        "terminated": log.terminated,
        "time_to_target_s": float(log.time[within[0]]) if within.size else math.nan,
        "final_speed_error_m_s": float(error[-1]),
        "energy_J": energy,
        "distance_m": distance,
        "energy_per_metre_mJ_m": 1e3 * energy / distance if distance > 0 else math.nan,
        "mean_abs_altitude_mm": 1e3 * float(np.mean(np.abs(log.altitude[1:]))),
        "final_abs_altitude_mm": 1e3 * abs(float(log.altitude[-1])),
        "mean_power_W_kg": float(np.mean(log.power_per_mass)),
        **{f"return_{key}": float(value) for key, value in log.terms.items()},
    }


def policy_summary_rows(episodes: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One row per policy: means (and the return's standard deviation) over its episodes."""
    out = []
    for policy in dict.fromkeys(e["policy"] for e in episodes):
        rows = [e for e in episodes if e["policy"] == policy]
        values = {k: np.array([r[k] for r in rows], np.float64) for k in rows[0] if k != "policy"}
        reached, metre = (
            v[np.isfinite(v)] for v in (values["time_to_target_s"], values["energy_per_metre_mJ_m"])
        )
        mean = {key: float(v.mean()) for key, v in values.items()}
        row = {
            "policy": policy,
            "episodes": len(rows),
            "return_mean": mean["return"],
            "return_std": float(values["return"].std()),
            "terminated_share": mean["terminated"],
            "reached_share": reached.size / len(rows),
            "time_to_target_median_s": float(np.median(reached)) if reached.size else math.nan,
            "final_speed_error_mean_m_s": mean["final_speed_error_m_s"],
            "energy_per_metre_mean_mJ_m": float(metre.mean()) if metre.size else math.nan,
            "mean_abs_altitude_mean_mm": mean["mean_abs_altitude_mm"],
            "flight_time_mean_s": mean["flight_time_s"],
            "mean_power_W_kg": mean["mean_power_W_kg"],
            **{
                f"return_{key}_mean": mean[f"return_{key}"]
                for key in REWARD_PARTS
                if f"return_{key}" in mean
            },
        }
        out.append(row)
    return out


#: The docs table's columns: heading and the cell of a row of :func:`policy_summary_rows`.
SUMMARY_COLUMNS: tuple[tuple[str, str], ...] = (
    ("policy", "{policy}"),
    ("mean return (± std)", "{return_mean:.2f} (± {return_std:.2f})"),
    ("ended early", "{terminated_share:.0%}"),
    ("reached u* ± 5 %", "{reached_share:.0%}"),
    ("median time to reach [s]", "{time_to_target_median_s:.3f}"),
    ("final |u − u*| [m/s]", "{final_speed_error_mean_m_s:.3f}"),
    ("energy per metre [mJ/m]", "{energy_per_metre_mean_mJ_m:.2f}"),
    ("mean |h| [mm]", "{mean_abs_altitude_mean_mm:.1f}"),
    ("mean P/m [W/kg]", "{mean_power_W_kg:.1f}"),
)


def policy_summary_markdown(rows: Sequence[Mapping[str, Any]]) -> str:
    """The docs table of :func:`policy_summary_rows`."""
    from eval.studies.report import table_head, table_row

    heads, cells = zip(*SUMMARY_COLUMNS, strict=True)
    lines = [*table_head(heads), *(table_row(c.format(**r) for c in cells) for r in rows)]
    if all(f"return_{key}_mean" in r for r in rows for key in REWARD_PARTS):
        lines += ["", *table_head(("policy", *REWARD_PARTS))]
        lines += [
            table_row([r["policy"], *(f"{r[f'return_{key}_mean']:+.2f}" for key in REWARD_PARTS)])
            for r in rows
        ]
    return "\n".join(lines) + "\n"


def plot_episode(logs: Sequence[EpisodeLog], path: str | os.PathLike[str]) -> None:
    """Speed, altitude and power against time of one episode for each policy (PNG)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from eval.figures import DPI, LINE_HUES

    figure = Figure(figsize=(7.5, 6.5), dpi=DPI)
    FigureCanvasAgg(figure)
    axes = figure.subplots(3, 1, sharex=True)
    first = logs[0]
    target = first.target_speed
    axes[0].axhline(target, color="0.3", ls="--", lw=1.0, label="target u*")
    axes[0].axhspan(
        (1 - TARGET_WITHIN) * target, (1 + TARGET_WITHIN) * target, color="0.9", zorder=0
    )
    axes[0].set_prop_cycle(color=LINE_HUES)  # Okabe-Ito, one hue per policy
    for log in logs:
        (line,) = axes[0].plot(log.time, log.forward_speed, lw=1.5, label=log.policy)
        axes[1].plot(log.time, 1e3 * log.altitude, lw=1.5, color=line.get_color())
        axes[2].step(log.time[1:], log.power_per_mass, where="pre", lw=1.2, color=line.get_color())
        if log.terminated:
            axes[0].plot(log.time[-1], log.forward_speed[-1], "x", color=line.get_color())
            axes[1].plot(log.time[-1], 1e3 * log.altitude[-1], "x", color=line.get_color())
    axes[2].axhline(90.0, color="0.3", ls=":", lw=1.0, label="power cap 90 W/kg")
    labels = ("forward speed u [m/s]", "altitude error h [mm]", "P/m [W/kg]")
    for axis, label in zip(axes, labels, strict=True):
        axis.set_ylabel(label)
        axis.grid(True, color="0.92")
    axes[2].set_xlabel("time [s]")
    axes[0].legend(fontsize=8, ncol=3, loc="best")
    axes[2].legend(fontsize=8, loc="upper right")
    start = f"u0 = {first.forward_speed[0]:.2f} m/s -> u* = {target:.2f} m/s (x: ended early)"
    figure.suptitle(f"SpeedChange-v0, seed {first.seed}: {start}", fontsize=10)
    figure.tight_layout()
    with atomic_path(path) as tmp:  # a killed run never leaves half a figure
        figure.savefig(tmp)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    for flag, kind, default, text in (
        ("--episodes", int, 32, f"evaluation episodes (32; 1 to {MAX_EPISODES:,})"),
        ("--first-seed", int, FIRST_SEED, f"first evaluation seed ({FIRST_SEED})"),
        ("--optima-budget", int, 12000, "model evaluations per level-flight optimum (12000)"),
        ("--out", Path, Path("results/speed-change"), "output folder"),
        ("--figure", Path, None, "PNG of one episode for every policy"),
        ("--figure-episode", int, 0, "the evaluation episode the figure shows (index, default 0)"),
    ):
        parser.add_argument(flag, type=kind, default=default, help=text)
    text = f"harness method for the level-flight optima (default {DEFAULT_OPTIMISER})"
    parser.add_argument("--optimiser", default=DEFAULT_OPTIMISER, help=text)
    text = "speeds [m/s] of the level-flight optima (default 0.25 to 2.0 in steps of 0.25)"
    parser.add_argument(
        "--grid", type=float, nargs="+", default=list(STEADY_GRID), metavar="V", help=text
    )
    for algo in ("ppo", "sac"):
        text = f"python -m train {algo.upper()} run folders"
        parser.add_argument(f"--{algo}", nargs="+", default=[], metavar="RUN_DIR", help=text)
    text = "which saved model (final)"
    parser.add_argument("--model", choices=("final", "best"), default="final", help=text)
    from eval.optimize import add_run_arguments  # eval.optimize imports the studies: not here

    add_run_arguments(parser, "--scheduler", "--no-cache", "--rerun", "--quiet")


def _check_optima(args: argparse.Namespace, config: SpeedChangeConfig) -> None:
    """Validate --optimiser, --optima-budget and --grid before any optimisation."""
    from agents.harness import prepare

    if len(set(args.grid)) != len(args.grid):
        grid = " ".join(shown(v, *args.grid) for v in args.grid)
        raise ValueError(f"--grid {grid}: allowed: distinct speeds")
    kwargs = level_kwargs(config)
    for speed in args.grid:
        try:  # the harness's own checks: method, budget, speed within the level task's range
            prepare(args.optimiser, "level", speed, args.optima_budget, [0], env_kwargs=kwargs)
        except ValueError as error:
            raise ValueError(
                f"the level-flight optimum at --grid speed {shown(speed, *args.grid)} m/s "
                f"(--optimiser {args.optimiser}, --optima-budget {args.optima_budget}): {error}"
            ) from None


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from eval.optimize import run_options, run_reporting

    if not 1 <= args.episodes <= MAX_EPISODES:
        parser.error(f"--episodes {args.episodes}; allowed: 1 to {MAX_EPISODES:,}")
    if args.first_seed < 0:  # Gymnasium's seeds; found only after the optima otherwise
        parser.error(f"--first-seed {args.first_seed}; allowed: an integer >= 0")
    if not 0 <= args.figure_episode < args.episodes:
        parser.error(f"--figure-episode {args.figure_episode}; allowed: 0 to {args.episodes - 1}")
    try:
        output_directory(args.out, folders=("optima", "optima/records"))
        if (figure := args.figure) is not None:  # a Path (argparse's type)
            if figure.is_dir():
                raise ValueError(f"--figure {str(figure)!r} is a folder; allowed: a file name")
            from matplotlib.backend_bases import FigureCanvasBase

            formats = FigureCanvasBase.get_supported_filetypes()
            if figure.suffix[1:].lower() not in formats:
                raise ValueError(
                    f"--figure {str(figure)!r}: the format {figure.suffix or '(none)'!r} is not "
                    f"one matplotlib writes; allowed: a name ending in "
                    f"{', '.join('.' + f for f in sorted(formats))}"
                )
            output_directory(figure.parent, "--figure")
        config = SpeedChangeConfig.from_kwargs()
        _check_optima(args, config)
        trained = [(run_dir, name) for name in ("ppo", "sac") for run_dir in getattr(args, name)]
        policies: list[Any] = [RandomPolicy(seed=0)]
        policies += [SB3Policy.load(run_dir, name, args.model) for run_dir, name in trained]
    except (ValueError, NotImplementedError) as error:
        parser.error(str(error))
    run = dict(run_options(args), speeds=args.grid, budget=args.optima_budget)
    run.update(method=args.optimiser, cache_dir=args.out / "optima")
    steady = run_reporting(parser, lambda: steady_optima(config, **run))  # type: ignore[arg-type]
    if isinstance(steady, int):
        return steady
    policies.insert(1, steady)
    seeds = list(range(args.first_seed, args.first_seed + args.episodes))
    episodes, drawn = [], []
    for policy in policies:
        logs = run_episodes(policy, seeds)
        episodes.extend(episode_metrics(log) for log in logs)
        drawn.append(logs[args.figure_episode])
    rows = policy_summary_rows(episodes)
    write_csv_atomic(args.out / "episodes.csv", episodes)  # atomically, the folder created
    write_csv_atomic(args.out / "summary.csv", rows)
    table = policy_summary_markdown(rows)
    write_text_atomic(args.out / "summary.md", table)
    print(table)
    if args.figure is not None:
        plot_episode(drawn, args.figure)
        print(f"figure: {args.figure}", file=sys.stderr)
    return 0
