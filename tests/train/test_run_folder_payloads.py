"""A tampered run folder runs no code: a live payload in every file of a run folder, for every
loader of one (``--resume``, ``policy:RUN_DIR``, ``python -m train.envelope``,
``speed-change --ppo/--sac``).

Each payload would ``touch`` a marker file if it were unpickled or evaluated (``os.system`` by
``__reduce__``, or a YAML tag); the marker must never appear. A loader that reads the file
refuses it with one line naming it (exit status 2, no traceback) and leaves the folder as it
was; a file the loader does not read changes nothing (the command runs as on the intact folder).
"""

from __future__ import annotations

import base64
import io
import json
import os
import pickle
import re
import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import torch

from eval.__main__ import main as eval_main
from tandem_env.envs.registration import LEVEL_FLIGHT_ID, SPEED_CHANGE_ID
from train.__main__ import main as train_main
from train.config import TrainConfig
from train.envelope import main as envelope_main
from train.run import train
from train.run_folder import LOCK_FILE, RunLayout

NAME = "TandemWing-LevelFlight-v0"


class _Touch:
    """Unpickling this runs ``touch path``: what a hostile file would do."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self):
        return (os.system, (f"touch {self.path}",))


def _run(tmp_path_factory: pytest.TempPathFactory, algo: str, **settings) -> Path:
    """A finished run of 128 env steps (16 envs) with checkpoints, evaluations and, for PPO,
    normalised observations: every kind of file a run folder has."""
    config = TrainConfig(
        algo=algo,  # type: ignore[arg-type]
        env_id=LEVEL_FLIGHT_ID,
        n_timesteps=128,
        n_envs=16,
        env_kwargs={"speed": 1.5},
        log_folder=tmp_path_factory.mktemp(algo),
        eval_freq=64,
        save_freq=64,
        progress_bar=False,
        tensorboard=False,
        verbose=0,
        **settings,
    )
    result = train(config)
    assert result.run_dir is not None
    return result.run_dir


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    normalize = "dict(norm_obs=True, norm_reward=False)"
    hyperparams = {"n_steps": 4, "batch_size": 64, "normalize": normalize}
    run_dir = _run(tmp_path_factory, "ppo", hyperparams=hyperparams)
    layout = RunLayout(run_dir, LEVEL_FLIGHT_ID)
    assert layout.vecnormalize.is_file() and layout.best_model.is_file()
    assert [c.step for c in layout.checkpoints()] == [64, 128]
    return run_dir


@pytest.fixture(scope="module")
def sac_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run_dir = _run(tmp_path_factory, "sac", hyperparams={"learning_starts": 32, "batch_size": 32})
    checkpoints = RunLayout(run_dir, LEVEL_FLIGHT_ID).checkpoints()
    assert [c.replay_buffer.is_file() for c in checkpoints] == [True, True]
    return run_dir


# --- the payloads, one writer per kind of file -----------------------------------------------
def _pickled(marker: Path) -> bytes:
    return pickle.dumps(_Touch(marker))


def _rewrite_member(path: Path, member: str, content: bytes) -> None:
    rewritten = path.with_suffix(".tmp")
    with zipfile.ZipFile(path) as source, zipfile.ZipFile(rewritten, "w") as target:
        assert member in source.namelist(), (path, member)
        for item in source.infolist():
            target.writestr(item, content if item.filename == member else source.read(item))
    rewritten.replace(path)


def _models(layout: RunLayout) -> list[Path]:
    """Every model zip: the final and best models and the checkpoints."""
    return sorted(layout.run_dir.glob("*.zip"))


def _data_entry(key: str) -> Callable[[RunLayout, Path], None]:
    def write(layout: RunLayout, marker: Path) -> None:
        serialized = base64.b64encode(_pickled(marker)).decode()  # as SB3 writes cloudpickle
        for path in _models(layout):
            with zipfile.ZipFile(path) as archive:
                data = json.loads(archive.read("data"))
            data[key] = {":type:": "<class 'object'>", ":serialized:": serialized}
            _rewrite_member(path, "data", json.dumps(data).encode())

    return write


def _pth(member: str) -> Callable[[RunLayout, Path], None]:
    def write(layout: RunLayout, marker: Path) -> None:
        stream = io.BytesIO()
        torch.save(_Touch(marker), stream)  # torch's own format, its pickle holding the payload
        for path in _models(layout):
            _rewrite_member(path, member, stream.getvalue())

    return write


def _vecnormalize(layout: RunLayout, marker: Path) -> None:
    files = sorted(layout.run_dir.rglob("*vecnormalize*.pkl"))
    assert len(files) == 4  # final, best model's, two checkpoints'
    for path in files:
        path.write_bytes(_pickled(marker))


def _yaml(name: str) -> Callable[[RunLayout, Path], None]:
    def write(layout: RunLayout, marker: Path) -> None:
        path = layout.params_dir / name
        path.write_text(
            path.read_text() + f"extra: !!python/object/apply:os.system ['touch {marker}']\n"
        )

    return write


def _object_array(marker: Path) -> np.ndarray:
    array = np.empty(1, dtype=object)
    array[0] = _Touch(marker)
    return array


def _npz(path: Path, marker: Path, member: str) -> None:
    with np.load(path, allow_pickle=False) as archive:
        arrays = {name: archive[name] for name in archive.files}
    arrays[member] = _object_array(marker)
    with path.open("wb") as stream:
        np.savez(stream, **arrays)  # savez pickles an object array


def _evaluations(layout: RunLayout, marker: Path) -> None:
    _npz(layout.evaluations, marker, "results")


def _result_json(layout: RunLayout, marker: Path) -> None:
    data = json.loads(layout.result_file.read_text())
    data["best_seen"] = {":serialized:": base64.b64encode(_pickled(marker)).decode()}
    layout.result_file.write_text(json.dumps(data))


def _replay_buffer(layout: RunLayout, marker: Path) -> None:
    for checkpoint in layout.checkpoints():
        _npz(checkpoint.replay_buffer, marker, "rewards")


def _legacy_replay_buffer(layout: RunLayout, marker: Path) -> None:
    """The pickled buffer file of earlier versions (SB3's save_replay_buffer), npz removed."""
    for checkpoint in layout.checkpoints():
        checkpoint.replay_buffer.unlink()
        checkpoint.legacy_replay_buffer.write_bytes(_pickled(marker))


# --- the loaders -------------------------------------------------------------------------------
def _status(command: Callable[[], int]) -> int:
    try:
        return command()
    except SystemExit as error:
        return int(error.code or 0)


def _resume(run_dir: Path, out: Path) -> int:
    quiet = ["--no-progress", "--no-tensorboard", "--verbose", "0"]
    algo = run_dir.parent.name
    return train_main(
        ["--algo", algo, "--env", LEVEL_FLIGHT_ID, "--run-dir", str(run_dir), "-n", "192", *quiet]
    )


def _policy(run_dir: Path, out: Path) -> int:
    job = ["--budget", "1", "--seeds", "0", "--out", str(out), "--quiet"]
    return eval_main(
        ["optimize", "--task", "level", "--speed", "1.5", "--method", f"policy:{run_dir}", *job]
    )


def _envelope(run_dir: Path, out: Path) -> int:
    return envelope_main(["--run", str(run_dir), "--out", str(out), "--conditions", "1.5"])


def _speed_change(run_dir: Path, out: Path) -> int:
    algo = run_dir.parent.name
    return eval_main(["speed-change", f"--{algo}", str(run_dir), "--out", str(out), "--quiet"])


LOADERS = {
    "resume": _resume,
    "policy": _policy,
    "envelope": _envelope,
    "speed-change": _speed_change,
}
#: What each loader ends with on an intact LevelFlight run: speed-change flies SpeedChange runs
#: only, and says so once the run's policy has been loaded (its files read).
INTACT = {
    "resume": 0,
    "policy": 0,
    "envelope": 0,
    "speed-change": f"trained on {LEVEL_FLIGHT_ID}; allowed: a run on {SPEED_CHANGE_ID}",
}

REFUSED_MODEL = r"rl_model_128_steps\.zip|best_model\.zip|TandemWing-LevelFlight-v0\.zip"
#: (run, writer, the refusal of a loader that reads the file; None: nobody refuses it, and
#: which loaders read it).
CASES: dict[str, tuple[str, Callable[[RunLayout, Path], None], str | None, tuple[str, ...]]] = {
    "data JSON, an entry SB3 does not write": (
        "ppo",
        _data_entry("evil"),
        rf"({REFUSED_MODEL}): refused: its data holds serialized \(pickled\) entries SB3 does "
        "not write: evil; nothing in it was run",
        tuple(LOADERS),
    ),
    # SB3's own entries are never decoded: the model is rebuilt from config.yml.
    "data JSON, SB3's policy_class": ("ppo", _data_entry("policy_class"), None, tuple(LOADERS)),
    "data JSON, SB3's observation_space": (
        "ppo",
        _data_entry("observation_space"),
        None,
        tuple(LOADERS),
    ),
    **{
        member: (
            "ppo",
            _pth(member),
            rf"({REFUSED_MODEL}): refused: its {re.escape(member)} fails the weights-only load "
            r"\(tensors only\): UnpicklingError: Trying to load unsupported GLOBAL posix\.system",
            tuple(LOADERS),
        )
        for member in ("policy.pth", "policy.optimizer.pth", "pytorch_variables.pth")
    },
    "SAC actor.optimizer.pth": (
        "sac",
        _pth("actor.optimizer.pth"),
        rf"({REFUSED_MODEL}): refused: its actor\.optimizer\.pth fails the weights-only load",
        tuple(LOADERS),
    ),
    "vecnormalize": (
        "ppo",
        _vecnormalize,
        r"vecnormalize(_128_steps)?\.pkl: refused: not a VecNormalize file of SB3 "
        r"\(it names posix\.system",
        tuple(LOADERS),
    ),
    "args.yml": (
        "ppo",
        _yaml("args.yml"),
        r"args\.yml: refused: it holds the YAML tag tag:yaml\.org,2002:python/object/apply",
        tuple(LOADERS),
    ),
    "config.yml": (
        "ppo",
        _yaml("config.yml"),
        r"config\.yml: refused: it holds the YAML tag tag:yaml\.org,2002:python/object/apply",
        tuple(LOADERS),
    ),
    # Read by a resume only, with allow_pickle=False: warned about, the history starts again.
    "evaluations.npz": ("ppo", _evaluations, None, ("resume",)),
    # Read by a resume only, as JSON: no object is built from it.
    "result.json": ("ppo", _result_json, None, ("resume",)),
    "replay buffer": (
        "sac",
        _replay_buffer,
        r"rl_model_replay_buffer_128_steps\.npz: refused as the replay buffer of this run "
        r"\(Object arrays cannot be loaded when allow_pickle=False\); nothing was loaded",
        ("resume",),
    ),
    "replay buffer of earlier versions (.pkl)": (
        "sac",
        _legacy_replay_buffer,
        r"no checkpoint is intact \(rl_model_64_steps\.zip, rl_model_128_steps\.zip",
        ("resume",),
    ),
}


def _files(folder: Path) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in folder.rglob("*") if p.is_file() and p.name != LOCK_FILE}


