"""Another insect through the env keyword insect=, --insect of optimize / study / train, and
the record key: the default insect leaves every key as it was; one insect given as an object, a
mapping or a file is one key; the records, the summary and the report say which insect ran."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import gymnasium as gym
import pytest

import tandem_env  # noqa: F401 - registers the envs
from agents.jobs import Job
from agents.store import RecordStore
from eval.__main__ import main
from eval.studies.base import StudyPlan
from eval.studies.presets import TINY
from tandem_env.io.files import to_jsonable
from tandem_env.physics.insect import DRAGONFLY, insect_mapping, load_insect
from train.__main__ import build_parser, parse_config

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "scaled_dragonfly.yaml"
LEVEL_ID = "TandemWing/LevelFlight-v0"
SMALL = {"n_blade": 6, "n_time": 32}


def _job(**env_kwargs) -> Job:
    return Job("pso", "level", 1.5, 16, 0, env_kwargs={**SMALL, **env_kwargs}, preset="quick")


def test_env_keyword_takes_an_object_a_mapping_or_a_file() -> None:
    insect = load_insect(EXAMPLE)
    for given in (insect, insect_mapping(insect), str(EXAMPLE), EXAMPLE):
        env = gym.make(LEVEL_ID, insect=given, **SMALL)
        assert env.unwrapped.config.insect == insect
        env.close()
    with pytest.raises(ValueError, match=r"insect\.fore\.lenght: unknown field"):
        gym.make(LEVEL_ID, insect={"fore": {"lenght": 0.03}})


def test_the_default_insect_leaves_the_key_unchanged(tmp_path: Path) -> None:
    empty = tmp_path / "specimen.yaml"
    empty.write_text("{}\n", encoding="utf-8")
    plain = _job()
    for default in (DRAGONFLY, {}, empty):
        job = _job(insect=default)
        assert job == plain and job.key == plain.key
        assert "insect" not in job.to_dict()["env_kwargs"]
    assert StudyPlan(TINY).jobs("level", [1.0]) == StudyPlan(TINY, insect=DRAGONFLY).jobs(
        "level", [1.0]
    )


def test_one_insect_is_one_key_and_another_is_another() -> None:
    insect = load_insect(EXAMPLE)
    jobs = [_job(insect=given) for given in (insect, insect_mapping(insect), str(EXAMPLE))]
    assert len({job.key for job in jobs}) == 1 and len(set(jobs)) == 1  # hashable
    assert jobs[0].key != _job().key
    assert jobs[0].key != _job(insect={"body_mass": 2e-4}).key
    again = Job.from_dict(json.loads(json.dumps(jobs[0].to_dict())))
    assert again == jobs[0] and again.key == jobs[0].key
    assert jobs[0].to_dict()["env_kwargs"]["insect"] == insect_mapping(insect)
    study = StudyPlan(TINY, insect=insect).jobs("level", [1.0])
    assert all(to_jsonable(job.env("insect")) == insect_mapping(insect) for job in study)


@pytest.mark.parametrize(
    "text, message",
    [
        ("fore: {lenght: 0.03}\n", r"insect\.fore\.lenght: unknown field; allowed: mean_chord"),
        ("body_mass: -1\n", r"Dragonfly\.body_mass = -1 kg; allowed: 0 < body_mass"),
    ],
)
def test_cli_refuses_a_bad_insect_in_one_line(tmp_path: Path, capsys, text: str, message: str):
    path = tmp_path / "bad.yaml"
    path.write_text(text, encoding="utf-8")
    base = ["--insect", str(path), "--out", str(tmp_path / "out")]
    for argv in (
        ["optimize", "--task", "level", "--speed", "1", "--method", "pso", "--budget", "16",
         "--seeds", "0", *base],
        ["study", "speed", "--preset", "quick", *base],
    ):  # fmt: skip
        with pytest.raises(SystemExit) as stop:
            main(argv)
        assert stop.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()[-1]
        assert "error:" in err and re.search(message, err)
    assert not (tmp_path / "out").exists()  # before any work
    with pytest.raises(ValueError, match=message):
        parse_config(build_parser(), ["--algo", "sac", "--env", LEVEL_ID, "--insect", str(path)])


def test_train_insect_goes_into_env_kwargs() -> None:
    config = parse_config(
        build_parser(), ["--algo", "sac", "--env", LEVEL_ID, "--insect", str(EXAMPLE)]
    )
    assert config.env_kwargs["insect"] == insect_mapping(load_insect(EXAMPLE))
    assert config.to_dict()["env_kwargs"]["insect"] == insect_mapping(load_insect(EXAMPLE))


def test_optimize_records_say_which_insect(tmp_path: Path, capsys) -> None:
    argv = ["optimize", "--task", "level", "--speed", "1", "--method", "random", "--budget", "8",
            "--swarm-size", "8", "--seeds", "0", "--out", str(tmp_path), "--insect", str(EXAMPLE),
            "--env-kwargs", "n_blade=6", "n_time=32"]  # fmt: skip
    assert main(argv) == 0
    assert "insect: the paper's specimen but" in capsys.readouterr().err
    (record,) = RecordStore(tmp_path).records()
    expected = insect_mapping(load_insect(EXAMPLE))
    assert to_jsonable(record.job.env("insect")) == expected
    assert record.config["env"]["insect"]["body_mass"] == pytest.approx(411.4e-6)
    with open(tmp_path / "summary.csv", newline="", encoding="utf-8") as handle:
        (row,) = list(csv.DictReader(handle))
    assert json.loads(row["insect"]) == expected
