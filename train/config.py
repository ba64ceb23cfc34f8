"""Training configuration: the run config (:class:`TrainConfig`) and the hyperparameter files
(``train/hyperparams/<algo>.yml``, rl-baselines3-zoo's format: per env id, and ``default``, the
model's constructor arguments and the zoo's keys :data:`ZOO_KEYS`), whose entry (with the
command line's overrides) :func:`resolve_hyperparams` preprocesses as the zoo does.
"""

from __future__ import annotations

import ast
import contextlib
import importlib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from itertools import pairwise
from pathlib import Path
from types import MappingProxyType
from typing import Any

import yaml

from tandem_env.envs.config import insect_keyword
from tandem_env.envs.declaration import refusal
from tandem_env.envs.registration import check_env_id
from tandem_env.io.datafile import BoundedLoader, parse_yaml
from tandem_env.io.files import output_directory, to_jsonable, write_text_atomic
from tandem_env.physics.checks import count, flag, is_integer, is_real
from tandem_env.physics.model import MAX_BATCH_STROKES
from train.entry import option

#: The Stable-Baselines3 algorithms (``python -m train``'s RL path, :class:`TrainConfig`).
ALGOS = ("ppo", "sac")
#: Every ``--algo`` of ``python -m train``: the RL algorithms and ``amortised``, one network
#: from the condition to a stroke trained on the reference optima (``train.amortised``).
AMORTISED = "amortised"
TRAINERS: tuple[str, ...] = (*ALGOS, AMORTISED)
DEVICES = ("cpu", "cuda", "auto")

HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"

#: Keys of a zoo entry that are not model constructor arguments.
ZOO_KEYS = ("n_envs", "n_timesteps", "policy", "policy_kwargs", "normalize", "env_kwargs")
#: Zoo keys this trainer does not implement; refused rather than silently ignored.
UNSUPPORTED_ZOO_KEYS = tuple(
    "env_wrapper vec_env_wrapper callback frame_stack monitor_kwargs replay_buffer_class "
    "replay_buffer_kwargs noise_type noise_std".split()
)
#: Constructor arguments the zoo turns from "lin_<x>" strings into linear schedules.
SCHEDULE_KEYS = ("learning_rate", "clip_range", "clip_range_vf")
#: Ranges of the numeric PPO / SAC hyperparameters that SB3 takes unchecked (``gamma = 2``
#: trains on a diverging return, ``n_epochs = 0`` fails after the first rollout): (integer?,
#: low, high). A string (SAC's ``ent_coef = "auto"``) and a schedule are left to SB3.
HYPERPARAM_RANGES: dict[str, tuple[bool, float, float]] = {
    **dict.fromkeys(("n_steps", "batch_size", "n_epochs", "buffer_size"), (True, 1, math.inf)),
    "learning_starts": (True, 0, math.inf),
    **dict.fromkeys(("gamma", "gae_lambda", "tau"), (False, 0.0, 1.0)),
    **dict.fromkeys(("ent_coef", "vf_coef", "max_grad_norm"), (False, 0.0, math.inf)),
}

# Modules whose classes (activations, optimisers) ``policy_kwargs`` may name, as the zoo spells them
_POLICY_KWARGS_MODULES = {
    **dict.fromkeys(("nn", "th.nn", "torch.nn"), "torch.nn"),
    **dict.fromkeys(("th.optim", "torch.optim"), "torch.optim"),
}
_POLICY_KWARGS_ALLOWED = (
    "allowed names: numbers, strings, True/False/None, lists, tuples, {...}, dict(key=...), "
    "list(...), tuple(...) and the classes nn.<Name>, th.nn.<Name>, torch.nn.<Name>, "
    "th.optim.<Name>, torch.optim.<Name> (e.g. nn.ReLU)"
)