@pytest.mark.parametrize("loader", list(LOADERS))
@pytest.mark.parametrize("case", list(CASES))
def test_a_payload_in_a_run_folder_runs_nothing(
    case: str,
    loader: str,
    ppo_run: Path,
    sac_run: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    algo, write, refusal, readers = CASES[case]
    source = ppo_run if algo == "ppo" else sac_run
    run_dir = tmp_path / algo / source.name
    shutil.copytree(source, run_dir)
    layout = RunLayout(run_dir, LEVEL_FLIGHT_ID)
    marker = tmp_path / "MARKER"
    write(layout, marker)
    files = _files(run_dir)
    capsys.readouterr()

    status = _status(lambda: LOADERS[loader](run_dir, tmp_path / "out"))

    assert not marker.exists(), f"{case}: the payload ran under {loader}"
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    if refusal is not None and loader in readers:
        assert status == 2, err
        assert re.search(refusal, err), err
        assert _files(run_dir) == files  # refused before any work: the folder as it was
        if case.startswith("replay buffer of earlier"):
            assert "the pickled format of earlier versions, which is never loaded" in err
    elif isinstance(INTACT[loader], str):
        assert status == 2 and INTACT[loader] in err, err
    else:
        assert status == INTACT[loader], err
        if loader == "resume" and case == "evaluations.npz":
            assert "evaluations.npz cannot be read (ValueError: Object arrays" in err
