"""``python -m train.tune``: tune PPO's or SAC's hyperparameters for a policy over an envelope.

Optuna's seeded TPE proposes overrides of the shipped zoo entry (the first trial) from
:data:`SEARCH_SPACES`; a trial trains one policy as ``python -m train`` does, valued by the
median normalised score of its strokes at the reference grid's *training* conditions
(docs/training.md, "Tuning for the envelope"). Needs the ``tune`` extra.
"""

from __future__ import annotations

import datetime
import hashlib
import json
import math
import platform
import shlex
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import yaml

from train.entry import command, exit_on_bad_environment, option

# importing tandem_env checks numba's environment: a bad setting is one line and status 2
with exit_on_bad_environment("python -m train.tune"):
    from tandem_env.io.command import command_line
from tandem_env.envs.reference import score_strokes, training_conditions
from tandem_env.envs.registration import check_env_id, condition_keywords
from tandem_env.io.files import output_directory, write_csv_atomic, write_text_atomic
from tandem_env.physics.checks import is_integer, is_real
from train.config import TrainConfig, check_seed, load_entry

#: Per algorithm and parameter: what Optuna proposes (kind, choices or (low, high): "log" and
#: "float" are ranges, "choice" a list) and the shipped entry's value (the first trial). Every
#: choice here is a value the shipped entry could hold (the shipped value is among them).
_SPACES: Mapping[str, Mapping[str, tuple[str, Any, Any]]] = {
    "ppo": {
        "learning_rate": ("log", (3e-4, 1e-2), 3e-3),
        "lr_schedule": ("choice", ("linear", "constant"), "linear"),
        "n_steps": ("choice", (2, 4, 8), 4),
        "batch_size": ("choice", (256, 512, 1024), 512),
        "n_epochs": ("choice", (5, 10, 20), 20),
        "clip_range": ("choice", (0.1, 0.2, 0.3), 0.2),
        "ent_coef": ("choice", (0.0, 1e-3, 1e-2), 0.0),
        "width": ("choice", (64, 128, 256), 64),
        "log_std_init": ("float", (-2.0, 0.0), -1.0),
    },
    "sac": {
        "learning_rate": ("log", (1e-4, 3e-3), 1e-3),
        "batch_size": ("choice", (128, 256, 512), 256),
        "gradient_steps": ("choice", (2, 4, 8), 8),
        "tau": ("choice", (0.005, 0.01, 0.02), 0.005),
        "buffer_size": ("choice", (20_000, 50_000, 100_000), 50_000),
        "learning_starts": ("choice", (1024, 4096), 1024),
        "width": ("choice", (64, 128, 256), 128),
    },
}
#: What Optuna proposes per algorithm: name -> (kind, choices or (low, high)).
SEARCH_SPACES: Mapping[str, Mapping[str, tuple[str, Any]]] = {
    algo: {name: (kind, values) for name, (kind, values, _) in space.items()}
    for algo, space in _SPACES.items()
}
#: The shipped entry (``train/hyperparams/<algo>.yml``, level flight) in the search space's
#: terms: the first trial (tests check it resolves to the shipped file's hyperparameters).
SHIPPED: Mapping[str, Mapping[str, Any]] = {
    algo: {name: shipped for name, (_, _, shipped) in space.items()}
    for algo, space in _SPACES.items()
}

#: Most trials and env steps per trial one command accepts.
MAX_TRIALS = 1000
MAX_STEPS = 10_000_000


def overrides(algo: str, params: Mapping[str, Any]) -> dict[str, Any]:
    """The ``--hyperparams`` overrides of a point of :data:`SEARCH_SPACES` (zoo terms: a
    ``lin_`` learning rate decays linearly to 0; ``policy_kwargs`` as the zoo's text)."""
    out = {k: v for k, v in params.items() if k not in ("lr_schedule", "width", "log_std_init")}
    width = int(params["width"])
    if algo == "ppo":
        rate = float(params["learning_rate"])
        out["learning_rate"] = f"lin_{rate:.6g}" if params["lr_schedule"] == "linear" else rate
        out["policy_kwargs"] = (
            f"dict(net_arch=dict(pi=[{width}, {width}], vf=[{width}, {width}]), "
            f"log_std_init={float(params['log_std_init']):.6g})"
        )
    else:
        out["policy_kwargs"] = f"dict(net_arch=[{width}, {width}])"
    return out


