"""A task is declared once, in its env module, and read everywhere.

A toy task declared in ONE file (``toy_task.py``: declaration, config, core, vector env, single
env) plus one registration line passes Gymnasium's env checker and runs through the harness and
through ``python -m eval optimize``, whose ``--cruise-speed`` option and help come from the
declaration; bad declarations fail when declared, and old names are refused naming the new.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Literal

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.envs.registration import registry
from gymnasium.utils.env_checker import check_env

from agents.harness import run
from agents.store import read_record
from agents.tasks import (
    ACCELERATE_TASK,
    LEVEL_TASK,
    STROKE_DISCRETE,
    Condition,
    TaskSpec,
    available_tasks,
    get_task,
)
from tandem_env.envs import (
    ACCELERATE_ID,
    LEVEL_FLIGHT_ID,
    SPEED_CHANGE_ID,
    AccelerateConfig,
    FlightConfig,
    LevelFlightConfig,
    TaskCondition,
    TaskDeclaration,
    TaskObjectives,
    registration,
)
from tandem_env.envs.declaration import POWER_CAP
from tandem_env.envs.registration import (
    add_entry,
    check_env_id,
    config_class,
    env_ids,
    remove_entry,
)

sys.path.insert(0, str(Path(__file__).parent))
from toy_task import TOY_ENTRY, TOY_ID, CruiseConfig


@pytest.fixture()
def toy() -> Iterator[TaskSpec]:
    """The toy task, registered in one line; unregistered afterwards."""
    add_entry(TOY_ID, TOY_ENTRY)  # the one registration line
    yield get_task("cruise-toy")
    remove_entry(TOY_ID)


def test_the_package_tasks_are_read_from_the_env_declarations() -> None:
    assert registration.task_env_ids() == {"level": LEVEL_FLIGHT_ID, "accelerate": ACCELERATE_ID}
    level, accelerate = LEVEL_TASK.declared_condition, ACCELERATE_TASK.declared_condition
    assert (level.keyword, level.unit) == ("speed", "m/s")
    assert LEVEL_TASK.condition(1.5) == Condition("speed", 1.5, "m/s")
    assert dict(LEVEL_TASK.declared_objectives.metrics) == {"efficiency": "efficiency"}
    assert LEVEL_TASK.declared_objectives.keyword is None
    assert LEVEL_TASK.forbidden_kwargs == ("speed", "speed_range")
    # One name for Accelerate's condition: keyword, reset option, info key, record name.
    assert (accelerate.keyword, accelerate.unit) == ("available_power", "W/kg")
    assert ACCELERATE_TASK.condition(2.0) == Condition("available_power", 2.0, "W/kg")
    assert ACCELERATE_TASK.condition_flag == "--power"  # the command line keeps --power
    assert dict(ACCELERATE_TASK.declared_objectives.metrics) == {
        "vertical": "excess_vertical",
        "horizontal": "excess_horizontal",
        "resultant": "excess_total",
        "horizontal_literal": "excess_horizontal_literal",
    }
    objectives = ACCELERATE_TASK.declared_objectives
    assert (objectives.default, objectives.keyword) == ("vertical", "objective")
    assert ACCELERATE_TASK.forbidden_kwargs == ("available_power", "available_power_range")
    assert LEVEL_TASK.discrete_actions == ACCELERATE_TASK.discrete_actions == STROKE_DISCRETE
    assert config_class(LEVEL_FLIGHT_ID) is LevelFlightConfig
    # The spec is a view of the declaration, not a copy.
    assert LEVEL_TASK.declaration is LevelFlightConfig.DECLARATION
    assert ACCELERATE_TASK.declaration is AccelerateConfig.DECLARATION
    assert AccelerateConfig.CONDITION is ACCELERATE_TASK.declaration.condition


def test_the_registries_are_read_when_asked() -> None:
    """A task added after import is an env id, a harness task and a training env at once, and
    gone again once removed: nothing keeps a copy."""
    from eval.studies.presets import QUICK
    from train.config import TrainConfig

    own = (LEVEL_FLIGHT_ID, ACCELERATE_ID, SPEED_CHANGE_ID)
    assert env_ids() == own and "cruise-toy" not in available_tasks()
    add_entry(TOY_ID, TOY_ENTRY)
    try:
        assert env_ids() == (*own, TOY_ID) and check_env_id(TOY_ID) == TOY_ID
        assert get_task("cruise-toy").declaration is CruiseConfig.DECLARATION
        assert registration.task_env_ids()["cruise-toy"] == TOY_ID
        assert "cruise_speed" in registration.condition_keywords()
        assert TrainConfig(algo="ppo", env_id=TOY_ID).env_id == TOY_ID
        with pytest.raises(ValueError, match="task 'cruise-toy' already runs TandemToy/Cruise"):
            add_entry("TandemToy/Other-v0", TOY_ENTRY)
        # A study preset budgets the tasks it runs and names them for any other.
        assert QUICK.budgets == {"level": 8_000, "accelerate": 4_000}
        with pytest.raises(
            ValueError,
            match="Preset 'quick' has no budget for task 'cruise-toy'; allowed: "
            "'level', 'accelerate'",
        ):
            QUICK.budget("cruise-toy")
    finally:
        remove_entry(TOY_ID)
    assert env_ids() == own and TOY_ID not in registry
    with pytest.raises(ValueError, match=r"unknown task 'cruise-toy'; allowed: 'level', 'acc"):
        get_task("cruise-toy")
    with pytest.raises(ValueError, match="is not a tandem-wing env"):
        check_env_id(TOY_ID)
    with pytest.raises(ValueError, match="allowed: an id added by add_entry"):
        remove_entry(LEVEL_FLIGHT_ID)


def test_the_specimen_power_is_derived_from_the_insect() -> None:
    from tandem_env import Dragonfly

    insect = Dragonfly()
    top = insect.flight_muscle_ratio * insect.muscle_specific_power
    condition = AccelerateConfig.CONDITION
    assert condition.default == condition.envelope[1] == condition.sweep[-1] == top == 90.0


def test_the_config_reads_its_declaration() -> None:
    level = LevelFlightConfig()
    assert level.speed == LevelFlightConfig.CONDITION.default == 1.5
    assert level.envelope == level.speed_envelope == LevelFlightConfig.CONDITION.envelope
    assert level.condition_key == "speed" and level.objective_metric == "efficiency"
    accelerate = AccelerateConfig(available_power_range=(60.0, 80.0), objective="horizontal")
    assert accelerate.condition_range == (60.0, 80.0) and accelerate.fixed_condition is None
    assert accelerate.condition_key == "available_power"
    assert accelerate.objective_metric == "excess_horizontal"
    assert accelerate.describe().startswith("P_avail ~ U(60, 80) W/kg")


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("power", "available_power"),
        ("power_range", "available_power_range"),
        ("power_envelope", "available_power_envelope"),
    ],
)
def test_old_names_are_refused_naming_the_new(old: str, new: str) -> None:
    value = (50.0, 90.0) if old != "power" else 60.0
    with pytest.raises(ValueError, match=f"'{old}' was renamed; use '{new}'"):
        gym.make(ACCELERATE_ID, **{old: value})
    env = gym.make(ACCELERATE_ID)
    with pytest.raises(ValueError, match="reset option 'power' was renamed; use 'available_power'"):
        env.reset(options={"power": 60.0})


def test_the_toy_task_passes_the_env_checker_in_both_front_ends(toy: TaskSpec) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(TOY_ID, cruise_speed_range=(0.5, 1.5))
        check_env(env.unwrapped, skip_render_check=False)
    assert isinstance(env.unwrapped.config, CruiseConfig)
    # The single env is the vector env at B = 1: the same stroke, the same info.
    action = np.full(28, 0.1)
    vector = gym.make_vec(TOY_ID, num_envs=3, vectorization_mode="vector_entry_point")
    vector.reset(seed=0, options={"cruise_speed": 0.75})
    _, rewards, terminated, _, infos = vector.step(np.tile(action, (3, 1)))
    env.reset(options={"cruise_speed": 0.75})
    _, reward, done, _, info = env.step(action)
    assert done and terminated.all() and rewards[0] == reward == rewards[2]
    assert info["lift_deficit"] == infos["lift_deficit"][0] and "lift_violation" not in info
    assert info["objective"] == info["excess_horizontal"]
    with pytest.raises(gym.error.ResetNeeded):
        env.step(action)


def test_a_new_task_runs_through_the_harness(toy: TaskSpec) -> None:
    assert toy.declared_condition.keyword == toy.condition(1.0).name == "cruise_speed"
    assert toy.forbidden_kwargs == ("cruise_speed", "cruise_speed_range")
    assert toy.discrete_actions == STROKE_DISCRETE  # a flight env: its actions are strokes
    assert toy.declaration is CruiseConfig.DECLARATION
    small = {"n_time": 16, "n_blade": 4}
    (record,) = run("random", "cruise-toy", 1.2, 16, [0], env_kwargs=small, progress=False)
    assert record.condition.to_dict() == {"name": "cruise_speed", "value": 1.2, "unit": "m/s"}
    assert record.objective_name == "excess_horizontal"
    assert record.metrics["speed"] == 1.2  # the re-evaluation ran at the condition
    with pytest.raises(ValueError, match="cruise_speed_range"):
        run("random", "cruise-toy", 1.0, 8, [0], env_kwargs={"cruise_speed_range": (0.5, 1)})
    with pytest.raises(ValueError, match=r"CruiseConfig.cruise_speed = 1.9 m/s; allowed.*envelope"):
        run("random", "cruise-toy", 1.9, 8, [0], env_kwargs=small, progress=False)


def test_eval_optimize_takes_the_new_condition(toy: TaskSpec, tmp_path, capsys) -> None:
    from eval.__main__ import build_parser, main

    help_text = build_parser()._subparsers._group_actions[0].choices["optimize"].format_help()
    assert "--cruise-speed V_c" in help_text and "cruise-toy: cruise speed [m/s]" in help_text
    words = " ".join(help_text.split())
    assert "Toy cruise: maximise the thrust surplus" in words  # the declaration's summary
    out = tmp_path / "toy"
    argv = ["optimize", "--task", "cruise-toy", "--cruise-speed", "0.8", "--method", "random"]
    argv += ["--budget", "8", "--seeds", "0", "--out", str(out), "--quiet"]
    argv += ["--env-kwargs", "n_time=16", "n_blade=4"]
    assert main(argv) == 0
    (path,) = (out / "records").glob("*.json")
    record = read_record(path)
    assert record.condition.to_dict() == {"name": "cruise_speed", "value": 0.8, "unit": "m/s"}
    for wrong, message in (
        (["--speed", "1"], "--task cruise-toy takes --cruise-speed V_c [m/s], not --speed"),
        (["--cruise-speed", "1", "--objective", "vertical"], "cruise-toy maximises surplus"),
    ):
        with pytest.raises(SystemExit):
            main(["optimize", "--task", "cruise-toy", *wrong, *argv[5:]])
        assert message in capsys.readouterr().err
    # The paper's tasks keep their documented options.
    with pytest.raises(SystemExit):
        main(["optimize", "--task", "level", "--cruise-speed", "1", *argv[5:]])
    assert "--task level takes --speed V [m/s], not --cruise-speed" in capsys.readouterr().err


# --- bad declarations ---------------------------------------------------------------------------
GOOD = dict(
    keyword="climb",
    label="climb rate",
    symbol="w",
    unit="m/s",
    limits=(-5.0, 5.0),
    default=0.0,
    envelope=(-1.0, 1.0),
    sweep=(-1.0, 0.0, 1.0),
)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"keyword": "climb rate"}, "TaskCondition.keyword = 'climb rate'; allowed: a Python"),
        ({"option": "climb rate"}, "TaskCondition.option = 'climb rate'"),
        ({"former_keyword": ""}, "TaskCondition.former_keyword = ''"),
        ({"unit": " "}, "TaskCondition.unit = ' '; allowed: a non-empty string"),
        ({"limits": (5.0, -5.0)}, r"TaskCondition.limits = \(5.0, -5.0\); allowed: .*low < high"),
        ({"envelope": (-6.0, 1.0)}, r"envelope = \(-6.0, 1.0\) m/s; allowed: inside limits"),
        ({"default": 2.0}, r"default = 2.0 m/s; allowed: a number inside envelope"),
        ({"default": "0"}, r"default = '0' m/s"),
        ({"sweep": (0.0, -1.0)}, r"sweep = \(0.0, -1.0\); allowed: a non-empty, increasing"),
        ({"sweep": ()}, r"sweep = \(\); allowed"),
        ({"sweep": (0.0, 3.0)}, "inside envelope"),
    ],
)
def test_a_bad_condition_is_refused_naming_it(change: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        TaskCondition(**{**GOOD, **change})


def test_bad_objectives_are_refused_naming_them() -> None:
    with pytest.raises(ValueError, match="default = 'up'; allowed: one of 'climb'"):
        TaskObjectives(metrics={"climb": "climb_rate"}, default="up")
    with pytest.raises(ValueError, match=r"2 objectives .* but no keyword"):
        TaskObjectives(metrics={"a": "x", "b": "y"}, default="a")
    with pytest.raises(ValueError, match=r"metrics = \{\}; allowed: a non-empty mapping"):
        TaskObjectives(metrics={}, default="a")
    with pytest.raises(ValueError, match=r"metrics\['a'\].metric = 'x y'"):
        TaskObjectives(metrics={"a": "x y"}, default="a")


def test_a_config_missing_the_declared_fields_fails_when_defined() -> None:
    with pytest.raises(
        TypeError, match=r"ClimbConfig declares the condition 'climb'.*'climb_range'"
    ):

        @dataclass(frozen=True, kw_only=True)
        class ClimbConfig(FlightConfig):
            DECLARATION: ClassVar[TaskDeclaration] = _declaration()
            climb: float | None = None

    with pytest.raises(TypeError, match=r"condition = .*objectives = None; allowed: a"):
        TaskDeclaration("Half", "half", (POWER_CAP,), condition=TaskCondition(**GOOD))
    with pytest.raises(TypeError, match=r"DECLARATION = 3; allowed: a TaskDeclaration"):

        class NotAConfig(FlightConfig):
            DECLARATION: ClassVar[Any] = 3

    with pytest.raises(TypeError, match=r"constraints = \[.*\]; allowed: a tuple of Constraint"):
        TaskDeclaration("List", "list", [POWER_CAP])  # type: ignore[arg-type]


def _declaration(**objectives: Any) -> TaskDeclaration:
    return TaskDeclaration(
        name="Climb",
        summary="climb",
        constraints=(POWER_CAP,),
        condition=TaskCondition(**GOOD),
        objectives=TaskObjectives(
            **(objectives or {"metrics": {"efficiency": "efficiency"}, "default": "efficiency"})
        ),
    )


def test_objective_choices_must_match_the_literal() -> None:
    with pytest.raises(TypeError, match=r"objective is typed .*Literal.* but OBJECTIVES declares"):

        @dataclass(frozen=True, kw_only=True)
        class TwoObjectives(FlightConfig):
            DECLARATION: ClassVar[TaskDeclaration] = _declaration(
                metrics={"vertical": "excess_vertical", "horizontal": "excess_horizontal"},
                default="vertical",
                keyword="objective",
            )
            climb: float | None = None
            climb_range: tuple[float, float] | None = None
            climb_envelope: tuple[float, float] = (-1.0, 1.0)
            objective: Literal["vertical", "resultant"] = "vertical"


def test_from_env_names_what_is_missing() -> None:
    with pytest.raises(ValueError, match=r"SpeedChangeConfig declares DECLARATION = .*SpeedChange"):
        TaskSpec.from_env("speed-change", SPEED_CHANGE_ID)
    with pytest.raises(ValueError, match="'Nope/Nothing-v0' is not registered"):
        TaskSpec.from_env("nothing", "Nope/Nothing-v0")
