"""A faulty run folder is refused when the command is prepared, not inside a job: one line
naming the file and what is allowed, exit status 2, no traceback, nothing written.

Every loader of a run folder goes through the same checks
(:meth:`train.trained_policy.TrainedPolicy.load` for its settings,
:func:`train.saved.load_model` for a model file), so each fault is tried with
``policy:RUN_DIR``, ``python -m train.envelope`` and ``--resume``.
"""

from __future__ import annotations

import json
import re
import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest

from eval.__main__ import main as eval_main
from tandem_env.envs.registration import LEVEL_FLIGHT_ID
from train.__main__ import main as train_main
from train.config import TrainConfig
from train.envelope import main as envelope_main
from train.run import train
from train.run_folder import LOCK_FILE, RunLayout


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    result = train(
        TrainConfig(
            algo="ppo",
            env_id=LEVEL_FLIGHT_ID,
            n_timesteps=128,
            n_envs=16,
            env_kwargs={"speed": 1.5},
            hyperparams={"n_steps": 4, "batch_size": 64},
            log_folder=tmp_path_factory.mktemp("logs"),
            eval_freq=64,
            save_freq=64,
            progress_bar=False,
            tensorboard=False,
            verbose=0,
        )
    )
    assert result.run_dir is not None
    return result.run_dir


# --- the faults ----------------------------------------------------------------------------------
def _every_model(rewrite: Callable[[Path], None]) -> Callable[[RunLayout], None]:
    def write(layout: RunLayout) -> None:
        for path in sorted(layout.run_dir.glob("*.zip")):
            rewrite(path)

    return write


def _member(member: str, change: Callable[[bytes], bytes]) -> Callable[[Path], None]:
    def rewrite(path: Path) -> None:
        rewritten = path.with_suffix(".tmp")
        with zipfile.ZipFile(path) as source, zipfile.ZipFile(rewritten, "w") as target:
            for item in source.infolist():
                content = source.read(item)
                target.writestr(item, change(content) if item.filename == member else content)
        rewritten.replace(path)

    return rewrite


def _data(key: str, raw: str) -> Callable[[Path], None]:
    """The data JSON with ``key`` set to the JSON text ``raw``."""

    def change(content: bytes) -> bytes:
        data = json.loads(content)
        data[key] = "@@"
        return json.dumps(data).replace('"@@"', raw).encode()

    return _member("data", change)


def _empty_zip(path: Path) -> None:
    zipfile.ZipFile(path, "w").close()


def _yaml(name: str, key: str, value: str) -> Callable[[RunLayout], None]:
    def write(layout: RunLayout) -> None:
        path = layout.params_dir / name
        lines = [line for line in path.read_text().splitlines() if not line.startswith(f"{key}:")]
        path.write_text("\n".join([*lines, f"{key}: {value}", ""]))

    return write


def _result_json(text: str) -> Callable[[RunLayout], None]:
    def write(layout: RunLayout) -> None:
        layout.result_file.write_text(text, encoding="utf-8")

    return write


