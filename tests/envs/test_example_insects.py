"""Every shipped example YAML's insect (a whole insect file such as
examples/orthetrum_cancellatum.yaml, or the ``insect:`` section of an ``eval measured`` kinematics
file) loads through the public loader, builds the env through ``gym.make(..., insect=...)`` and
flies a stroke; the file's body mass is the env's weight; an example species' derived values
follow the rules its header states."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import tandem_env  # noqa: F401 - registers the envs
from tandem_env.physics.insect import DRAGONFLY, Dragonfly, load_insect

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
FILES = sorted(EXAMPLES.glob("*.yaml"))
LEVEL_ID = "TandemWing/LevelFlight-v0"
SMALL = {"n_blade": 6, "n_time": 32}
CUTICLE_DENSITY = 1200.0  # [kg/m³], docs/model.md §1.4
SPEED = 1.5  # [m/s]


def _insect_source(path: Path) -> Path | dict:
    """What the env's insect= keyword gets for an example: an insect file's path, or the
    ``insect:`` section ({} when absent) of a kinematics file."""
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    if isinstance(data, dict) and "kinematics" in data:
        return data.get("insect", {})
    return path


def _insect_files() -> list[Path]:
    return [path for path in FILES if isinstance(_insect_source(path), Path)]


def _middle_stroke(env: gym.Env) -> np.ndarray:
    """The middle of the normalised action box (a stroke inside Table 4)."""
    return np.zeros(env.action_space.shape, dtype=env.action_space.dtype)


def _lift_to_weight(insect: Dragonfly) -> float:
    env = gym.make(LEVEL_ID, insect=insect, **SMALL)
    env.reset(seed=0, options={"speed": SPEED})
    _, reward, _, _, info = env.step(_middle_stroke(env))
    env.close()
    assert math.isfinite(reward) and abs(info["lift_to_weight"]) > 0.1  # not a vanishing force
    return float(info["lift_to_weight"])


def test_the_examples_are_found() -> None:
    names = {path.name for path in _insect_files()}
    assert {"orthetrum_cancellatum.yaml", "scaled_dragonfly.yaml"} <= names


@pytest.mark.parametrize("path", FILES, ids=lambda path: path.name)
def test_every_example_builds_an_env_and_flies(path: Path) -> None:
    source = _insect_source(path)
    insect = load_insect(source)
    env = gym.make(LEVEL_ID, insect=source, **SMALL)
    assert env.unwrapped.config.insect == insect
    env.reset(seed=0, options={"speed": SPEED})
    _, reward, _, _, info = env.step(_middle_stroke(env))
    env.close()
    assert math.isfinite(reward)
    assert all(math.isfinite(info[key]) for key in ("lift_to_weight", "power", "efficiency"))
    if isinstance(source, Path):  # an insect file describes another insect than the specimen
        assert insect != DRAGONFLY


@pytest.mark.parametrize("path", _insect_files(), ids=lambda path: path.name)
def test_the_files_body_mass_is_the_envs_weight(path: Path) -> None:
    # the wings' forces do not depend on the body's mass, so at one stroke L/W goes as 1/m
    insect = load_insect(path)
    specimen_mass = dataclasses.replace(insect, body_mass=DRAGONFLY.body_mass)
    ratio = _lift_to_weight(insect) / _lift_to_weight(specimen_mass)
    assert ratio == pytest.approx(DRAGONFLY.body_mass / insect.body_mass, rel=1e-9)


def test_orthetrum_follows_its_stated_rules() -> None:
    # the header's rules: thickness = mass / (ρ_cuticle·c̄·R) per wing, root spacing = 1.5
    # fore-wing mean chords; the file gives them rounded to 3 digits
    insect = load_insect(EXAMPLES / "orthetrum_cancellatum.yaml")
    for wing in (insect.fore, insect.hind):
        rule = wing.mass / (CUTICLE_DENSITY * wing.mean_chord * wing.length)
        assert wing.thickness == pytest.approx(rule, rel=2e-3)
    assert insect.root_spacing == pytest.approx(1.5 * insect.fore.mean_chord, rel=2e-3)
    # a libellulid's broad hind-wing: lower aspect ratio than the fore-wing, as in the specimen
    assert insect.hind.aspect_ratio < insect.fore.aspect_ratio
