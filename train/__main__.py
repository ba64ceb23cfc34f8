"""``python -m train``: train PPO or SAC on a tandem-wing env (rl-baselines3-zoo's spelling),
or with ``--algo amortised`` one network from the condition to a stroke on the reference
optima (``train.amortised``, docs/training.md "Amortised policy"; its settings are
--hyperparams)::

    python -m train --algo sac --env TandemWing/LevelFlight-v0 --timesteps 100000 --seed 0
    python -m train --algo ppo --env TandemWing/LevelFlight-v0 --env-kwargs "speed_range=(0.25,2.0)"
    python -m train --algo sac --env TandemWing/LevelFlight-v0 --resume      # latest run
    python -m train --algo sac --env TandemWing/LevelFlight-v0 --run-dir logs/sac/TandemWing-LevelFlight-v0_3
    python -m train --algo amortised --env TandemWing/Accelerate-v0 --env-kwargs objective=horizontal
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from dataclasses import fields
from pathlib import Path
from typing import Any

from train.entry import exit_on_bad_environment

# importing tandem_env checks numba's environment: a bad setting is one line and status 2
with exit_on_bad_environment("python -m train"):
    from tandem_env.io.command import command_line
from tandem_env.envs.registration import config_class
from tandem_env.io.progress_bar import warnings_as_lines
from train.config import AMORTISED, TrainConfig
from train.entry import build_parser as build_fields_parser
from train.run_folder import Interrupted, RunComplete

EPILOG = """\
Values of --env-kwargs / --hyperparams are Python literals or YAML scalars: speed=1.5,
"speed_range=(0.25, 2.0)", thrust_split=body, learning_rate=lin_1e-3,
"policy_kwargs=dict(net_arch=[64, 64])". The zoo's key:value spelling works too.

A run writes logs/<algo>/<env>_<n>/ (the zoo's layout; see docs/training.md). A killed run
continues from its last checkpoint with --resume (the latest run of that algo and env) or
--run-dir DIR (that run); the step count continues and -n may raise the target. Only runs
written by python -m train are continued: a folder of rl_zoo3 (same layout) is left untouched.
Training stops at whole iterations (PPO: n_steps x n_envs env steps), so -n is rounded up to
one and the run says so.
"""


def build_parser() -> argparse.ArgumentParser:
    """The command line: one option per :class:`TrainConfig` field (:mod:`train.entry`; ``--resume``
    and ``--run-dir`` exclude each other), plus ``--insect``."""
    parser = build_fields_parser(
        TrainConfig,
        exclusive=("resume", "run_dir"),
        prog="tandem-train" if Path(sys.argv[0]).name == "tandem-train" else "python -m train",
        description="Train PPO or SAC (Stable-Baselines3) on a TandemWing env through the batched vector env.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    # Short for --env-kwargs insect=FILE (TrainConfig reads it into env_kwargs).
    parser.add_argument(
        "--insect",
        metavar="FILE",
        help="YAML file of the insect (what differs from the paper's specimen; docs/envs.md)",
    )
    return parser


def parse_config(parser: argparse.ArgumentParser, argv: Sequence[str] | None) -> TrainConfig:
    """The :class:`TrainConfig` of the command line ``argv`` (``--insect`` in its env options)."""
    args = parser.parse_args(argv)
    values = {spec.name: getattr(args, spec.name) for spec in fields(TrainConfig)}
    insect = getattr(args, "insect", None)
    if insect is not None:
        if args.algo == AMORTISED:
            raise ValueError(
                f"--insect {insect}: the reference table describes the paper's insects "
                "only; allowed with amortised: planform=tear-drop or planform=real"
            )
        if "insect" in values["env_kwargs"]:
            raise ValueError("give --insect FILE or --env-kwargs insect=..., not both")
        values["env_kwargs"]["insect"] = insect  # TrainConfig reads it (insect_keyword)
    return TrainConfig(**values)


@command_line
def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    result: Any
    try:
        config = parse_config(parser, argv)
        from train.amortised import train_run
        from train.run import train

        with warnings_as_lines():  # every input was checked before any training
            result = (train_run if config.algo == AMORTISED else train)(config)
    except RunComplete as done:
        print(done)
        return 0
    except (Interrupted, KeyboardInterrupt) as stop:
        # Ctrl-C: in training (Interrupted: a checkpoint was saved) or outside its steps
        said = "interrupted; a run continues from its last checkpoint"
        print(f"{parser.prog}: {stop if isinstance(stop, Interrupted) else said}", file=sys.stderr)
        return 130
    except ValueError as error:
        parser.error(str(error))
    except OSError as error:  # a disk that fills or a folder made read-only during the run
        print(f"{parser.prog}: error: {error}", file=sys.stderr)
        return 1
    print(f"run folder: {result.run_dir}")
    if config.algo == AMORTISED:
        summary = result.summary
        print(
            f"trained in {summary['wall_time']:.1f} s (regression "
            f"{summary['regression_seconds']:.1f} s, fine-tuning {summary['finetune_seconds']:.1f} "
            f"s, {summary['num_timesteps']} strokes evaluated)"
        )
        for branch in summary["branches"]:
            conditions = ", ".join(f"{c:g}" for c in branch["training_conditions"])
            print(
                f"  branch N={branch['N']} from {branch['serves_from']:g} to "
                f"{branch['serves_to']:g} (training conditions {conditions})"
            )
        for row in summary["training_evaluation"]:
            print(
                f"  at training condition {row['condition']:g}: objective {row['objective']:.4g} "
                f"(reference {row['reference']:.4g}), feasible {row['feasible']}"
            )
        return 0
    # The info key of the env's observed condition (speed, available_power, target_speed).
    condition_key = config_class(config.env_id).condition_key
    episodic = any(row["episode_length"] > 1 for row in result.final_evaluation)
    print(f"{result.num_timesteps} steps in {result.wall_time:.1f} s", end="")
    if episodic:
        # A step is one cycle of an episode: the best single step says nothing about the policy.
        print()
        for row in result.final_evaluation:
            print(
                f"  final deterministic policy, episode to {condition_key} "
                f"{row[condition_key]:g}: return {row['reward']:.4g} over "
                f"{row['episode_length']} cycles, ended at u = {row['forward_speed']:.3g} m/s, "
                f"h = {1e3 * row['altitude']:.3g} mm"
            )
        return 0
    best = result.best_info or {}
    since = "" if result.resumed_from is None else f" since step {result.resumed_from}"
    print(
        f"; best stroke seen{since}: reward {result.best_reward:.4g}, "
        f"objective {best.get('objective', float('nan')):.4g}, feasible {best.get('feasible')}"
    )
    for row in result.final_evaluation:
        # A task's info may leave its condition out (a model input such as a cruise speed).
        where = f" at {row[condition_key]:g}" if condition_key in row else ""
        print(
            f"  final deterministic policy{where}: reward {row['reward']:.4g}, "
            f"objective {row['objective']:.4g}, feasible {row['feasible']}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