# --- parsing ---------------------------------------------------------------------------------
def eval_policy_kwargs(text: str) -> dict[str, Any]:
    """The zoo's ``policy_kwargs`` string, e.g. ``"dict(net_arch=[64, 64], log_std_init=-1)"``,
    read from its syntax tree, nothing run (the zoo evaluates it): literals, ``dict``, ``list``,
    ``tuple`` and ``torch.nn`` / ``torch.optim`` classes (looked up)."""
    try:
        value = _policy_value(ast.parse(text, mode="eval").body, text)
    except (SyntaxError, RecursionError, MemoryError) as error:
        raise ValueError(
            f"policy_kwargs = {text[:200]!r} is not a Python expression this reader takes: "
            f"{type(error).__name__}"
        ) from None
    if not isinstance(value, dict):
        raise ValueError(f"policy_kwargs = {text!r} gives {type(value).__name__}; allowed: a dict")
    return value


def _policy_value(node: ast.expr, text: str) -> Any:
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
        operand = _policy_value(node.operand, text)
        if isinstance(operand, int | float) and not isinstance(operand, bool):
            return -operand if isinstance(node.op, ast.USub) else operand
    elif isinstance(node, ast.List | ast.Tuple):
        items = [_policy_value(item, text) for item in node.elts]
        return items if isinstance(node, ast.List) else tuple(items)
    elif isinstance(node, ast.Dict) and None not in node.keys:
        return {
            _policy_value(k, text): _policy_value(v, text)  # type: ignore[arg-type]
            for k, v in zip(node.keys, node.values, strict=True)
        }
    elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
        name, args, keywords = node.func.id, node.args, node.keywords
        if name == "dict" and not args and all(k.arg is not None for k in keywords):
            return {k.arg: _policy_value(k.value, text) for k in keywords}
        if name in ("list", "tuple") and len(args) <= 1 and not keywords:
            items = _policy_value(args[0], text) if args else []
            if isinstance(items, list | tuple):
                return list(items) if name == "list" else tuple(items)
    elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Load):
        # a chain of plain names unparses as itself; anything else names no module here
        module = _POLICY_KWARGS_MODULES.get(ast.unparse(node.value))
        if module is not None:
            found = getattr(importlib.import_module(module), node.attr, None)
            if isinstance(found, type) and not node.attr.startswith("_"):
                return found
    raise ValueError(
        f"policy_kwargs = {text!r} uses {ast.unparse(node)!r}; {_POLICY_KWARGS_ALLOWED}"
    )


# --- hyperparameter files ----------------------------------------------------------------------
def load_hyperparams_file(path: str | Path) -> dict[str, dict[str, Any]]:
    """Every entry of a zoo hyperparameter file (env id -> settings)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"hyperparameter file {path} does not exist; allowed: a zoo-format .yml")
    try:
        data = parse_yaml(path.read_text(encoding="utf-8"), BoundedLoader)
    except (UnicodeDecodeError, yaml.YAMLError, RecursionError) as error:
        # a safe loader: a Python tag (the zoo's files have none) is refused, not built
        what = (
            f"is not UTF-8 text (byte {error.start})"
            if isinstance(error, UnicodeDecodeError)
            else f"is not plain YAML ({' '.join(str(error).split())})"
        )
        raise ValueError(f"hyperparameter file {path} {what}; allowed: a zoo-format .yml") from None
    if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
        raise ValueError(f"{path}: expected a mapping of env id -> mapping of hyperparameters")
    return data


def load_entry(algo: str, env_id: str, path: str | Path | None = None) -> dict[str, Any]:
    """The entry for ``env_id`` (else ``default``) of ``algo``'s hyperparameter file (``path``,
    default ``train/hyperparams/<algo>.yml``; ``algo`` checked by the caller), as the zoo."""
    file = Path(path) if path is not None else HYPERPARAMS_DIR / f"{algo}.yml"
    entries = load_hyperparams_file(file)
    for key in (env_id, "default"):
        if key in entries:
            return dict(entries[key])
    raise ValueError(
        f"{file}: no entry for {env_id!r} and no 'default'; entries: {sorted(entries)}"
    )


@dataclass(frozen=True)
class Hyperparams:
    """One zoo entry after preprocessing (what the model and the envs are built from)."""

    algo: str
    """The algorithm of the entry's file (``ppo``, ``sac``)."""
    n_envs: int
    n_timesteps: int
    policy: str
    policy_kwargs: Mapping[str, Any]
    """Evaluated ``policy_kwargs`` (the constructor's)."""
    normalize: Mapping[str, Any] | None
    """``VecNormalize`` keyword arguments, or None for no normalisation."""
    env_kwargs: Mapping[str, Any]
    """Env options from the file (the command line's ``--env-kwargs`` override them)."""
    model_kwargs: Mapping[str, Any]
    """Every other constructor argument, schedules already built."""
    saved: Mapping[str, Any] = field(default_factory=dict)
    """The entry as given (after overrides), sorted: what ``config.yml`` stores."""


