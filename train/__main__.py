"""``python -m train``: train PPO or SAC on a tandem-wing env (rl-baselines3-zoo's spelling).

Examples::

    python -m train --algo sac --env TandemWing/LevelFlight-v0 --timesteps 100000 --seed 0
    python -m train --algo ppo --env TandemWing/LevelFlight-v0 --env-kwargs "speed_range=(0.25,2.0)"
    python -m train --algo sac --env TandemWing/LevelFlight-v0 --resume      # latest run
    python -m train --algo sac --env TandemWing/LevelFlight-v0 --run-dir logs/sac/TandemWing-LevelFlight-v0_3
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from agents.keyvalue import parse_pairs
from train.config import ALGOS, TrainConfig
from train.layout import RunComplete

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
    parser = argparse.ArgumentParser(
        prog="tandem-train" if Path(sys.argv[0]).name == "tandem-train" else "python -m train",
        description="Train PPO or SAC (Stable-Baselines3) on a TandemWing env through the batched vector env.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--algo", required=True, choices=ALGOS, help="RL algorithm")
    parser.add_argument("--env", required=True, help="env id, e.g. TandemWing/LevelFlight-v0")
    parser.add_argument(
        "-n",
        "--n-timesteps",
        "--timesteps",
        dest="n_timesteps",
        type=int,
        default=None,
        help="total env steps (strokes evaluated); default the yml's n_timesteps",
    )
    parser.add_argument(
        "--seed", type=int, default=0, help="seed of the model and envs (default 0)"
    )
    parser.add_argument("--n-envs", type=int, default=None, help="parallel envs; default the yml's")
    parser.add_argument(
        "--env-kwargs", nargs="+", metavar="KEY=VALUE", default=None, help="env options"
    )
    parser.add_argument(
        "-params",
        "--hyperparams",
        nargs="+",
        metavar="KEY=VALUE",
        default=None,
        help="override hyperparameters of the yml entry",
    )
    parser.add_argument(
        "-conf",
        "--conf-file",
        default=None,
        help="zoo-format hyperparameter file (default train/hyperparams/<algo>.yml)",
    )
    parser.add_argument(
        "-f",
        "--log-folder",
        "--log-dir",
        dest="log_folder",
        default="logs",
        help="log folder; runs go to <folder>/<algo>/<env>_<n>/ (default logs)",
    )
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--resume",
        action="store_true",
        help="continue the latest run of this algo and env from its last checkpoint",
    )
    where.add_argument(
        "--run-dir",
        default=None,
        help="use this run folder; a checkpoint there is resumed automatically",
    )
    parser.add_argument(
        "--eval-freq",
        type=int,
        default=10_000,
        help="env steps between deterministic evaluations (<= 0: none; default 10000)",
    )
    parser.add_argument(
        "--save-freq",
        type=int,
        default=20_000,
        help="env steps between checkpoints (<= 0: none, no resume; default 20000)",
    )
    parser.add_argument("--log-interval", type=int, default=None, help="SB3 log_interval")
    parser.add_argument(
        "--no-progress", dest="progress", action="store_false", help="hide the progress bar"
    )
    parser.add_argument(
        "-P",
        "--progress",
        dest="progress",
        action="store_true",
        default=True,
        help="show a progress bar (default)",
    )
    parser.add_argument(
        "--no-tensorboard",
        dest="tensorboard",
        action="store_false",
        help="do not write TensorBoard logs (default: <run>/tb/)",
    )
    parser.add_argument("--verbose", type=int, default=1, help="0 quiet, 1 info (default), 2 debug")
    parser.add_argument(
        "--torch-threads",
        type=int,
        default=1,
        help="torch threads (default 1: faster on 2 cores, see docs/training.md)",
    )
    parser.add_argument("--device", default="cpu", choices=("cpu", "cuda", "auto"))
    return parser


def config_from_args(args: argparse.Namespace) -> TrainConfig:
    import tandem_env  # noqa: F401 - registers the ids before the config checks the env

    return TrainConfig(
        algo=args.algo,
        env_id=args.env,
        n_timesteps=args.n_timesteps,
        seed=args.seed,
        n_envs=args.n_envs,
        env_kwargs=parse_pairs(args.env_kwargs, "--env-kwargs"),
        hyperparams=parse_pairs(args.hyperparams, "--hyperparams"),
        hyperparams_file=args.conf_file,
        log_folder=args.log_folder,
        run_dir=args.run_dir,
        resume=args.resume,
        eval_freq=args.eval_freq,
        save_freq=args.save_freq,
        progress_bar=args.progress,
        tensorboard=args.tensorboard,
        verbose=args.verbose,
        torch_threads=args.torch_threads,
        device=args.device,
        log_interval=args.log_interval,
    )


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        config = config_from_args(args)
        from train.run import train

        result = train(config)
    except RunComplete as done:
        print(done)
        return 0
    except ValueError as error:
        parser.error(str(error))
    best = result.best_info or {}
    print(f"run folder: {result.run_dir}")
    since = "" if result.resumed_from is None else f" since step {result.resumed_from}"
    print(
        f"{result.num_timesteps} steps in {result.wall_time:.1f} s; best stroke seen{since}: "
        f"reward {result.best_reward:.4g}, objective {best.get('objective', float('nan')):.4g}, "
        f"feasible {best.get('feasible')}"
    )
    for row in result.final_evaluation:
        condition = (
            row.get("speed") if "LevelFlight" in result.env_id else row.get("available_power")
        )
        print(
            f"  final deterministic policy at {condition:g}: reward {row['reward']:.4g}, "
            f"objective {row['objective']:.4g}, feasible {row['feasible']}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
