"""Where a run's files live: the rl-baselines3-zoo folder layout
(``logs/<algo>/<env>_<n>/``, each file listed in docs/training.md, "The run folder"), and
finding checkpoints. ``<env>`` is the env id with ``/`` replaced by ``-`` (the zoo's
``EnvironmentName``).

rl-baselines3-zoo writes the same layout into the same folders (``logs/<algo>/<env>_<n>/``,
``rl_model_<N>_steps.zip``, ``<env>/args.yml``), so a run of this project is recognised by the
``made_by`` entry of its ``args.yml`` (:data:`MADE_BY`); :meth:`RunLayout.foreign` says why a
folder is not one, and ``python -m train`` never resumes in, or writes into, such a folder.
"""

from __future__ import annotations

import math
import os
import pickle
import pickletools
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from tandem_env.io.datafile import BoundedLoader, parse_yaml
from tandem_env.io.files import FolderLock, read_json
from tandem_env.physics.checks import is_real

CHECKPOINT_PREFIX = "rl_model"
#: The ``made_by`` entry of ``args.yml`` that marks a run folder written by ``python -m train``.
MADE_BY = "tandem-env python -m train"
#: An ``args.yml`` key only this project writes (runs from before ``made_by`` have it; the
#: zoo calls its thread count ``num_threads``).
_LEGACY_KEY = "torch_threads"
_CHECKPOINT = re.compile(rf"^{CHECKPOINT_PREFIX}_(\d+)_steps\.zip$")
#: The lock file of a run folder: held (``flock``) by the ``python -m train`` writing there.
LOCK_FILE = ".train.lock"


# --- the pickled normalisation statistics ----------------------------------------------------
#: The globals a pickled ``VecNormalize`` (SB3's ``save``) refers to: the wrapper and its running
#: statistics, the spaces, numpy arrays and random generators. Nothing that runs code.
_NORMALIZER_GLOBALS = frozenset(
    {
        ("stable_baselines3.common.vec_env.vec_normalize", "VecNormalize"),
        ("stable_baselines3.common.running_mean_std", "RunningMeanStd"),
        ("gymnasium.spaces.box", "Box"),
        ("gymnasium.spaces.dict", "Dict"),
        ("gymnasium.spaces.discrete", "Discrete"),
        ("collections", "OrderedDict"),
        ("numpy", "dtype"),
        ("numpy", "ndarray"),
        ("numpy.core.multiarray", "_reconstruct"),
        ("numpy._core.multiarray", "_reconstruct"),
        ("numpy.core.multiarray", "scalar"),
        ("numpy._core.multiarray", "scalar"),
        ("numpy.random._pickle", "__generator_ctor"),
        ("numpy.random._pickle", "__bit_generator_ctor"),
        ("numpy.random._pcg64", "PCG64"),
        ("numpy.random.bit_generator", "SeedSequence"),
        ("numpy.random.bit_generator", "__pyx_unpickle_SeedSequence"),
    }
)


class _NormalizerUnpickler(pickle.Unpickler):
    """``pickle.Unpickler`` that builds only :data:`_NORMALIZER_GLOBALS` (the "restricting
    globals" recipe of the ``pickle`` documentation)."""

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) in _NORMALIZER_GLOBALS:
            return super().find_class(module, name)
        raise pickle.UnpicklingError(
            f"it names {module}.{name}, which a VecNormalize file does not"
        )


def read_normalizer(path: Path) -> Any:
    """The ``VecNormalize`` statistics SB3 saved at ``path``, unpickled with only the classes
    such a file holds (:data:`_NORMALIZER_GLOBALS`); ValueError naming the file otherwise. The
    caller attaches its env with the public ``set_venv`` (what ``VecNormalize.load`` does)."""
    try:
        with Path(path).open("rb") as stream:
            normalizer = _NormalizerUnpickler(stream).load()
    except (pickle.UnpicklingError, EOFError, ValueError, TypeError, AttributeError) as error:
        raise ValueError(
            f"{path}: refused: not a VecNormalize file of SB3 ({error}); nothing was run"
        ) from None
    except OSError as error:
        raise ValueError(f"{path} cannot be read ({error.strerror})") from None
    from stable_baselines3.common.vec_env import VecNormalize

    if not isinstance(normalizer, VecNormalize):
        raise ValueError(f"{path} holds a {type(normalizer).__name__}, not VecNormalize statistics")
    return normalizer


