"""``python -m train`` writes the zoo-style run folder; ``python -m train.envelope`` its CSV."""

from __future__ import annotations

import csv
import subprocess
import sys
import zipfile
from dataclasses import MISSING, fields
from pathlib import Path

import numpy as np
import pytest
import yaml

from tandem_env.envs.registration import LEVEL_FLIGHT_ID
from train.__main__ import build_parser, main, parse_config
from train.config import TrainConfig
from train.run import MONITOR_KEYWORDS, train
from train.run_folder import RunLayout
from train.saved import read_normalizer

REPO = Path(__file__).resolve().parents[2]


def test_cli_writes_the_run_folder(tmp_path: Path) -> None:
    command = [
        sys.executable,
        "-m",
        "train",
        "--algo",
        "sac",
        "--env",
        LEVEL_FLIGHT_ID,
        "--timesteps",
        "256",
        "--seed",
        "0",
        "--n-envs",
        "16",
        "--env-kwargs",
        "speed_range=(0.25, 2.0)",
        "thrust_split:sign",
        "--hyperparams",
        "learning_starts=64",
        "gradient_steps=2",
        "--eval-freq",
        "128",
        "--save-freq",
        "128",
        "--log-dir",
        str(tmp_path),
        "--no-progress",
    ]
    done = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    run_dir = tmp_path / "sac" / "TandemWing-LevelFlight-v0_1"
    layout = RunLayout(run_dir, LEVEL_FLIGHT_ID)
    for path in (
        layout.final_model,
        layout.best_model,
        layout.evaluations,
        layout.config_file,
        layout.args_file,
        layout.result_file,
    ):
        assert path.is_file(), path
    checkpoint = layout.checkpoints()[-1]
    assert checkpoint.step == 256
    with (
        zipfile.ZipFile(checkpoint.model) as model,
        zipfile.ZipFile(checkpoint.replay_buffer) as rb,
    ):
        assert model.testzip() is None and rb.testzip() is None  # complete, every CRC right
    assert list((run_dir / "tb").glob("SAC_1/events.out.tfevents.*"))

    config = yaml.safe_load(layout.config_file.read_text())
    assert config["n_envs"] == 16 and config["learning_starts"] == 64
    assert isinstance(config["policy_kwargs"], str)  # as the zoo stores it
    args = yaml.safe_load(layout.args_file.read_text())
    assert args["env_kwargs"] == {"speed_range": [0.25, 2.0], "thrust_split": "sign"}
    assert args["seed"] == 0 and args["algo"] == "sac"

    [monitor] = layout.monitor_files()
    with monitor.open() as stream:
        stream.readline()  # the JSON header line
        rows = list(csv.DictReader(stream))
    assert len(rows) == 256
    assert set(MONITOR_KEYWORDS) <= set(rows[0])
    speeds = np.array([float(r["speed"]) for r in rows])
    assert 0.25 <= speeds.min() < speeds.max() <= 2.0  # sampled over the range

    with np.load(layout.evaluations) as evaluations:
        # One episode per evaluation condition: the sweep speeds inside the range.
        assert evaluations["results"].shape[1] == 8
    assert "run folder:" in done.stdout

    # A second run goes to the next folder, as in the zoo.
    assert (
        main(
            [
                *command[3:],
                "--timesteps",
                "32",
                "--eval-freq",
                "0",
                "--save-freq",
                "0",
                "--no-tensorboard",
                "--verbose",
                "0",
            ]
        )
        == 0
    )
    assert (
        tmp_path / "sac" / "TandemWing-LevelFlight-v0_2" / "TandemWing-LevelFlight-v0.zip"
    ).is_file()


