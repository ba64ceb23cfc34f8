"""A run folder's files read and written without running anything in them (docs/training.md,
"What a run folder may hold"; SB3's ``load`` and ``load_replay_buffer`` unpickle, so never read
one): :func:`load_model` rebuilds a model from ``config.yml`` and gives it the zip's
``num_timesteps`` (``data`` parsed as JSON) and weights (``torch.load(weights_only=True)``);
SAC's replay buffer is an ``.npz`` of arrays; the YAML, ``VecNormalize`` and ``result.json``
have their own readers.
"""

from __future__ import annotations

import io
import json
import pickle
import sys
import warnings
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml
from stable_baselines3 import PPO, SAC
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.buffers import ReplayBuffer
from stable_baselines3.common.logger import HumanOutputFormat, Logger
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

from tandem_env.envs.sb3 import make_sb3_vec_env
from tandem_env.io.datafile import BoundedLoader, parse_yaml
from tandem_env.io.files import atomic_path, read_json
from tandem_env.physics.checks import is_integer, is_real
from train.config import MAX_TIMESTEPS, Hyperparams


class Incomplete(ValueError):
    """A file cut short (a kill while saving): the loader's refusal, and in :attr:`damage` what
    a resume says when it skips that checkpoint for an earlier one."""

    def __init__(self, message: str, path: Path, what: str) -> None:
        super().__init__(message)
        self.damage = f"{Path(path).name} is damaged ({what})"