def resolve_hyperparams(
    entry: Mapping[str, Any],
    overrides: Mapping[str, Any] | None = None,
    *,
    algo: str,
    n_envs: int | None = None,
    n_timesteps: int | None = None,
) -> Hyperparams:
    """Preprocess ``algo``'s zoo entry as ``rl_zoo3.exp_manager`` does (schedules,
    policy_kwargs, normalize)."""
    given = {"n_envs": n_envs, "n_timesteps": n_timesteps}
    raw = {**entry, **(overrides or {}), **{k: v for k, v in given.items() if v is not None}}
    unsupported = sorted(set(raw) & set(UNSUPPORTED_ZOO_KEYS))
    if unsupported:
        raise ValueError(
            f"hyperparameters {unsupported} are zoo features this trainer does not implement; "
            "allowed: model constructor arguments and " + ", ".join(ZOO_KEYS)
        )
    params = dict(raw)
    envs = _positive_int(params.pop("n_envs", 1), "n_envs")
    if "n_timesteps" not in params:
        raise ValueError("hyperparameters have no n_timesteps; allowed: an integer >= 1")
    timesteps = _positive_int(params.pop("n_timesteps"), "n_timesteps")
    policy = params.pop("policy", "MlpPolicy")
    if not isinstance(policy, str):
        raise ValueError(f"policy = {policy!r}; allowed: a policy name such as 'MlpPolicy'")
    policy_kwargs = params.pop("policy_kwargs", None) or {}
    if isinstance(policy_kwargs, str):
        policy_kwargs = eval_policy_kwargs(policy_kwargs)
    if not isinstance(policy_kwargs, dict):
        raise refusal("policy_kwargs", policy_kwargs, "a dict or a 'dict(...)' string")
    arch = policy_kwargs.get("net_arch")
    if arch is not None and not _layer_sizes(arch):
        allowed = "a list of layer sizes >= 1, or a dict of such lists (pi, vf, qf)"
        raise refusal("net_arch", arch, allowed)
    if arch is not None and network_parameters(arch) > MAX_NETWORK_PARAMETERS:
        raise ValueError(
            f"net_arch = {arch!r} has at least {network_parameters(arch):,} weights; allowed: "
            f"networks of at most {MAX_NETWORK_PARAMETERS:,} (MAX_NETWORK_PARAMETERS)"
        )
    normalize = params.pop("normalize", None)
    if isinstance(normalize, str):
        normalize = eval_policy_kwargs(normalize)
    if normalize is True or isinstance(normalize, dict):
        normalize = {} if normalize is True else dict(normalize)
        # As the zoo: the reward normaliser discounts with the algorithm's gamma.
        if params.get("gamma") is not None:
            normalize.setdefault("gamma", params["gamma"])
    elif normalize is not False and normalize is not None:
        raise ValueError(
            f"normalize = {normalize!r}; allowed: false, true, or VecNormalize kwargs as a dict "
            "or a 'dict(norm_obs=..., norm_reward=...)' string"
        )
    env_kwargs = params.pop("env_kwargs", None) or {}
    if not isinstance(env_kwargs, dict):
        raise ValueError(f"env_kwargs = {env_kwargs!r}; allowed: a mapping of env options")
    for key, (integer, low, high) in HYPERPARAM_RANGES.items():
        value = params.get(key)
        if value is None or (isinstance(value, str) and key == "ent_coef"):
            continue
        if not (is_integer(value) if integer else is_real(value)) or not low <= value <= high:
            kind = "an integer" if integer else "a number"
            upper = "" if high == math.inf else f" to {high:g}"
            raise ValueError(f"{key} = {value!r}; allowed: {kind} from {low:g}{upper}")
    for key in set(SCHEDULE_KEYS) & set(params):
        params[key] = _schedule(key, params[key])
    if isinstance(params.get("train_freq"), list):
        params["train_freq"] = tuple(params["train_freq"])
    return Hyperparams(
        algo=algo,
        n_envs=envs,
        n_timesteps=timesteps,
        policy=policy,
        policy_kwargs=MappingProxyType(policy_kwargs),
        normalize=MappingProxyType(normalize) if isinstance(normalize, dict) else None,
        env_kwargs=MappingProxyType(dict(env_kwargs)),
        model_kwargs=MappingProxyType(params),
        saved=MappingProxyType({key: raw[key] for key in sorted(raw)}),
    )