# --- the YAML of a run folder ---------------------------------------------------------------
class RunFileLoader(BoundedLoader):
    """YAML's safe loader, bounded in what a document may expand to (:class:`BoundedLoader`),
    plus the two Python tags rl_zoo3 writes (``yaml.dump`` of its
    ``OrderedDict`` of arguments and hyperparameters, and of tuples such as ``train_freq``):
    ``!!python/object/apply:collections.OrderedDict`` becomes a dict and ``!!python/tuple`` a
    tuple. Every other tag is refused (:class:`ForbiddenTag`) before anything is built."""


class ForbiddenTag(yaml.constructor.ConstructorError):
    """A YAML tag :class:`RunFileLoader` does not admit (``node.tag`` in :attr:`tag`)."""

    def __init__(self, node: yaml.Node) -> None:
        self.tag = node.tag
        super().__init__(None, None, f"the tag {node.tag!r} is not admitted", node.start_mark)


def _ordered_dict(loader: RunFileLoader, node: yaml.Node) -> dict[Any, Any]:
    # PyYAML writes an OrderedDict as a one-item sequence: the list of [key, value] pairs.
    arguments = (
        loader.construct_sequence(node, deep=True) if isinstance(node, yaml.SequenceNode) else None
    )
    if (
        not arguments
        or len(arguments) != 1
        or not all(isinstance(pair, list) and len(pair) == 2 for pair in arguments[0])
    ):
        raise ForbiddenTag(node)  # the tag, but not the zoo's form of it
    return {key: value for key, value in arguments[0]}


def _tuple(loader: RunFileLoader, node: yaml.Node) -> tuple[Any, ...]:
    if not isinstance(node, yaml.SequenceNode):
        raise ForbiddenTag(node)
    return tuple(loader.construct_sequence(node, deep=True))


def _refuse(loader: RunFileLoader, node: yaml.Node) -> None:
    raise ForbiddenTag(node)


RunFileLoader.add_constructor(
    "tag:yaml.org,2002:python/object/apply:collections.OrderedDict", _ordered_dict
)
RunFileLoader.add_constructor("tag:yaml.org,2002:python/tuple", _tuple)
RunFileLoader.add_constructor(None, _refuse)


def parse_run_yaml(text: str, path: Path) -> dict[str, Any]:
    """The mapping in a run folder's YAML ``text`` (of file ``path``), read with
    :class:`RunFileLoader`; ValueError naming the file for a refused tag, YAML that does not
    parse, or a document that is not a mapping."""
    try:
        data = parse_yaml(text, RunFileLoader)
    except ForbiddenTag as error:
        line = f" (line {error.problem_mark.line + 1})" if error.problem_mark else ""
        raise ValueError(
            f"{path}: refused: it holds the YAML tag {error.tag}{line}, which builds a Python "
            "object; allowed in a run folder's YAML: plain YAML values, !!python/tuple and "
            "rl_zoo3's !!python/object/apply:collections.OrderedDict. Nothing was loaded"
        ) from None
    except yaml.YAMLError as error:
        raise ValueError(f"{path} is not readable YAML ({error}); it is left untouched") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ValueError(
            f"{path} holds a YAML {type(data).__name__}, not a mapping of settings; it is left "
            "untouched. Allowed: the file python -m train wrote there"
        )
    return data