# --- the YAML, the normalisation statistics and result.json -----------------------------------
#: The globals (``module:name``) a pickled ``VecNormalize`` (SB3's ``save``) refers to: the
#: wrapper, its running statistics, spaces, numpy arrays and random generators; none runs code.
_NORMALIZER_GLOBALS = frozenset(
    tuple(entry.split(":"))
    for entry in (
        "stable_baselines3.common.vec_env.vec_normalize:VecNormalize collections:OrderedDict "
        "stable_baselines3.common.running_mean_std:RunningMeanStd gymnasium.spaces.box:Box "
        "gymnasium.spaces.dict:Dict gymnasium.spaces.discrete:Discrete numpy:dtype numpy:ndarray "
        "numpy.core.multiarray:_reconstruct numpy.core.multiarray:scalar "
        "numpy._core.multiarray:_reconstruct numpy._core.multiarray:scalar "
        "numpy.random._pickle:__generator_ctor numpy.random._pickle:__bit_generator_ctor "
        "numpy.random._pcg64:PCG64 numpy.random.bit_generator:SeedSequence "
        "numpy.random.bit_generator:__pyx_unpickle_SeedSequence"
    ).split()
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


def read_normalizer(path: Path, venv: VecEnv | None = None, **settings: Any) -> Any:
    """The ``VecNormalize`` statistics SB3 saved at ``path``, unpickled with only
    :data:`_NORMALIZER_GLOBALS`; ValueError naming the file otherwise. Given ``venv``, they
    wrap it, with their attributes ``settings`` (e.g. ``training=False``)."""
    try:
        with Path(path).open("rb") as stream:
            normalizer = _NormalizerUnpickler(stream).load()
    except (pickle.UnpicklingError, EOFError, ValueError, TypeError, AttributeError) as error:
        message = f"{path}: refused: not a VecNormalize file of SB3 ({error}); nothing was run"
        if isinstance(error, EOFError) or "truncated" in str(error):
            raise Incomplete(message, path, f"not a complete pickle: {error}") from None
        raise ValueError(message) from None
    except OSError as error:
        raise ValueError(f"{path} cannot be read ({error.strerror})") from None
    if not isinstance(normalizer, VecNormalize):
        raise ValueError(f"{path} holds a {type(normalizer).__name__}, not VecNormalize statistics")
    if venv is not None:
        normalizer.set_venv(venv)
        for name, value in settings.items():
            setattr(normalizer, name, value)
    return normalizer


# --- the YAML of a run folder ---------------------------------------------------------------
class RunFileLoader(BoundedLoader):
    """YAML's safe loader, bounded (:class:`BoundedLoader`), plus the two Python tags rl_zoo3
    writes (its ``OrderedDict`` of settings, tuples such as ``train_freq``; :func:`_construct`);
    every other tag is refused (:class:`ForbiddenTag`) before anything is built."""


class ForbiddenTag(yaml.constructor.ConstructorError):
    """A YAML tag :class:`RunFileLoader` does not admit (``node.tag`` in :attr:`tag`)."""

    def __init__(self, node: yaml.Node) -> None:
        self.tag = node.tag
        super().__init__(None, None, f"the tag {node.tag!r} is not admitted", node.start_mark)


_TUPLE = "tag:yaml.org,2002:python/tuple"
_ORDERED_DICT = "tag:yaml.org,2002:python/object/apply:collections.OrderedDict"


def _construct(loader: RunFileLoader, node: yaml.Node) -> Any:
    """A ``!!python/tuple`` sequence as a tuple, an ``OrderedDict`` (PyYAML writes a one-item
    sequence: the list of [key, value] pairs) as a dict; any other tag or form is refused."""
    if isinstance(node, yaml.SequenceNode) and node.tag in (_TUPLE, _ORDERED_DICT):
        items = loader.construct_sequence(node, deep=True)
        if node.tag == _TUPLE:
            return tuple(items)
        if len(items) == 1 and all(isinstance(pair, list) and len(pair) == 2 for pair in items[0]):
            return dict(items[0])
    raise ForbiddenTag(node)


for _tag in (_TUPLE, _ORDERED_DICT, None):
    RunFileLoader.add_constructor(_tag, _construct)


def parse_run_yaml(text: str, path: Path) -> dict[str, Any]:
    """The mapping in a run folder's YAML ``text`` (of file ``path``), read with
    :class:`RunFileLoader`; ValueError naming the file otherwise."""
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
    """The training segments of a run's ``result.json`` (() where there is none); ValueError
    naming the file for one this project did not write as it is."""
    if not path.is_file():
        return ()
    try:
        segments = read_json(path)["segments"]
        readable = isinstance(segments, list) and all(
            isinstance(segment, dict)
            and is_real(segment.get("wall_time_s"))
            and "best_reward" in segment
            and (segment["best_reward"] is None or is_real(segment["best_reward"]))
            and isinstance(segment.get("best_info") or {}, dict)
            for segment in segments
        )
    except (OSError, ValueError, KeyError, TypeError):
        readable = False
    if not readable:
        raise ValueError(
            f"{path}: not the run's result.json as python -m train writes it (its training "
            "segments cannot be read); it is left untouched. Allowed: that file, or none (move "
            "it away: the resumed run's summary then starts from its own segment)"
        )
    return tuple(segments)


# --- the model ------------------------------------------------------------------------------
ALGORITHMS: dict[str, type[BaseAlgorithm]] = {"ppo": PPO, "sac": SAC}


def build_model(
    algo: str,
    hp: Hyperparams,
    venv: VecEnv,
    *,
    seed: int,
    tensorboard_log: Path | None = None,
    verbose: int = 0,
    device: str = "cpu",
) -> BaseAlgorithm:
    """A new SB3 model of ``algo`` on ``venv`` with the resolved hyperparameters."""
    try:
        model = ALGORITHMS[algo](
            hp.policy,
            venv,
            seed=seed,
            tensorboard_log=None if tensorboard_log is None else str(tensorboard_log),
            policy_kwargs=dict(hp.policy_kwargs),
            verbose=verbose,
            device=device,
            **dict(hp.model_kwargs),
        )
    except TypeError as error:
        raise ValueError(f"{algo.upper()} rejected a hyperparameter: {error}") from error
    if tensorboard_log is None:
        # SB3's own logger would make an empty SB3-<time> folder in the temp dir at each
        # learn(); this one writes what that one would (the table on stdout at verbose >= 1).
        model.set_logger(Logger(None, [HumanOutputFormat(sys.stdout)] if verbose >= 1 else []))
    return model


# --- the model zip ---------------------------------------------------------------------------
#: The largest ``data`` JSON read [bytes]; SB3's is a few kB plus the last observations.
MAX_DATA_BYTES = 64 * 2**20

_ALLOWED_MODEL = "Allowed: a model saved by python -m train with the run's config.yml"


def _model_error(path: Path, what: str, damage: str | None = None) -> ValueError:
    message = f"{path}: refused: {what}; nothing in it was run. {_ALLOWED_MODEL}"
    return ValueError(message) if damage is None else Incomplete(message, path, damage)


def _read_member(archive: zipfile.ZipFile, name: str, path: Path) -> bytes:
    """The bytes of the member ``name``; :class:`Incomplete` where they fail their CRC."""
    try:
        return archive.read(name)
    except zipfile.BadZipFile as error:
        what = f"member {name} fails its CRC check"
        raise _model_error(path, f"{what} ({error})", what) from None


#: The ``.pth`` member of a model zip that holds torch variables (SAC's entropy coefficient)
#: rather than state dicts.
VARIABLES_MEMBER = "pytorch_variables.pth"


def read_model_zip(path: Path, attributes: set[str]) -> tuple[int, dict[str, Any], dict[str, Any]]:
    """The ``num_timesteps``, state dicts and torch variables of the model zip at ``path`` (its
    ``data`` parsed as JSON, each ``.pth`` read with ``torch.load(weights_only=True)``);
    ValueError naming the file (and member) for a serialized entry that is none of the rebuilt
    model's ``attributes`` (a tampered file), a bad count, or weights that fail the load."""
    params: dict[str, Any] = {}
    variables: dict[str, Any] = {}
    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, EOFError, ValueError) as error:
        damage = f"not a complete zip file: {error}"
        raise _model_error(path, f"not a zip file ({error})", damage) from None
    except OSError as error:
        raise ValueError(f"{path} cannot be read ({error.strerror})") from None
    with archive:
        try:
            info = archive.getinfo("data")
        except KeyError:  # a zip cut short can read as the inner archive of its last member
            members = ", ".join(archive.namelist()) or "no members"
            what = f"no data entry (it holds {members})"
            raise _model_error(path, what, "not a complete model file: no data") from None
        if info.file_size > MAX_DATA_BYTES:
            raise _model_error(path, f"its data is {info.file_size:,} bytes")
        try:
            data = json.loads(_read_member(archive, info.filename, path))
        except (UnicodeDecodeError, json.JSONDecodeError, OSError) as error:
            raise _model_error(path, f"its data is not JSON ({error})") from None
        if not isinstance(data, dict):
            raise _model_error(path, f"its data is a JSON {type(data).__name__}, not an object")
        foreign = sorted(
            key
            for key, value in data.items()
            if key not in attributes and isinstance(value, dict) and ":serialized:" in value
        )
        if foreign:
            raise _model_error(
                path,
                "its data holds serialized (pickled) entries SB3 does not write: "
                + ", ".join(foreign),
            )
        steps = data.get("num_timesteps", 0)
        if not is_integer(steps) or not 0 <= steps <= MAX_TIMESTEPS:
            raise _model_error(
                path,
                f"its num_timesteps = {steps!r}; allowed: an integer from 0 to {MAX_TIMESTEPS:,}",
            )
        for name in archive.namelist():
            if not name.endswith(".pth"):
                continue
            try:
                with warnings.catch_warnings():  # torch's notes on a file it then refuses
                    warnings.simplefilter("ignore", UserWarning)
                    stream = io.BytesIO(_read_member(archive, name, path))
                    content = torch.load(stream, map_location="cpu", weights_only=True)
            except Incomplete:  # a member that fails its CRC: said as such, not as a load
                raise
            # a damaged member (zlib.error, EOFError) or what torch refuses: the same refusal
            except Exception as error:
                # the line that says what was found (torch explains its defaults at length first)
                lines = [line.strip() for line in str(error).splitlines() if line.strip()]
                found = [line for line in lines if "nsupported" in line]  # "... unsupported ..."
                gist = (found or lines or [""])[0][:300]
                raise _model_error(
                    path,
                    f"its {name} fails the weights-only load (tensors only): "
                    f"{type(error).__name__}: {gist}",
                ) from None
            if name == VARIABLES_MEMBER:
                if not isinstance(content, dict):
                    raise _model_error(path, f"its {name} is not a mapping of tensors")
                variables = content
            else:
                params[name.removesuffix(".pth")] = content
    if "policy" not in params:
        raise _model_error(path, "it has no policy.pth (the policy's weights)")
    return steps, params, variables