#: The most weights and biases the networks of one ``net_arch`` may have [-]: 10⁸ is 0.4 GB of
#: float32, and the optimiser keeps two more copies (SAC also a target critic); the yml entries'
#: networks have about 10⁵. Counted from the layer sizes before anything is allocated
#: (:func:`network_parameters`), so a mistyped size is refused instead of an allocator error.
MAX_NETWORK_PARAMETERS = 10**8


def network_parameters(arch: Any) -> int:
    """A lower bound on the weights and biases of the networks of a valid ``net_arch`` [-]
    (each list of sizes from at least one input to at least one output)."""
    if isinstance(arch, Mapping):
        return sum(network_parameters(sizes) for sizes in arch.values())
    sizes = [1, *(int(n) for n in arch), 1]
    return sum((inputs + 1) * outputs for inputs, outputs in pairwise(sizes))


def _layer_sizes(arch: Any) -> bool:
    """Whether ``arch`` is an SB3 ``net_arch``: layer sizes >= 1 (a zero-width layer trains
    without an error and without any hidden unit), or a dict of them per network."""
    if isinstance(arch, Mapping):
        return all(_layer_sizes(v) for v in arch.values())
    return isinstance(arch, list | tuple) and all(is_integer(n) and n >= 1 for n in arch)


def _positive_int(value: Any, name: str) -> int:
    # YAML reads 1e5 as a float (the zoo writes !!float 1e5); accept integral floats.
    if not is_real(value) or not math.isfinite(value) or int(value) != value or value < 1:
        raise ValueError(f"{name} = {value!r}; allowed: an integer >= 1")
    most = {"n_envs": MAX_ENVS, "n_timesteps": MAX_TIMESTEPS}.get(name)
    if most is not None and value > most:
        raise ValueError(f"{name} = {value!r}; allowed: an integer from 1 to {most:,}")
    return int(value)


def _schedule(key: str, value: Any) -> Any:
    from stable_baselines3.common.utils import LinearSchedule

    if is_real(value):
        return float(value)
    kind, _, number = value.partition("_") if isinstance(value, str) else ("", "", "")
    with contextlib.suppress(ValueError):
        if kind == "lin" and math.isfinite(initial := float(number)):
            # The zoo's linear schedule: from `initial` at the start to 0 at the end.
            return LinearSchedule(initial, 0.0, 1.0)
    raise ValueError(f"{key} = {value!r}; allowed: a number or 'lin_<initial value>'")


def step_granularity(hp: Hyperparams) -> int:
    """Env steps one learn iteration takes (``learn`` never stops inside one)."""
    if hp.algo == "ppo":
        return int(hp.model_kwargs.get("n_steps", 2048)) * hp.n_envs
    train_freq = hp.model_kwargs.get("train_freq", 1)
    # Every episode is one step, so "episode" frequencies count the same vector steps.
    steps = train_freq[0] if isinstance(train_freq, tuple) else train_freq
    return int(steps) * hp.n_envs


def check_algo(algo: str) -> str:
    if algo not in ALGOS:
        raise ValueError(f"algo = {algo!r}; allowed: {', '.join(ALGOS)}")
    return algo


# --- the run configuration ---------------------------------------------------------------------
#: The most parallel envs of a run [-]: they are stepped by one model call of that many strokes
#: (``MAX_BATCH_STROKES``); SB3 keeps per-env buffers besides.
MAX_ENVS = MAX_BATCH_STROKES
#: The most env steps of a run [-]: 10¹², far beyond any training run, and inside the int64
#: step counters of SB3 and numpy (2**63 wraps them).
MAX_TIMESTEPS = 10**12
#: The largest training seed: SB3 seeds numpy's legacy generator, which takes 32 bits.
MAX_SEED = 2**32 - 1