@dataclass(frozen=True)
class TuneConfig:
    """One tuning command (each field an option of ``python -m train.tune``, its docstring the
    option's help), checked once, when it is made (ValueError naming the value and what is
    allowed, before any training)."""

    algo: str = option("--algo", choices=tuple(SEARCH_SPACES))
    """The algorithm whose hyperparameters are tuned."""
    env_id: str = option("--env", cli_default="TandemWing/LevelFlight-v0")
    """Env id."""
    env_kwargs: Mapping[str, Any] = option("--env-kwargs", cli_default={})
    """Env options of every trial, e.g. 'speed_range=(0.25, 2.0)' (the whole envelope)."""
    trials: int = option("--trials")
    """Finished trials wanted."""
    steps: int = option("--steps")
    """Env steps per trial."""
    seed: int = option("--seed", cli_default=0)
    """Training and sampler seed."""
    out: Path = option("--out")
    """The study's folder."""

    @property
    def study_name(self) -> str:
        """The study's name in its journal: what the trials' values depend on."""
        options = hashlib.sha256(repr(sorted(self.env_kwargs.items())).encode()).hexdigest()[:8]
        return f"{self.algo}-{self.env_id}-{self.steps}-seed{self.seed}-env{options}"

    def command(self) -> str:
        """The command line that makes this study."""
        words = ["python", "-m", "train.tune"]
        for spec in fields(self):
            value = getattr(self, spec.name)
            if value != {}:
                words.append(spec.metadata["flags"][0])
                pairs = isinstance(value, Mapping)
                words += [f"{k}={v!r}" for k, v in value.items()] if pairs else [str(value)]
        return shlex.join(words)

    def __post_init__(self) -> None:
        from train.amortised import table_series

        if self.algo not in SEARCH_SPACES:
            raise ValueError(f"algo = {self.algo!r}; allowed: {', '.join(SEARCH_SPACES)}")
        check_env_id(self.env_id, "--env")
        # the trials are scored against the reference table: an env it does not describe
        # (n_time=64, another insect) would train a whole trial to a NaN score
        table_series(self.env_id, self.env_kwargs)
        for flag, value, high in (
            ("--trials", self.trials, MAX_TRIALS),
            ("--steps", self.steps, MAX_STEPS),
        ):
            if not is_integer(value) or not 1 <= value <= high:
                raise ValueError(f"{flag} {value!r}; allowed: an integer from 1 to {high:,}")
        check_seed(self.seed, "--seed")
        object.__setattr__(self, "out", Path(self.out))
        gym.make(self.env_id, disable_env_checker=True, **self.env_kwargs).close()  # its options


def _rows(study: Any) -> list[dict[str, Any]]:
    import optuna

    return [
        {
            "trial": trial.number,
            "median_score": round(float(trial.value), 3),
            "scores": " ".join(map(str, trial.user_attrs.get("scores", ()))),
            "seconds": trial.user_attrs.get("seconds"),
            **trial.params,
        }
        for trial in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))
    ]


def best_entry_text(config: TuneConfig, study: Any) -> str:
    """The best trial's zoo-format file: the shipped entry of ``config.env_id`` with the
    trial's overrides, and where it came from in comments."""
    import optuna

    best = study.best_trial
    entry = {**load_entry(config.algo, config.env_id), **overrides(config.algo, best.params)}
    env_kwargs = ", ".join(f"{k}={v!r}" for k, v in config.env_kwargs.items())
    finished = len(_rows(study))
    head = [
        f"# {config.algo.upper()} for {config.env_id} with {env_kwargs or 'its defaults'}, tuned by",
        f"#   {config.command()}",
        f"# Optuna {optuna.__version__} TPE over train.tune.SEARCH_SPACES; {finished} trials of "
        f"{config.steps:,} env steps, seed {config.seed}; the first is the shipped entry.",
        f"# Best: trial {best.number}, median score {best.value:.1f} at the training conditions "
        f"(scores {' '.join(map(str, best.user_attrs.get('scores', ())))}).",
        f"# Written {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC on "
        f"{platform.machine()}, Python {platform.python_version()}. Use: python -m train "
        f"--conf-file THIS_FILE ...",
    ]
    body = yaml.safe_dump({config.env_id: entry}, sort_keys=False, default_flow_style=False)
    return "\n".join(head) + "\n" + body


