"""A task's condition and objectives are declared once, on its env config, and read everywhere.

A toy task (a new config class, env and vector env, nothing added to agents/ or eval/) runs
through the harness and through ``python -m eval optimize``, whose ``--offset`` option and
help come from the declaration; bad declarations fail when declared, naming what is wrong.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.envs.registration import register, registry
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

import agents.tasks as tasks
from agents.harness import run
from agents.records import Record
from agents.tasks import ACCELERATE, LEVEL, STROKE_DISCRETE, TaskSpec, get_task, register_task
from tandem_env.envs import ACCELERATE_ID, LEVEL_FLIGHT_ID, SPEED_CHANGE_ID
from tandem_env.envs.condition import TaskCondition, TaskObjectives
from tandem_env.envs.config import (
    AccelerateConfig,
    FlightConfig,
    LevelFlightConfig,
    normalise_condition,
)
from tandem_env.envs.registration import TASK_ENV_IDS, config_class

TOY_ID = "DeclarationTest/Offset-v0"
DIM = 4


@dataclass(frozen=True, kw_only=True)
class OffsetConfig:
    """Toy task: bring every coordinate of the action to the offset c."""

    CONDITION: ClassVar[TaskCondition] = TaskCondition(
        keyword="offset",
        info_key="offset",
        label="target offset",
        symbol="c",
        unit="-",
        limits=(-1.0, 1.0),
        default=0.25,
        envelope=(-0.5, 0.5),
        sweep=(-0.5, 0.0, 0.5),
    )
    OBJECTIVES: ClassVar[TaskObjectives] = TaskObjectives(
        metrics={"closeness": "closeness"}, default="closeness"
    )

    offset: float | None = None
    offset_range: tuple[float, float] | None = None
    offset_envelope: tuple[float, float] = CONDITION.envelope

    def __post_init__(self) -> None:
        normalise_condition(self)  # type: ignore[arg-type]


class OffsetVectorEnv(VectorEnv):
    """n toy envs in one call: reward = closeness = −|a − c|² (maximum 0 at a = c)."""

    metadata = {"autoreset_mode": AutoresetMode.DISABLED}  # noqa: RUF012
    config_class = OffsetConfig

    def __init__(self, num_envs: int = 1, autoreset_mode: str = "Disabled", **kwargs: Any):
        self.config = OffsetConfig(**kwargs)
        self.num_envs = num_envs
        self.single_action_space = spaces.Box(-1.0, 1.0, (DIM,), dtype=np.float32)
        self.single_observation_space = spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.offsets: list[float] = []
        self._offset = float(self.config.offset)

    def reset(self, *, seed: Any = None, options: dict[str, Any] | None = None):
        key = OffsetConfig.CONDITION.reset_option
        self._offset = float((options or {}).get(key, self.config.offset))
        self.offsets.append(self._offset)
        n = self.num_envs
        return np.full((n, 1), self._offset, np.float32), {"offset": np.full(n, self._offset)}

    def step(self, actions: np.ndarray):
        n = self.num_envs
        closeness = -np.sum((np.asarray(actions, dtype=np.float64) - self._offset) ** 2, axis=1)
        infos = {
            "closeness": closeness,
            "objective": closeness,
            "feasible": np.ones(n, dtype=bool),
            "offset": np.full(n, self._offset),
        }
        obs = np.zeros((n, 1), np.float32)
        return obs, closeness, np.ones(n, bool), np.zeros(n, bool), infos


class OffsetEnv(gym.Env):
    """The toy task, one env (the vector env at n = 1)."""

    metadata = {"render_modes": []}  # noqa: RUF012
    config_class = OffsetConfig

    def __init__(self, **kwargs: Any) -> None:
        self._batch = OffsetVectorEnv(1, **kwargs)
        self.config = self._batch.config
        self.action_space = self._batch.single_action_space
        self.observation_space = self._batch.single_observation_space

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        obs, info = self._batch.reset(options=options)
        return obs[0], {k: v[0].item() for k, v in info.items()}

    def step(self, action: np.ndarray):
        obs, reward, _, _, info = self._batch.step(np.asarray(action)[None, :])
        return obs[0], float(reward[0]), True, False, {k: v[0].item() for k, v in info.items()}


@pytest.fixture()
def toy(monkeypatch: pytest.MonkeyPatch) -> TaskSpec:
    """The toy task registered like the package's own: a gym id and ``from_env``."""
    if TOY_ID not in registry:
        register(id=TOY_ID, entry_point=OffsetEnv, vector_entry_point=OffsetVectorEnv)
    monkeypatch.setattr(tasks, "_TASKS", dict(tasks._TASKS))  # unregistered afterwards
    spec = TaskSpec.from_env("offset-toy", TOY_ID)
    register_task(spec)
    return spec


def test_the_package_tasks_are_built_from_the_env_configs() -> None:
    assert TASK_ENV_IDS == {"level": LEVEL_FLIGHT_ID, "accelerate": ACCELERATE_ID}
    # What the hand-written specs said before, now read from the declarations.
    assert (LEVEL.condition_name, LEVEL.condition_unit) == ("speed", "m/s")
    assert (LEVEL.condition_kwarg, LEVEL.reset_option) == ("speed", "speed")
    assert dict(LEVEL.objectives) == {"efficiency": "efficiency"}
    assert (LEVEL.objective_kwarg, LEVEL.forbidden_kwargs) == (None, ("speed", "speed_range"))
    assert (ACCELERATE.condition_name, ACCELERATE.condition_unit) == ("available_power", "W/kg")
    assert (ACCELERATE.condition_kwarg, ACCELERATE.reset_option) == ("power", "power")
    assert dict(ACCELERATE.objectives) == {
        "vertical": "excess_vertical",
        "horizontal": "excess_horizontal",
        "resultant": "excess_total",
        "horizontal_literal": "excess_horizontal_literal",
    }
    assert (ACCELERATE.default_objective, ACCELERATE.objective_kwarg) == ("vertical", "objective")
    assert ACCELERATE.forbidden_kwargs == ("power", "power_range")
    assert LEVEL.discrete_actions == ACCELERATE.discrete_actions == STROKE_DISCRETE
    assert config_class(LEVEL_FLIGHT_ID) is LevelFlightConfig
    assert LEVEL.declaration is LevelFlightConfig.CONDITION
    assert ACCELERATE.declaration is AccelerateConfig.CONDITION