def _frequency(value: Any, name: str) -> int:
    if not is_integer(value):
        raise ValueError(f"{name} = {value!r}; allowed: an integer (<= 0 disables)")
    return int(value)


def _verbosity(value: Any, name: str) -> int:
    if count(value, name, 0) > 2:
        raise ValueError(f"{name} = {int(value)}; allowed: 0 quiet, 1 info, 2 debug")
    return int(value)


def check_seed(value: Any, name: str = "seed") -> int:
    """``value`` as a training seed [-]; ValueError naming ``name`` unless it is an integer from 0
    to :data:`MAX_SEED`."""
    if not is_integer(value) or not 0 <= value <= MAX_SEED:
        raise ValueError(f"{name} = {value!r}; allowed: an integer from 0 to 2**32 - 1")
    return int(value)


@dataclass(frozen=True, kw_only=True)
class TrainConfig:
    """Everything one training run is made from: each field an option of ``python -m train``,
    its docstring the help. ``n_envs``, ``n_timesteps`` None take the yml's values;
    ``hyperparams`` and ``env_kwargs`` override its entry key by key."""

    algo: str = option("--algo", choices=TRAINERS, amortised=True)
    """RL algorithm, or amortised (a network from condition to stroke)."""
    env_id: str = option("--env", metavar="ENV", amortised=True)
    """Env id, e.g. TandemWing/LevelFlight-v0."""
    n_timesteps: int | None = option(
        "-n", "--n-timesteps", "--timesteps", default=None, check=_positive_int
    )
    """Total env steps (strokes evaluated); default the yml's n_timesteps."""
    seed: int = option("--seed", default=0, amortised=True, check=check_seed)
    """Seed of the model and envs."""
    n_envs: int | None = option("--n-envs", default=None, check=_positive_int)
    """Parallel envs; default the yml's."""
    env_kwargs: Mapping[str, Any] = option("--env-kwargs", factory=dict, amortised=True)
    """Env options."""
    hyperparams: Mapping[str, Any] = option(
        "-params", "--hyperparams", factory=dict, amortised=True
    )
    """Override hyperparameters of the yml entry (amortised: its settings,
    train.amortised_policy.Settings)."""
    hyperparams_file: Path | None = option(
        "-conf", "--conf-file", default=None, metavar="CONF_FILE"
    )
    """Zoo-format hyperparameter file (default train/hyperparams/<algo>.yml)."""
    log_folder: Path = option(
        "-f", "--log-folder", "--log-dir", default=Path("logs"), amortised=True
    )
    """Log folder; runs go to <folder>/<algo>/<env>_<n>/ (the zoo's layout)."""
    resume: bool = option("--resume", default=False)
    """Continue the latest run of this algo and env from its last checkpoint."""
    run_dir: Path | None = option("--run-dir", default=None, amortised=True)
    """Use this run folder; a checkpoint there is resumed automatically."""
    eval_freq: int = option("--eval-freq", default=10_000, check=_frequency)
    """Env steps between deterministic evaluations (<= 0: none)."""
    save_freq: int = option("--save-freq", default=20_000, check=_frequency)
    """Env steps between checkpoints (<= 0: none, and no resume)."""
    log_interval: int | None = option("--log-interval", default=None, check=count)
    """SB3's log_interval; default one that dumps every few thousand steps (SAC counts it in
    episodes, and every env step ends n_envs of them)."""
    log_table: bool = option("--log-table", default=False, check=flag)
    """Print SB3's statistics table at every log dump (default: off, the progress bar and the
    final lines only; TensorBoard gets the same numbers)."""
    progress_bar: bool = option(
        "-P", "--progress", default=True, off="--no-progress", amortised=True
    )
    """A progress bar (on by default)."""
    tensorboard: bool = option(default=True, off="--no-tensorboard")
    """TensorBoard logs in <run>/tb/ (on by default)."""
    verbose: int = option("--verbose", default=1, amortised=True, check=_verbosity)
    """0 quiet, 1 info, 2 debug."""
    torch_threads: int = option("--torch-threads", default=1, check=count)
    """Torch threads: faster on 2 cores, where torch's second thread fights the model's numba
    threads and small-MLP updates get up to 10x slower (docs/training.md)."""
    device: str = option("--device", default="cpu", choices=DEVICES)
    """Torch device of the model."""

    def __post_init__(self) -> None:
        check_env_id(self.env_id, "env")
        for spec in fields(self):  # the fields' choices, and their checks (given, not None)
            value, allowed = getattr(self, spec.name), spec.metadata.get("choices")
            if allowed and value not in allowed:
                raise ValueError(f"{spec.name} = {value!r}; allowed: {', '.join(allowed)}")
            check = spec.metadata.get("check")
            if check is not None and value is not None:
                object.__setattr__(self, spec.name, check(value, spec.name))
        for name in ("env_kwargs", "hyperparams"):
            value = getattr(self, name)
            if not isinstance(value, Mapping):
                raise ValueError(f"{name} = {value!r}; allowed: a mapping of keyword -> value")
            value = dict(value)
            if name == "env_kwargs" and "insect" in value:
                # what differs from the paper's specimen, read now (a file, before any work)
                insect = insect_keyword(value.pop("insect"))
                if insect is not None:
                    value["insect"] = insect
            object.__setattr__(self, name, MappingProxyType(value))
        # a file, a dangling link or an empty name: said here, not as errno text when a run starts
        output_directory(self.log_folder, "log_folder (-f)", write=False)
        for name in ("log_folder", "run_dir", "hyperparams_file"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, Path(getattr(self, name)))
        if self.resume and self.run_dir is not None:
            raise ValueError(
                "give resume=True (the latest run in log_folder) or run_dir (that run), not both"
            )

        # an amortised run takes the options marked amortised only: any other one given (not
        # its default) is refused, naming its flag
        def flag(spec: Any) -> str:
            return next(f for f in (*spec.metadata["flags"], spec.metadata.get("off")) if "--" in f)

        given = [
            flag(f)
            for f in fields(self)
            if not f.metadata.get("amortised") and getattr(self, f.name) != f.default
        ]
        if self.algo == AMORTISED and given:
            allowed = [flag(f) for f in fields(self) if f.metadata.get("amortised")]
            raise ValueError(
                f"{', '.join(given)}: option(s) of ppo and sac, not of --algo amortised; allowed "
                f"with amortised: {', '.join(allowed)}"
            )

    def to_dict(self) -> dict[str, Any]:
        """Plain-YAML form (``args.yml``): every field (:func:`plain`), under its zoo name where
        it has one (:data:`ARGS_KEYS`), marked as written by this project (``made_by``)."""
        settings = {ARGS_KEYS.get(f.name, f.name): getattr(self, f.name) for f in fields(self)}
        return plain({"made_by": MADE_BY, **settings})