def _check_journal_lines(path: Path) -> None:
    """ValueError naming the journal unless every line is a JSON object with an integer
    ``op_code`` ending in a newline (Optuna would append to a line a kill cut short)."""
    if not path.exists():
        return
    try:
        *lines, cut = path.read_text(encoding="utf-8").split("\n")
        whole = all(
            isinstance(op := json.loads(line), dict) and type(op.get("op_code")) is int
            for line in lines
        )
    except (OSError, ValueError, RecursionError):  # not UTF-8 or not JSON (or nested too deep)
        whole = False
    if not whole or cut:
        why = (
            "its last line is cut short (a write a kill interrupted?): remove that line to "
            "continue the study"
            if whole
            else "a line is not one of its JSON operations: damaged or edited"
        )
        raise ValueError(
            f"{path}: not an Optuna journal as python -m train.tune writes it ({why}); it is "
            "left untouched. Allowed: that journal, or another --out"
        )


def foreign_trial(algo: str, n_conditions: int, trial: Any) -> str | None:
    """None if the finished ``trial`` is one this tuner recorded (parameters inside
    :data:`SEARCH_SPACES`, value the median of its ``n_conditions`` scores), else why not."""
    space = SEARCH_SPACES[algo]
    if set(trial.params) != set(space):
        return f"its parameters {sorted(trial.params)} are not the search space's"
    for name, (kind, values) in space.items():
        value = trial.params[name]
        ranged = is_real(value) and values[0] <= value <= values[1]
        if not (value in values if kind == "choice" else ranged):
            return f"{name} = {value!r} is outside the search space ({values})"
    scores = trial.user_attrs.get("scores")
    if not (
        is_real(trial.value)
        and math.isfinite(trial.value)
        and isinstance(scores, list)
        and len(scores) == n_conditions
        and all(is_real(x) and math.isfinite(x) for x in scores)
        and abs(statistics.median(scores) - trial.value) <= 0.005 + 1e-9
    ):
        return (
            f"its value {trial.value!r} is not the median of {n_conditions} finite scores it "
            f"recorded ({scores!r})"
        )
    return None


def open_study(config: TuneConfig) -> Any:
    """The Optuna study of ``config`` in ``config.out`` (made, or loaded to continue it);
    ValueError naming the folder or journal, before any training, for one it cannot continue."""
    import optuna

    output_directory(config.out, files=("study.journal", "trials.csv", f"{config.algo}.yml"))
    config.out.mkdir(parents=True, exist_ok=True)  # the journal is opened, not written whole
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    journal = config.out / "study.journal"
    _check_journal_lines(journal)
    name = config.study_name
    try:
        storage = optuna.storages.JournalStorage(
            optuna.storages.journal.JournalFileBackend(str(journal))
        )
        names = set(optuna.get_all_study_names(storage))
        trials = optuna.load_study(study_name=name, storage=storage).trials if name in names else []
    # what replaying a damaged journal raises (Optuna asserts on unknown operations, looks up
    # studies and trials by id)
    except (AssertionError, KeyError, IndexError, TypeError, ValueError, AttributeError) as error:
        raise ValueError(
            f"{journal}: its operations do not replay ({type(error).__name__}: damaged or "
            "edited); it is left untouched. Allowed: the journal python -m train.tune wrote, "
            "or another --out"
        ) from None
    if names - {name}:
        raise ValueError(
            f"--out {config.out} holds the study {sorted(names - {name})[0]!r} of other settings "
            "(algo, env, steps, seed or env options); allowed: those settings to continue it, "
            "or another --out"
        )
    n_conditions = len(training_conditions(config.env_id))
    for trial in (t for t in trials if t.state == optuna.trial.TrialState.COMPLETE):
        why = foreign_trial(config.algo, n_conditions, trial)
        if why is not None:
            raise ValueError(
                f"{journal}: trial {trial.number} is not one this tuner recorded: {why}; the "
                "journal is left untouched. Allowed: the journal python -m train.tune wrote, or "
                "another --out"
            )
    # seeded by the trials already run too: a resumed study must not propose its first
    # random trials again
    sampler = optuna.samplers.TPESampler(
        seed=(config.seed + len(trials)) % 2**32, n_startup_trials=5
    )
    study = optuna.create_study(
        study_name=name, storage=storage, sampler=sampler, direction="maximize", load_if_exists=True
    )
    if not trials:  # a new study (or one without trials) starts from the shipped entry
        study.enqueue_trial(dict(SHIPPED[config.algo]))
    return study