def load_model(
    algo: str,
    path: Path,
    hp: Hyperparams,
    venv: VecEnv,
    *,
    step: int | None = None,
    replay_buffer: Path | None = None,
    **settings: Any,
) -> BaseAlgorithm:
    """The model saved at ``path``, rebuilt from ``hp`` on ``venv`` (``settings``:
    :func:`build_model`'s) and given the file's weights and step count (a checkpoint's: its
    ``step``), nothing unpickled; ValueError naming the file if they do not fit."""
    model = build_model(algo, hp, venv, **settings)
    num_timesteps, params, variables = read_model_zip(path, set(vars(model)))
    expected = sorted(model.get_parameters())
    if sorted(params) != expected:
        raise _model_error(
            path,
            f"it holds the state dicts {', '.join(sorted(params))}; a {algo.upper()} model of "
            f"the run's config.yml has {', '.join(expected)}",
        )
    try:
        model.set_parameters(params, exact_match=True)  # a dict: its tensors, no device move
        # the saved torch variables (SAC's entropy coefficient) into the model's own
        for name, value in variables.items():
            if value is None:
                continue  # SB3 saves None for a variable the model does not use
            known = name in ("log_ent_coef", "ent_coef_tensor")
            target = getattr(model, name, None) if known else None
            if not isinstance(target, torch.Tensor) or not isinstance(value, torch.Tensor):
                raise ValueError(f"a torch variable {name!r} this model does not have")
            if target.shape != value.shape:
                raise ValueError(
                    f"{name} has shape {tuple(value.shape)}, not {tuple(target.shape)}"
                )
            with torch.no_grad():
                target.copy_(value)
    except (RuntimeError, ValueError, KeyError, TypeError, IndexError) as error:
        reason = " ".join(str(error).split())
        raise ValueError(
            f"{path}: its weights do not load into a {algo.upper()} model built from the run's "
            f"config.yml ({type(error).__name__}: {reason[:400]}). {_ALLOWED_MODEL}"
        ) from None
    if step is not None and num_timesteps != step:
        raise _model_error(
            path, f"its num_timesteps = {num_timesteps}, not the step {step} of its name"
        )
    model.num_timesteps = num_timesteps
    if replay_buffer is not None:
        load_replay_buffer(model, replay_buffer)
    return model