#: The ``made_by`` entry of ``args.yml`` that marks a run folder written by ``python -m train``.
MADE_BY = "tandem-env python -m train"
#: An env id as a folder name (``env_id.translate(FOLDER_NAME)``), as the zoo:
#: ``TandemWing/LevelFlight-v0`` -> ``TandemWing-LevelFlight-v0``.
FOLDER_NAME = str.maketrans("/", "-")
#: The ``args.yml`` keys of the :class:`TrainConfig` fields the zoo names otherwise.
ARGS_KEYS = {"env_id": "env", "hyperparams_file": "conf_file", "progress_bar": "progress"}


def plain(value: Any) -> Any:
    """YAML-safe form (config.yml, args.yml) by :func:`tandem_env.io.files.to_jsonable`;
    anything it cannot convert is kept, for ``yaml.safe_dump`` to accept or refuse."""
    return to_jsonable(value, default=lambda kept: kept)


def write_yaml(path: Path, data: Mapping[str, Any]) -> None:
    """Write a run folder's ``data`` (:func:`plain`) as YAML to ``path``, atomically."""
    try:
        text = yaml.safe_dump(plain(dict(data)), sort_keys=True)
    except yaml.representer.RepresenterError as error:
        raise ValueError(
            f"cannot write {path.name}: {error.args[-1]!r} is not a YAML value; allowed in "
            "env_kwargs / hyperparams of a run with files: numbers, strings, booleans, lists"
        ) from error
    write_text_atomic(path, text)