def test_normalised_run_saves_its_statistics(tmp_path: Path) -> None:
    result = train(
        TrainConfig(
            algo="ppo",
            env_id=LEVEL_FLIGHT_ID,
            n_timesteps=256,
            n_envs=16,
            hyperparams={
                "n_steps": 4,
                "batch_size": 64,
                "normalize": "dict(norm_obs=True, norm_reward=False)",
            },
            env_kwargs={"speed_range": (0.5, 1.5)},
            log_folder=tmp_path,
            eval_freq=64,
            save_freq=128,
            progress_bar=False,
            tensorboard=False,
            verbose=0,
        )
    )
    layout = RunLayout(result.run_dir, LEVEL_FLIGHT_ID)  # type: ignore[arg-type]
    assert layout.vecnormalize.is_file()
    read_normalizer(layout.checkpoints()[-1].vecnormalize)  # complete: it loads
    # Range 0.5-1.5 m/s holds the sweep speeds 0.5, 0.75, ..., 1.5.
    assert [row["speed"] for row in result.final_evaluation] == [0.5, 0.75, 1.0, 1.25, 1.5]


def test_cli_defaults_are_the_configs() -> None:
    # Every option sets a TrainConfig field, and an option left out keeps the field's default.
    names = {f.name for f in fields(TrainConfig)}
    parser = build_parser()
    assert {action.dest for action in parser._actions} == {*names, "help", "insect"}
    config = parse_config(parser, ["--algo", "sac", "--env", LEVEL_FLIGHT_ID])
    for f in fields(TrainConfig):
        if f.default is not MISSING:
            assert getattr(config, f.name) == f.default, f.name
    assert config.env_kwargs == {} and config.hyperparams == {}
    help_text = " ".join(build_parser().format_help().split())
    # the help is each field's docstring, with its default
    assert "evaluations (<= 0: none) (default 10000)" in help_text and "(default logs)" in help_text


def test_cli_rejects_bad_arguments(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(
            [
                "--algo",
                "ppo",
                "--env",
                LEVEL_FLIGHT_ID,
                "--env-kwargs",
                "speed=9",
                "-f",
                str(tmp_path),
                "--no-progress",
            ]
        )
    assert "speed" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["--algo", "ppo", "--env", LEVEL_FLIGHT_ID, "--resume", "-f", str(tmp_path)])
    assert "no run of ppo" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(
            [
                "--algo",
                "ppo",
                "--env",
                LEVEL_FLIGHT_ID,
                "--hyperparams",
                "bogus=1",
                "-n",
                "64",
                "-f",
                str(tmp_path),
                "--no-progress",
            ]
        )
    assert "bogus" in capsys.readouterr().err


def test_a_seed_beyond_32_bits_is_refused_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """SB3 seeds numpy's legacy generator (32 bits): it said "Seed must be between 0 and
    2**32 - 1" without naming the option or the value."""
    argv = ["--algo", "ppo", "--env", LEVEL_FLIGHT_ID, "-f", str(tmp_path / "logs")]
    with pytest.raises(SystemExit) as info:
        main([*argv, "--seed", str(2**32)])
    err = capsys.readouterr().err
    assert info.value.code == 2 and "seed = 4294967296; allowed: an integer from 0 to 2**32" in err
    assert not (tmp_path / "logs").exists()