# --- the replay buffer -----------------------------------------------------------------------
#: The arrays of SB3's ``ReplayBuffer`` (public attributes) an ``.npz`` buffer file holds, each
#: cut to the rows filled so far; ``next_observations`` is None with ``optimize_memory_usage``.
REPLAY_ARRAYS = ("observations", "next_observations", "actions", "rewards", "dones", "timeouts")
#: The write position and fullness of the ring, stored beside the arrays.
REPLAY_COUNTERS = ("pos", "full")


def _replay_buffer(model: BaseAlgorithm) -> ReplayBuffer:
    buffer = getattr(model, "replay_buffer", None)
    if type(buffer) is not ReplayBuffer:
        raise TypeError(f"{type(buffer).__name__} is not SB3's plain ReplayBuffer")
    return buffer


def save_replay_buffer(model: BaseAlgorithm, path: Path) -> None:
    """Write the model's replay buffer to ``path`` as an ``.npz`` of plain arrays (no pickle)."""
    buffer = _replay_buffer(model)
    rows = buffer.buffer_size if buffer.full else buffer.pos
    arrays = {
        name: getattr(buffer, name)[:rows]
        for name in REPLAY_ARRAYS
        if getattr(buffer, name) is not None
    }
    with Path(path).open("wb") as stream:  # a file object: savez would append ".npz" to a name
        np.savez(stream, pos=np.int64(buffer.pos), full=np.bool_(buffer.full), **arrays)