def test_the_config_reads_its_declaration() -> None:
    level = LevelFlightConfig()
    assert level.speed == LevelFlightConfig.CONDITION.default == 1.5
    assert level.envelope == level.speed_envelope == LevelFlightConfig.CONDITION.envelope
    assert level.condition_key == "speed" and level.objective_metric == "efficiency"
    accelerate = AccelerateConfig(power_range=(60.0, 80.0), objective="horizontal")
    assert accelerate.condition_range == (60.0, 80.0) and accelerate.fixed_condition is None
    assert accelerate.condition_key == "available_power"
    assert accelerate.objective_metric == "excess_horizontal"
    assert accelerate.describe().startswith("P_avail ~ U(60, 80) W/kg")


def test_a_new_task_runs_through_the_harness(toy: TaskSpec) -> None:
    assert (toy.condition_name, toy.condition_kwarg, toy.reset_option) == ("offset",) * 3
    assert toy.forbidden_kwargs == ("offset", "offset_range")
    assert toy.discrete_actions == ()  # not a flight env: its actions are not strokes
    assert get_task("offset-toy") is toy
    (record,) = run("random", "offset-toy", 0.2, 64, [0], progress=False)
    assert record.condition.to_dict() == {"name": "offset", "value": 0.2, "unit": "-"}
    assert record.objective_name == "closeness"
    # The re-evaluation ran at the condition, so the reward is −|a − 0.2|².
    action = np.array(record.normalised_stroke, dtype=np.float64)
    assert record.metrics["offset"] == 0.2
    assert record.reward == pytest.approx(-np.sum((action - 0.2) ** 2))
    with pytest.raises(ValueError, match="offset_range"):
        run("random", "offset-toy", 0.2, 8, [0], env_kwargs={"offset_range": (0, 0.1)})
    with pytest.raises(ValueError, match=r"OffsetConfig.offset = 0.9 -; allowed.*offset_envelope"):
        run("random", "offset-toy", 0.9, 8, [0], progress=False)


def test_eval_optimize_takes_the_new_condition(toy: TaskSpec, tmp_path, capsys) -> None:
    from eval.__main__ import build_parser, main

    help_text = build_parser()._subparsers._group_actions[0].choices["optimize"].format_help()
    assert "--offset c" in help_text and "offset-toy: target offset [-]" in help_text
    assert "Toy task: bring every coordinate" in help_text  # the config's docstring
    out = tmp_path / "toy"
    argv = ["optimize", "--task", "offset-toy", "--offset", "-0.1", "--method", "random"]
    argv += ["--budget", "16", "--seeds", "0", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    (path,) = (out / "records").glob("*.json")
    record = Record.load(path)
    assert record.condition.to_dict() == {"name": "offset", "value": -0.1, "unit": "-"}
    for wrong, message in (
        (["--speed", "1"], "--task offset-toy takes --offset c [-], not --speed"),
        (["--offset", "0", "--objective", "vertical"], "offset-toy maximises closeness"),
    ):
        with pytest.raises(SystemExit):
            main(["optimize", "--task", "offset-toy", *wrong, *argv[5:]])
        assert message in capsys.readouterr().err
    # The paper's tasks keep their documented options.
    with pytest.raises(SystemExit):
        main(["optimize", "--task", "level", "--offset", "0", *argv[5:]])
    assert "--task level takes --speed V [m/s], not --offset" in capsys.readouterr().err


# --- bad declarations ---------------------------------------------------------------------------
GOOD = dict(
    keyword="climb",
    info_key="climb_rate",
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
        ({"info_key": ""}, "TaskCondition.info_key = ''"),
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
            CONDITION: ClassVar[TaskCondition] = TaskCondition(**GOOD)
            OBJECTIVES: ClassVar[TaskObjectives] = TaskObjectives(
                metrics={"efficiency": "efficiency"}, default="efficiency"
            )
            climb: float | None = None

    with pytest.raises(TypeError, match=r"CONDITION = .*OBJECTIVES = None; allowed: a"):

        class HalfConfig(FlightConfig):
            CONDITION: ClassVar[TaskCondition] = TaskCondition(**GOOD)


def test_objective_choices_must_match_the_literal() -> None:
    with pytest.raises(TypeError, match=r"objective is typed .*Literal.* but OBJECTIVES declares"):

        @dataclass(frozen=True, kw_only=True)
        class TwoObjectives(AccelerateConfig):
            OBJECTIVES: ClassVar[TaskObjectives] = TaskObjectives(
                metrics={"vertical": "excess_vertical", "horizontal": "excess_horizontal"},
                default="vertical",
                keyword="objective",
            )


def test_from_env_names_what_is_missing() -> None:
    with pytest.raises(ValueError, match="SpeedChangeConfig declares CONDITION = None"):
        TaskSpec.from_env("speed-change", SPEED_CHANGE_ID)
    with pytest.raises(ValueError, match="'Nope/Nothing-v0' is not registered"):
        TaskSpec.from_env("nothing", "Nope/Nothing-v0")