@pytest.mark.parametrize("where", ["file", "parent"])
def test_envelope_refuses_a_file_as_out_before_loading_the_policy(
    where: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from train.envelope import main as envelope

    blocker = tmp_path / "taken"
    blocker.write_text("")
    out = blocker if where == "file" else blocker / "sub"
    with pytest.raises(SystemExit) as info:
        envelope(["--run", str(tmp_path / "no-run"), "--out", str(out)])
    err = capsys.readouterr().err
    assert info.value.code == 2 and f"{blocker} is a file; allowed: a directory" in err
    assert "Traceback" not in err


@pytest.mark.parametrize(
    ("folder", "match"),
    [("file", r"log_folder \(-f\) '.*file': .*file is a file; allowed: a directory"),
     ("", r"log_folder \(-f\) '': an empty path"),
     ("dangling", r"is a dangling symlink")],
)  # fmt: skip
def test_a_log_folder_that_cannot_be_one_is_named_not_errno_text(
    tmp_path: Path, folder: str, match: str
) -> None:
    (tmp_path / "file").write_text("")
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    log_folder = str(tmp_path / folder) if folder else ""
    with pytest.raises(ValueError, match=match):
        TrainConfig(algo="ppo", env_id=LEVEL_FLIGHT_ID, log_folder=log_folder)


def test_sb3_log_table_is_off_by_default_and_a_flag_away(tmp_path: Path) -> None:
    from tandem_env.envs.sb3 import make_sb3_vec_env
    from train.config import load_entry, resolve_hyperparams
    from train.run_folder import RunFolder, RunLayout

    hp = resolve_hyperparams(load_entry("ppo", LEVEL_FLIGHT_ID), algo="ppo", n_envs=2)
    venv = make_sb3_vec_env(LEVEL_FLIGHT_ID, n_envs=2, seed=0)
    base = ["--algo", "ppo", "--env", LEVEL_FLIGHT_ID, "--no-tensorboard"]
    # the model's verbose: SB3's table only with --log-table or --verbose 2; the run's own lines
    # follow --verbose
    for extra, table in (([], 0), (["--log-table"], 1), (["--verbose", "2"], 2)):
        config = parse_config(build_parser(), [*base, *extra])
        run = RunFolder(RunLayout(tmp_path, LEVEL_FLIGHT_ID), config, hp)
        assert run.model(venv).verbose == table, extra
    assert config.verbose == 2 and not parse_config(build_parser(), base).log_table


def test_a_plugged_in_task_trains_without_a_patch(tmp_path: Path) -> None:
    """The toy task (tests/agents/toy_task.py, one file) with one registration line, the
    ``tandem_env.tasks`` entry point of an installed plug-in: ``python -m train`` takes its id,
    as the harness and ``eval optimize`` do, and writes the run folder."""
    sys.path.insert(0, str(REPO / "tests" / "agents"))
    from plugin import install_entry_points
    from toy_task import TOY_ID

    env = install_entry_points(
        tmp_path / "site", "tandem_env.tasks", {TOY_ID: "toy_task:TOY_ENTRY"}
    )
    command = [sys.executable, "-m", "train", "--algo", "ppo", "--env", TOY_ID]
    command += ["--timesteps", "32", "--n-envs", "4", "--env-kwargs", "n_time=16", "n_blade=4"]
    command += ["--hyperparams", "n_steps=8", "batch_size=16", "n_epochs=1"]
    command += ["--eval-freq", "0", "--save-freq", "0", "--no-tensorboard", "--no-progress"]
    command += ["--log-dir", str(tmp_path / "logs")]
    done = subprocess.run(
        command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    layout = RunLayout(tmp_path / "logs" / "ppo" / "TandemToy-Cruise-v0_1", TOY_ID)
    assert layout.final_model.is_file() and layout.result_file.is_file()
    args = yaml.safe_load(layout.args_file.read_text())
    assert args["env"] == TOY_ID and args["env_kwargs"] == {"n_time": 16, "n_blade": 4}


@pytest.mark.parametrize(
    "name", ["train.tune:TuneConfig", "train.envelope:EnvelopeOptions",
             "train.amortised_eval:HeldOutOptions", "train.curves:CurvesOptions"],
)  # fmt: skip
def test_each_command_line_is_its_dataclass(name: str) -> None:
    """Every option of train's other commands is one field of its options' dataclass, its help
    that field's docstring (train.entry), and nothing else is an option."""
    import importlib

    from train.entry import build_parser as fields_parser
    from train.entry import field_docs

    module, _, cls_name = name.partition(":")
    cls = getattr(importlib.import_module(module), cls_name)
    parser = fields_parser(cls)
    assert {a.dest for a in parser._actions} == {f.name for f in fields(cls)} | {"help"}
    help_text = " ".join(parser.format_help().split())
    for doc in field_docs(cls).values():
        assert doc.removesuffix(".") in help_text, doc


def test_a_value_its_dataclass_refuses_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from train.amortised_eval import main as held_out
    from train.curves import main as curves

    for command, argv, said in (
        (curves, ["--runs", str(tmp_path), "--out", str(tmp_path / "c.png")],
         f"{tmp_path} is not a training run folder (expected one <env>/args.yml"),
        (held_out, ["--run", str(tmp_path), "--records", str(tmp_path / "none")],
         f"--records {tmp_path / 'none'} is not a folder; allowed: the records folder"),
    ):  # fmt: skip
        with pytest.raises(SystemExit) as stop:
            command(argv)
        err = capsys.readouterr().err
        assert stop.value.code == 2 and said in err and "Traceback" not in err, err