def read_run_yaml(path: Path) -> dict[str, Any]:
    """:func:`parse_run_yaml` of the file ``path``; ValueError naming it if it cannot be read."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ValueError(
            f"{path} is not UTF-8 text (a damaged file?); it is left untouched"
        ) from None
    except OSError as error:
        raise ValueError(f"{path} cannot be read ({error.strerror})") from None
    return parse_run_yaml(text, path)


def read_result_segments(path: Path) -> tuple[dict[str, Any], ...]:
    """The training segments of a run's ``result.json`` (each run of ``python -m train`` on the
    folder adds one), read before a resume trains: () where there is none; ValueError naming
    the file for one this project did not write as it is."""

    def readable(segment: Any) -> bool:
        return (
            isinstance(segment, dict)
            and is_real(segment.get("wall_time_s"))
            and "best_reward" in segment
            and (segment["best_reward"] is None or is_real(segment["best_reward"]))
            and isinstance(segment.get("best_info") or {}, dict)
        )

    if not path.is_file():
        return ()
    try:
        segments = read_json(path)["segments"]
        readable_file = isinstance(segments, list) and all(map(readable, segments))
    except (OSError, ValueError, KeyError, TypeError):
        readable_file = False
    if not readable_file:
        raise ValueError(
            f"{path}: not the run's result.json as python -m train writes it (its training "
            "segments cannot be read); it is left untouched. Allowed: that file, or none (move "
            "it away: the resumed run's summary then starts from its own segment)"
        )
    return tuple(segments)


def read_run_args(run_dir: Path, allowed: str) -> tuple[Path, dict[str, Any]]:
    """The one ``<env>/args.yml`` of ``run_dir`` and its settings; ValueError naming the folder
    and ``allowed`` (the folders the caller takes) if it holds none or several."""
    found = sorted(run_dir.glob("*/args.yml")) if run_dir.is_dir() else []
    if len(found) != 1:
        raise ValueError(
            f"{run_dir} is not a training run folder (expected one <env>/args.yml, found "
            f"{len(found)}); allowed: {allowed}"
        )
    return found[0], read_run_yaml(found[0])


def check_args_env(args_file: Path, env_id: Any) -> str:
    """The ``env`` of ``args_file``; ValueError unless it is the env its settings folder is
    named after."""
    if not isinstance(env_id, str) or env_name(env_id) != args_file.parent.name:
        raise ValueError(
            f"{args_file}: env = {env_id!r}, but the file sits in the settings folder of "
            f"{args_file.parent.name}; allowed: the env the run was trained on"
        )
    return env_id


class RunPolicy:
    """What every trained policy (:class:`train.trained_policy.TrainedPolicy`,
    :class:`train.amortised_policy.AmortisedPolicy`) answers about its run."""

    run_dir: Path | None
    env_id: str
    training_conditions: tuple[float, float] | float | None
    """The condition range it was trained on, or its fixed condition (None if unknown) [the
    condition's unit]."""

    def check_env(self, env_id: str) -> None:
        """ValueError unless the run was trained on ``env_id``."""
        if self.env_id != env_id:
            raise ValueError(
                f"{self.run_dir} was trained on {self.env_id}; this task's env is {env_id}; "
                "allowed: a run of the same env"
            )

    def trained_at(self, value: float) -> bool:
        """Whether ``value`` is a condition the policy saw in training (inside its range, or
        its fixed condition); True when the training condition is unknown."""
        seen = self.training_conditions
        if isinstance(seen, tuple):
            return seen[0] - 1e-9 <= value <= seen[1] + 1e-9
        return seen is None or math.isclose(seen, value)


def env_name(env_id: str) -> str:
    """The env id as a folder name: ``TandemWing/LevelFlight-v0`` -> ``TandemWing-LevelFlight-v0``."""
    return env_id.replace("/", "-")


def latest_run_id(algo_folder: Path, name: str) -> int:
    """Greatest ``n`` of the ``<name>_<n>`` folders in ``algo_folder`` (0 if none), as the zoo."""
    best = 0
    if algo_folder.is_dir():
        for path in algo_folder.iterdir():
            stem, _, number = path.name.rpartition("_")
            if path.is_dir() and stem == name and number.isdigit():
                best = max(best, int(number))
    return best


class RunComplete(Exception):
    """A resumed run has nothing left to train (its checkpoint is at or past the target);
    nothing was changed. ``python -m train`` prints the message and exits with status 0."""

    def __init__(self, run_dir: Path, step: int, target: int) -> None:
        self.run_dir, self.step, self.target = run_dir, step, target
        super().__init__(
            f"{run_dir} is complete: its last checkpoint is at {step} env steps and the target "
            f"is {target}; nothing was trained or changed. To train on, give a larger target "
            f"(-n N with N > {step})"
        )


class Interrupted(Exception):
    """Training stopped by Ctrl-C with a checkpoint saved
    (:class:`train.checkpoint.StopOnInterrupt`); ``python -m train`` prints the message and
    exits with status 130."""

    def __init__(self, checkpoint: Checkpoint, resume: str) -> None:
        self.checkpoint = checkpoint
        super().__init__(
            f"interrupted: checkpoint at step {checkpoint.step} saved as {checkpoint.model}; "
            f"continue with: {resume}"
        )


@dataclass(frozen=True)
class Checkpoint:
    """One checkpoint: the model after ``step`` env steps and its companions."""

    step: int
    model: Path
    replay_buffer: Path
    """SAC's replay buffer, arrays in an ``.npz`` (:func:`train.checkpoint.save_replay_buffer`)."""
    vecnormalize: Path
    legacy_replay_buffer: Path
    """The pickled buffer of earlier versions: never loaded (a pickle can run code)."""

    def complete(self, *, replay_buffer: bool, vecnormalize: bool) -> bool:
        """All files a faithful resume needs are there and intact (:meth:`damage`)."""
        return self.damage(replay_buffer=replay_buffer, vecnormalize=vecnormalize) is None

    def damage(self, *, replay_buffer: bool, vecnormalize: bool) -> str | None:
        """None if every file a resume needs is there and intact, else what is wrong, in words.

        Read without loading anything: the model and the replay buffer are zips whose every
        member's CRC must match (a truncated or altered file fails), and the VecNormalize file
        is a pickle whose opcodes must run to its STOP (``pickletools.genops``, which builds no
        object), so a file cut short by a kill or a full disk is found before it is loaded. A
        replay buffer only in the pickled format of earlier versions is not loaded: it says so.
        """
        needed = [(self.model, _MODEL_ZIP)]
        if replay_buffer:
            needed.append((self.replay_buffer, _BUFFER_ZIP))
        if vecnormalize:
            needed.append((self.vecnormalize, None))  # a pickle
        for path, zip_members in needed:
            if (
                path == self.replay_buffer
                and not path.exists()
                and self.legacy_replay_buffer.exists()
            ):
                return (
                    f"its replay buffer is {self.legacy_replay_buffer.name}, the pickled format "
                    "of earlier versions, which is never loaded (a pickle can run code)"
                )
            if not path.is_file():
                return f"{path.name} is missing"
            if path.stat().st_size == 0:
                return f"{path.name} is empty"
            if zip_members is None:
                problem = _pickle_damage(path)
            else:
                problem = _zip_damage(path, *zip_members)
            if problem is not None:
                return f"{path.name} is damaged ({problem})"
        return None

    def paths(self) -> tuple[Path, ...]:
        return (self.model, self.replay_buffer, self.vecnormalize, self.legacy_replay_buffer)


#: The members every SB3 model zip has (``save_to_zip_file``) and every replay buffer ``.npz``
#: (:data:`train.checkpoint.REPLAY_COUNTERS`), and what such a file is called.
_MODEL_ZIP = (frozenset({"data", "_stable_baselines3_version"}), "model file")
_BUFFER_ZIP = (frozenset({"pos.npy", "full.npy"}), "replay buffer file")


def _zip_damage(path: Path, members: frozenset[str], what: str) -> str | None:
    try:
        with zipfile.ZipFile(path) as archive:
            # The model's zip stores torch's own zips uncompressed, so a file cut short can end
            # in an inner archive's directory and read as that archive: its members tell.
            missing = members - set(archive.namelist())
            bad = None if missing else archive.testzip()
    except (zipfile.BadZipFile, OSError, EOFError, ValueError) as error:
        return f"not a complete zip file: {error}"
    if missing:
        return f"not a complete {what}: no {', '.join(sorted(missing))}"
    return None if bad is None else f"member {bad} fails its CRC check"


def _pickle_damage(path: Path) -> str | None:
    try:
        with path.open("rb") as stream:
            for opcode, _, _ in pickletools.genops(stream):
                if opcode.name == "STOP":
                    return None
    except (ValueError, EOFError, OSError) as error:
        return f"not a complete pickle: {error}"
    return "not a complete pickle: no STOP opcode"


@dataclass(frozen=True)
class RunLayout:
    """The files of one run folder."""

    run_dir: Path
    env_id: str

    @property
    def name(self) -> str:
        return env_name(self.env_id)

    @property
    def final_model(self) -> Path:
        return self.run_dir / f"{self.name}.zip"

    @property
    def best_model(self) -> Path:
        return self.run_dir / "best_model.zip"

    @property
    def best_vecnormalize(self) -> Path:
        """The VecNormalize statistics ``best_model.zip`` was evaluated with."""
        return self.run_dir / "best_model_vecnormalize.pkl"

    @property
    def evaluations(self) -> Path:
        return self.run_dir / "evaluations.npz"

    @property
    def params_dir(self) -> Path:
        return self.run_dir / self.name

    @property
    def config_file(self) -> Path:
        return self.params_dir / "config.yml"

    @property
    def args_file(self) -> Path:
        return self.params_dir / "args.yml"

    @property
    def vecnormalize(self) -> Path:
        return self.params_dir / "vecnormalize.pkl"

    @property
    def tensorboard(self) -> Path:
        return self.run_dir / "tb"

    @property
    def result_file(self) -> Path:
        return self.run_dir / "result.json"

    def monitor_files(self) -> list[Path]:
        return sorted(self.run_dir.glob("*.monitor.csv"))

    def next_monitor_file(self) -> Path:
        """A fresh Monitor file per training segment (VecMonitor truncates an existing one)."""
        return self.run_dir / f"{len(self.monitor_files())}.monitor.csv"

    def foreign(self) -> str | None:
        """None if this folder is a run of ``python -m train`` on this env, or is absent or
        empty (a new run may start there); otherwise why it is not, in words."""
        if not self.run_dir.exists():
            return None
        if not self.run_dir.is_dir():
            return f"{self.run_dir} is a file, not a run folder"
        if not self.args_file.is_file():
            if not any(p.name != LOCK_FILE for p in self.run_dir.iterdir()):
                return None
            others = sorted(p.parent.name for p in self.run_dir.glob("*/args.yml"))
            if others:
                return (
                    f"{self.run_dir} holds a run of {', '.join(others)} (its */args.yml), not of "
                    f"{self.env_id}"
                )
            return f"{self.run_dir} holds files but no {self.name}/args.yml: not a training run"
        try:
            text = self.args_file.read_text(encoding="utf-8")
            args = parse_run_yaml(text, self.args_file)
        except UnicodeDecodeError:
            return f"{self.args_file} is not UTF-8 text"
        except (OSError, ValueError) as error:
            return str(error)
        if args.get("made_by") == MADE_BY:
            return None
        if _LEGACY_KEY in args and "!!python" not in text:
            return None
        looks_like = ""
        if "!!python/object/apply:collections.OrderedDict" in text or "trained_agent" in args:
            looks_like = (
                " (it looks like an rl-baselines3-zoo run: rl_zoo3.train writes the same layout)"
            )
        return f"{self.run_dir} was not written by python -m train{looks_like}"

    def checkpoint(self, step: int) -> Checkpoint:
        base = self.run_dir / CHECKPOINT_PREFIX
        return Checkpoint(
            step=step,
            model=Path(f"{base}_{step}_steps.zip"),
            replay_buffer=Path(f"{base}_replay_buffer_{step}_steps.npz"),
            vecnormalize=Path(f"{base}_vecnormalize_{step}_steps.pkl"),
            legacy_replay_buffer=Path(f"{base}_replay_buffer_{step}_steps.pkl"),
        )

    def checkpoints(self) -> list[Checkpoint]:
        """Every checkpoint model in the folder, oldest first."""
        if not self.run_dir.is_dir():
            return []
        steps = sorted(
            int(m.group(1)) for p in self.run_dir.iterdir() if (m := _CHECKPOINT.match(p.name))
        )
        return [self.checkpoint(step) for step in steps]

    @classmethod
    def new(cls, log_folder: Path, algo: str, env_id: str) -> RunLayout:
        """The next free ``log_folder/<algo>/<env>_<n>`` (created)."""
        algo_folder = Path(log_folder) / algo
        n = latest_run_id(algo_folder, env_name(env_id)) + 1
        run_dir = algo_folder / f"{env_name(env_id)}_{n}"
        run_dir.mkdir(parents=True, exist_ok=False)
        return cls(run_dir, env_id)

    @classmethod
    def latest(cls, log_folder: Path, algo: str, env_id: str) -> RunLayout:
        """The newest existing run of ``algo`` on ``env_id``; ValueError if there is none, or
        if the newest folder is not a run of this project (e.g. rl_zoo3's: same layout)."""
        algo_folder = Path(log_folder) / algo
        name = env_name(env_id)
        n = latest_run_id(algo_folder, name)
        if n == 0:
            raise ValueError(
                f"no run of {algo} on {env_id} in {algo_folder} to resume; allowed: start one "
                "without --resume, or give its folder with --run-dir"
            )
        layout = cls(algo_folder / f"{name}_{n}", env_id)
        reason = layout.foreign()
        if reason is not None:
            own = [
                candidate
                for k in range(n - 1, 0, -1)
                if (candidate := cls(algo_folder / f"{name}_{k}", env_id)).args_file.is_file()
                and candidate.foreign() is None
            ]
            hint = (
                f"--run-dir {own[0].run_dir} (the latest run of this project)"
                if own
                else ("a new run (without --resume)")
            )
            raise ValueError(
                f"--resume takes the latest run, and {reason}; it is left untouched. "
                f"Allowed: {hint}"
            )
        return layout


def resolve_run_dir(path: str | os.PathLike[str]) -> Path:
    """A run folder, or the latest run a path names: ``logs/ppo/TandemWing-LevelFlight-v0``
    (the folder without its ``_<n>``) is the run ``logs/ppo/TandemWing-LevelFlight-v0_<n>``
    with the greatest ``n`` there, so a command need not hard-code a run number. Any other path
    is returned as given."""
    path = Path(path)
    if path.is_dir() or not path.parent.is_dir():
        return path
    n = latest_run_id(path.parent, path.name)
    return path.parent / f"{path.name}_{n}" if n else path


def run_lock(run_dir: Path) -> FolderLock:
    """The exclusive lock of a run folder (``<run>/.train.lock``), held while ``python -m train``
    writes there; see :class:`tandem_env.io.files.FolderLock`."""
    return FolderLock(
        run_dir,
        LOCK_FILE,
        lambda pid: (
            f"{run_dir} is in use: another python -m train (pid {pid}) is training there "
            f"and holds {LOCK_FILE}; nothing was changed. Allowed: wait for it to finish, or resume "
            "another run"
        ),
    )