def run_trial(config: TuneConfig, params: Mapping[str, Any], folder: Path) -> dict[str, Any]:
    """Train one policy with ``params`` into ``folder`` and score it at the training
    conditions: ``{"value": median score, "scores": [...], "seconds": ...}``."""
    from train.amortised import make_problem
    from train.run import train
    from train.trained_policy import TrainedPolicy

    start = time.perf_counter()
    result = train(
        TrainConfig(
            algo=config.algo,  # type: ignore[arg-type]
            env_id=config.env_id,
            n_timesteps=config.steps,
            seed=config.seed,
            env_kwargs=dict(config.env_kwargs),
            hyperparams=overrides(config.algo, params),
            log_folder=folder,
            progress_bar=False,
            tensorboard=False,
            verbose=0,
        )
    )
    assert result.run_dir is not None  # a run with files
    # the normalised scores of its deterministic strokes, flown by its env (the training
    # options but the condition)
    policy = TrainedPolicy.load(result.run_dir, "best")
    env_kwargs = {k: v for k, v in policy.env_kwargs.items() if k not in condition_keywords()}
    conditions = np.asarray(training_conditions(config.env_id), dtype=np.float64)
    problem = make_problem(policy.env_id, env_kwargs)
    scores = score_strokes(problem, policy.strokes(conditions), conditions)
    return {
        "value": float(statistics.median(scores.tolist())),
        "scores": [round(float(s), 2) for s in scores],
        "seconds": round(time.perf_counter() - start, 1),
    }


def tune(config: TuneConfig, say: Callable[[str], None] = print, study: Any = None) -> Any:
    """Run the study of ``config`` (:func:`open_study`, unless given) up to ``config.trials``
    finished trials (module docstring); returns the Optuna study."""
    study = open_study(config) if study is None else study

    def objective(trial: Any) -> float:
        """Train one policy with the trial's parameters into a temporary folder
        (:func:`run_trial`): the median score (the scores and seconds: user attrs)."""
        params = {
            name: trial.suggest_categorical(name, list(values))
            if kind == "choice"
            else trial.suggest_float(name, *values, log=kind == "log")
            for name, (kind, values) in SEARCH_SPACES[config.algo].items()
        }
        with tempfile.TemporaryDirectory(prefix="tandem-tune-") as folder:
            found = run_trial(config, params, Path(folder))
        for key in ("scores", "seconds"):
            trial.set_user_attr(key, found[key])
        value, seconds = found["value"], found["seconds"]
        say(f"trial {trial.number}: median score {value:.1f} in {seconds:.0f} s ({params})")
        return value

    def write(study: Any, _trial: Any) -> None:
        write_csv_atomic(config.out / "trials.csv", _rows(study))
        write_text_atomic(config.out / f"{config.algo}.yml", best_entry_text(config, study))

    left = config.trials - len(_rows(study))
    say(
        f"tune {config.algo} on {config.env_id}: {left} of {config.trials} trials left, "
        f"{config.steps:,} env steps each -> {config.out}"
    )
    if left > 0:
        study.optimize(objective, n_trials=left, callbacks=[write])
    if _rows(study):
        write(study, None)
    return study


@command_line
def main(argv: Sequence[str] | None = None) -> int:
    with command(
        TuneConfig,
        argv,
        description=__doc__.split("\n\n")[0].split(": ", 1)[1],
        epilog="example: python -m train.tune --algo ppo --trials 12 --steps 100000 "
        "--env-kwargs 'speed_range=(0.25, 2.0)' --out results/tune-ppo",
    ) as config:
        try:
            study = open_study(config)  # imports Optuna first
        except ImportError:
            raise ValueError('needs Optuna: pip install -e ".[tune]"') from None
    start = time.perf_counter()
    study = tune(config, study=study)
    best = study.best_trial
    print(
        f"best: trial {best.number}, median score {best.value:.1f}; "
        f"{time.perf_counter() - start:.0f} s this run; wrote {config.out / (config.algo + '.yml')}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
