"""``python -m train``: train PPO or SAC on a tandem-wing env (rl-baselines3-zoo's spelling).

Examples::

    python -m train --algo sac --env TandemWing/LevelFlight-v0 --timesteps 100000 --seed 0
    python -m train --algo ppo --env TandemWing/LevelFlight-v0 --env-kwargs "speed_range=(0.25,2.0)"
    python -m train --algo sac --env TandemWing/LevelFlight-v0 --resume      # latest run
    python -m train --algo sac --env TandemWing/LevelFlight-v0 --run-dir logs/sac/TandemWing-LevelFlight-v0_3
    python -m train --algo amortised --env TandemWing/Accelerate-v0 --env-kwargs objective=horizontal

``--algo amortised`` trains one network from the condition to a stroke on the reference optima
(``train.amortised``, docs/training.md "Amortised policy"); its settings are --hyperparams.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping, Sequence
from dataclasses import MISSING, fields
from pathlib import Path
from typing import Any

from train.entry import exit_on_bad_environment

# importing tandem_env checks numba's environment: a bad setting is one line and status 2
with exit_on_bad_environment("python -m train"):
    from tandem_env.io.command import command_line
from tandem_env.io.keyvalue import parse_pairs
from tandem_env.io.progress_bar import warnings_as_lines
from train.config import AMORTISED, DEVICES, TRAINERS, TrainConfig
from train.layout import Interrupted, RunComplete

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


Option = tuple[str, tuple[str, ...], dict[str, Any]]


def _option(field: str, *flags: str, **settings: Any) -> Option:
    """One option: the :class:`TrainConfig` field it sets, its flags, its argparse settings."""
    return field, flags, settings


#: The command line, in ``-h`` order. Each option's default is its field's in
#: :class:`TrainConfig` (a help text shows it as ``%(default)s``).
OPTIONS: tuple[Option, ...] = (
    _option("algo", "--algo", required=True, choices=TRAINERS,
            help="RL algorithm, or amortised (a network from condition to stroke)"),
    _option("env_id", "--env", required=True, metavar="ENV",
            help="env id, e.g. TandemWing/LevelFlight-v0"),
    _option("n_timesteps", "-n", "--n-timesteps", "--timesteps", type=int,
            help="total env steps (strokes evaluated); default the yml's n_timesteps"),
    _option("seed", "--seed", type=int, help="seed of the model and envs (default %(default)s)"),
    _option("n_envs", "--n-envs", type=int, help="parallel envs; default the yml's"),
    _option("env_kwargs", "--env-kwargs", nargs="+", metavar="KEY=VALUE", help="env options"),
    _option("hyperparams", "-params", "--hyperparams", nargs="+", metavar="KEY=VALUE",
            help="override hyperparameters of the yml entry"),
    _option("hyperparams_file", "-conf", "--conf-file", metavar="CONF_FILE",
            help="zoo-format hyperparameter file (default train/hyperparams/<algo>.yml)"),
    _option("log_folder", "-f", "--log-folder", "--log-dir",
            help="log folder; runs go to <folder>/<algo>/<env>_<n>/ (default %(default)s)"),
    _option("resume", "--resume", action="store_true",
            help="continue the latest run of this algo and env from its last checkpoint"),
    _option("run_dir", "--run-dir",
            help="use this run folder; a checkpoint there is resumed automatically"),
    _option("eval_freq", "--eval-freq", type=int,
            help="env steps between deterministic evaluations (<= 0: none; default %(default)s)"),
    _option("save_freq", "--save-freq", type=int,
            help="env steps between checkpoints (<= 0: none, no resume; default %(default)s)"),
    _option("log_interval", "--log-interval", type=int, help="SB3 log_interval"),
    _option("log_table", "--log-table", action="store_true",
            help="print SB3's statistics table at every log dump (default: off, the progress "
            "bar and the final lines only; TensorBoard gets the same numbers)"),
    _option("progress_bar", "--no-progress", action="store_false", help="hide the progress bar"),
    _option("progress_bar", "-P", "--progress", action="store_true",
            help="show a progress bar (default)"),
    _option("tensorboard", "--no-tensorboard", action="store_false",
            help="do not write TensorBoard logs (default: <run>/tb/)"),
    _option("verbose", "--verbose", type=int, help="0 quiet, 1 info (default), 2 debug"),
    _option("torch_threads", "--torch-threads", type=int,
            help="torch threads (default %(default)s: faster on 2 cores, see docs/training.md)"),
    _option("device", "--device", choices=DEVICES),
)  # fmt: skip

#: Options that exclude each other: the latest run, or a given one.
EXCLUSIVE = ("resume", "run_dir")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="tandem-train" if Path(sys.argv[0]).name == "tandem-train" else "python -m train",
        description="Train PPO or SAC (Stable-Baselines3) on a TandemWing env through the batched vector env.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    defaults = {f.name: f.default for f in fields(TrainConfig) if f.default is not MISSING}
    exclusive = parser.add_mutually_exclusive_group()
    for name, flags, settings in OPTIONS:
        group = exclusive if name in EXCLUSIVE else parser
        group.add_argument(*flags, dest=name, default=defaults.get(name), **settings)
    # Short for --env-kwargs insect=FILE (TrainConfig reads it into env_kwargs).
    parser.add_argument(
        "--insect",
        metavar="FILE",
        help="YAML file of the insect (what differs from the paper's specimen; docs/envs.md)",
    )
    return parser


def config_from_args(args: argparse.Namespace) -> TrainConfig:
    import tandem_env  # noqa: F401 - registers the ids before the config checks the env

    values = {name: getattr(args, name) for name, _, _ in OPTIONS}
    for name in ("env_kwargs", "hyperparams"):
        values[name] = parse_pairs(values[name], f"--{name.replace('_', '-')}")
    insect = getattr(args, "insect", None)
    if insect is not None:
        if "insect" in values["env_kwargs"]:
            raise ValueError("give --insect FILE or --env-kwargs insect=..., not both")
        values["env_kwargs"]["insect"] = insect  # TrainConfig reads it (insect_keyword)
    return TrainConfig(**values)


@command_line
def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    result: Any
    try:
        if args.algo == AMORTISED:
            result = _train_amortised(parser, args)
        else:
            config = config_from_args(args)
            from train.run import train

            with warnings_as_lines():
                result = train(config)
    except Interrupted as stop:  # Ctrl-C in training: a checkpoint was saved
        print(f"{parser.prog}: {stop}", file=sys.stderr)
        return 130
    except RunComplete as done:
        print(done)
        return 0
    except KeyboardInterrupt:  # outside the training steps (those stop with Interrupted)
        print(
            f"{parser.prog}: interrupted; a run continues from its last checkpoint", file=sys.stderr
        )
        return 130
    except ValueError as error:
        parser.error(str(error))
    except OSError as error:  # a disk that fills or a folder made read-only during the run
        print(f"{parser.prog}: error: {error}", file=sys.stderr)
        return 1
    print(f"run folder: {result.run_dir}")
    if args.algo == AMORTISED:
        return _say_amortised(result.summary)
    from tandem_env.envs.registration import config_class

    # The info key of the env's observed condition (speed, available_power, target_speed).
    condition_key = config_class(result.env_id).condition_key
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


#: Options of the RL path (:class:`TrainConfig`) an amortised run has no use for.
RL_ONLY = (
    ("n_timesteps", "-n"),
    ("n_envs", "--n-envs"),
    ("hyperparams_file", "--conf-file"),
    ("resume", "--resume"),
    ("eval_freq", "--eval-freq"),
    ("save_freq", "--save-freq"),
    ("log_interval", "--log-interval"),
    ("log_table", "--log-table"),
    ("tensorboard", "--no-tensorboard"),
    ("torch_threads", "--torch-threads"),
    ("device", "--device"),
)


def _train_amortised(parser: argparse.ArgumentParser, args: argparse.Namespace) -> Any:
    """``--algo amortised``: every input checked before any computation, then
    :func:`train.amortised.train_run`."""
    given = [flag for name, flag in RL_ONLY if getattr(args, name) != parser.get_default(name)]
    if given:
        raise ValueError(
            f"{', '.join(given)}: option(s) of ppo and sac, not of --algo amortised; allowed "
            "with amortised: --env, --seed, --env-kwargs, --hyperparams (its settings, "
            "train.amortised.Settings), -f/--log-folder, --run-dir, --verbose"
        )
    if args.insect is not None:
        raise ValueError(
            f"--insect {args.insect}: the reference table describes the paper's insects "
            "only; allowed with amortised: planform=tear-drop or planform=real"
        )
    from tandem_env.envs.reference import REFERENCE_GRID
    from train.amortised import train_run

    if args.env_id not in REFERENCE_GRID:
        from tandem_env.envs.registration import check_env_id

        check_env_id(args.env_id, "--env")
    with warnings_as_lines():  # train_run checks the rest before it trains
        return train_run(
            args.env_id,
            parse_pairs(args.env_kwargs, "--env-kwargs"),
            parse_pairs(args.hyperparams, "--hyperparams"),
            args.seed,
            Path(args.log_folder),
            run_dir=None if args.run_dir is None else Path(args.run_dir),
            verbose=args.verbose,
        )


def _say_amortised(summary: Mapping[str, Any]) -> int:
    """What an amortised run ended with (stdout), after its run folder."""
    print(
        f"trained in {summary['wall_time']:.1f} s (regression {summary['regression_seconds']:.1f} "
        f"s, fine-tuning {summary['finetune_seconds']:.1f} s, {summary['num_timesteps']} strokes "
        "evaluated)"
    )
    for branch in summary["branches"]:
        print(
            f"  branch N={branch['N']} from {branch['serves_from']:g} to {branch['serves_to']:g} "
            f"(training conditions {', '.join(f'{c:g}' for c in branch['training_conditions'])})"
        )
    for row in summary["training_evaluation"]:
        print(
            f"  at training condition {row['condition']:g}: objective {row['objective']:.4g} "
            f"(reference {row['reference']:.4g}), feasible {row['feasible']}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