def load_replay_buffer(model: BaseAlgorithm, path: Path) -> None:
    """Fill the model's rebuilt replay buffer from the ``.npz`` at ``path`` (no pickle);
    ValueError naming the file if its arrays or counters are not this buffer's."""
    buffer = _replay_buffer(model)
    expected = {n for n in REPLAY_ARRAYS if getattr(buffer, n) is not None} | set(REPLAY_COUNTERS)
    refused = f"{path}: refused as the replay buffer of this run"
    try:
        with np.load(path, allow_pickle=False) as archive:
            if set(archive.files) != expected:
                raise ValueError(
                    f"it holds {', '.join(sorted(archive.files))}; a buffer file holds "
                    f"{', '.join(sorted(expected))}"
                )
            pos, full = archive["pos"], archive["full"]
            if pos.shape or pos.dtype.kind not in "iu" or not 0 <= pos < buffer.buffer_size:
                raise ValueError(f"pos = {pos!r}; allowed: 0 to {buffer.buffer_size - 1}")
            if full.shape or full.dtype != np.bool_:
                raise ValueError(f"full = {full!r}; allowed: a boolean")
            rows = buffer.buffer_size if full else int(pos)
            loaded = {}
            for name in expected - set(REPLAY_COUNTERS):
                array, target = archive[name], getattr(buffer, name)
                shape = (rows, *target.shape[1:])
                if array.dtype != target.dtype or array.shape != shape:
                    raise ValueError(
                        f"{name} is {array.dtype}{list(array.shape)}; this run's buffer takes "
                        f"{target.dtype}{list(shape)}"
                    )
                loaded[name] = array
    except ValueError as error:
        raise ValueError(f"{refused} ({error}); nothing was loaded") from None
    except (OSError, EOFError, zipfile.BadZipFile) as error:
        message = f"{refused}: not a readable .npz ({error}); nothing was loaded"
        raise Incomplete(message, path, f"not a complete zip file: {error}") from None
    for name, array in loaded.items():
        getattr(buffer, name)[:rows] = array
    buffer.pos, buffer.full = int(pos), bool(full)


def save_checkpoint(model: BaseAlgorithm, layout: Any, keep: int | None = None) -> Any:
    """Checkpoint at the model's step in ``layout`` (a ``RunLayout``), keeping the ``keep``
    newest; atomic files, the model last, so a model file means a complete checkpoint."""
    checkpoint = layout.checkpoint(model.num_timesteps)
    if getattr(model, "replay_buffer", None) is not None:
        with atomic_path(checkpoint.replay_buffer) as tmp:
            save_replay_buffer(model, tmp)
    normalizer = model.get_vec_normalize_env()
    if normalizer is not None:
        with atomic_path(checkpoint.vecnormalize) as tmp:
            normalizer.save(str(tmp))
    with atomic_path(checkpoint.model) as tmp:
        model.save(tmp)
    for old in layout.checkpoints()[: -keep if keep else 0]:
        for path in old.paths():
            path.unlink(missing_ok=True)
    return checkpoint


def load_on_copy(
    algo: str,
    path: Path,
    hp: Hyperparams,
    env_id: str,
    env_kwargs: Mapping[str, Any],
    **checkpoint: Any,
) -> BaseAlgorithm:
    """A model file (:func:`load_model`) loaded on a throwaway copy of the run's env."""
    # The run's own n_envs, so that the rebuilt model is the saved one (PPO's rollout size).
    venv = make_sb3_vec_env(env_id, n_envs=hp.n_envs, seed=0, **env_kwargs)
    try:
        return load_model(algo, path, hp, venv, seed=0, **checkpoint)
    except BaseException:
        venv.close()
        raise