MODEL = r"(best_model|rl_model_128_steps)\.zip"
RESULT = r"result\.json: not the run's result\.json as python -m train writes it"
#: fault -> (writer, what the policy loaders say, what a resume says).
FAULTS: dict[str, tuple[Callable[[RunLayout], None], str, str]] = {
    "not a zip": (
        _every_model(lambda path: path.write_bytes(b"not a zip file at all")),
        rf"{MODEL}: refused: not a zip file \(File is not a zip file\)",
        r"no checkpoint is intact \(rl_model_64_steps\.zip, rl_model_128_steps\.zip",
    ),
    "an empty zip": (
        _every_model(_empty_zip),
        rf"{MODEL}: refused: its data is missing|{MODEL}: refused: no data entry",
        r"no checkpoint is intact \(rl_model_64_steps\.zip, rl_model_128_steps\.zip",
    ),
    "policy.pth not weights-only": (
        _every_model(_member("policy.pth", lambda _: b"\x80\x04garbage")),
        rf"{MODEL}: refused: its policy\.pth fails the weights-only load \(tensors only\)",
        r"rl_model_128_steps\.zip: refused: its policy\.pth fails the weights-only load",
    ),
    "num_timesteps 'abc'": (
        _every_model(_data("num_timesteps", '"abc"')),
        rf"{MODEL}: refused: its num_timesteps = 'abc'; allowed: an integer from 0 to "
        "1,000,000,000,000",
        r"rl_model_128_steps\.zip: refused: its num_timesteps = 'abc'",
    ),
    "num_timesteps Infinity": (
        _every_model(_data("num_timesteps", "Infinity")),
        rf"{MODEL}: refused: its num_timesteps = inf; allowed: an integer",
        r"rl_model_128_steps\.zip: refused: its num_timesteps = inf",
    ),
    "num_timesteps other than the checkpoint's name": (
        _every_model(_data("num_timesteps", "7")),
        "",  # a policy's step count is only reported
        r"rl_model_128_steps\.zip: refused: its num_timesteps = 7, not the step 128 of its name",
    ),
    "net_arch no longer matching the weights": (
        _yaml("config.yml", "policy_kwargs", "'dict(net_arch=dict(pi=[32], vf=[32]))'"),
        rf"{MODEL}: its weights do not load into a PPO model built from the run's config\.yml "
        r"\(RuntimeError: Error\(s\) in loading state_dict for ActorCriticPolicy: .*size mismatch",
        r"rl_model_128_steps\.zip: its weights do not load into a PPO model",
    ),
    "a 4e9-unit network": (
        _yaml("config.yml", "policy_kwargs", "'dict(net_arch=[4000000000])'"),
        r"config\.yml: net_arch = \[4000000000\] has at least 12,000,000,001 weights; allowed: "
        r"networks of at most 100,000,000 \(MAX_NETWORK_PARAMETERS\)",
        r"config\.yml: net_arch = \[4000000000\] has at least 12,000,000,001 weights",
    ),
    "n_envs 10^8": (
        _yaml("config.yml", "n_envs", "100000000"),
        r"config\.yml: n_envs = 100000000; allowed: an integer from 1 to 10,000",
        r"config\.yml: n_envs = 100000000; allowed: an integer from 1 to 10,000",
    ),
    # the resumed run extends result.json's segments: read before it trains, not after
    "result.json cut short": (_result_json('{"segments": ['), "", RESULT),
    "result.json segments without rewards": (
        _result_json('{"segments": [{"wall_time_s": 1.0}]}'),
        "",
        RESULT,
    ),
    "args.yml naming another env": (
        _yaml("args.yml", "env", "TandemWing/SpeedChange-v0"),
        r"args\.yml: env = 'TandemWing/SpeedChange-v0', but the file sits in the settings folder "
        r"of TandemWing-LevelFlight-v0; allowed: the env the run was trained on",
        r"is a run of env = 'TandemWing/SpeedChange-v0', not 'TandemWing/LevelFlight-v0'",
    ),
}


def _policy(run_dir: Path, out: Path) -> int:
    job = ["--budget", "1", "--seeds", "0", "--out", str(out), "--quiet"]
    return eval_main(
        ["optimize", "--task", "level", "--speed", "1.5", "--method", f"policy:{run_dir}", *job]
    )


def _envelope(run_dir: Path, out: Path) -> int:
    return envelope_main(["--run", str(run_dir), "--out", str(out), "--conditions", "1.5"])


def _resume(run_dir: Path, out: Path) -> int:
    quiet = ["--no-progress", "--no-tensorboard", "--verbose", "0"]
    return train_main(
        ["--algo", "ppo", "--env", LEVEL_FLIGHT_ID, "--run-dir", str(run_dir), "-n", "192", *quiet]
    )


LOADERS = {"policy": _policy, "envelope": _envelope, "resume": _resume}


def _files(folder: Path) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in folder.rglob("*") if p.is_file() and p.name != LOCK_FILE}


def _says(fault: str, loader: str) -> str:
    _, policy_says, resume_says = FAULTS[fault]
    return resume_says if loader == "resume" else policy_says


@pytest.mark.parametrize(
    ("fault", "loader"),
    [(fault, loader) for fault in FAULTS for loader in LOADERS if _says(fault, loader)],
)
def test_a_faulty_run_folder_is_refused_before_any_work(
    fault: str, loader: str, ppo_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write, expected = FAULTS[fault][0], _says(fault, loader)
    run_dir = tmp_path / "ppo" / ppo_run.name
    shutil.copytree(ppo_run, run_dir)
    write(RunLayout(run_dir, LEVEL_FLIGHT_ID))
    files = _files(run_dir)
    out = tmp_path / "out"
    capsys.readouterr()
    try:
        status = LOADERS[loader](run_dir, out)
    except SystemExit as error:
        status = int(error.code or 0)
    err = capsys.readouterr().err
    assert status == 2, err
    assert "Traceback" not in err and "failed" not in err, err
    errors = [line for line in err.splitlines() if ": error: " in line]
    assert len(errors) == 1 and re.search(expected, errors[0]), err
    assert not out.exists()  # no record, no failed-job report
    assert _files(run_dir) == files
