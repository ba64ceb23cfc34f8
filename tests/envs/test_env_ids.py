"""An unknown env id is refused with the list of valid ones, wherever an id is taken."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

from tandem_env.envs import check_env_id, env_ids, make_sb3_vec_env

VALID = r"allowed: TandemWing/LevelFlight-v0, TandemWing/Accelerate-v0, TandemWing/SpeedChange-v0$"


@pytest.mark.parametrize("bad", ["TandemWing/Levelflight-v0", "CartPole-v1", "", None, 3])
def test_check_env_id_lists_the_ids(bad) -> None:
    with pytest.raises(ValueError, match=f"^env_id = {bad!r} is not a tandem-wing env; {VALID}"):
        check_env_id(bad)
    with pytest.raises(ValueError, match=VALID):
        make_sb3_vec_env(bad)  # type: ignore[arg-type]


def test_train_and_envelope_list_the_ids(capsys: pytest.CaptureFixture[str]) -> None:
    from agents.tasks import task_of
    from train.__main__ import main
    from train.config import TrainConfig

    with pytest.raises(ValueError, match=f"^env = 'Foo-v0' is not a tandem-wing env; {VALID}"):
        TrainConfig(algo="ppo", env_id="Foo-v0")
    with pytest.raises(SystemExit):
        main(["--algo", "ppo", "--env", "Foo-v0"])
    assert "allowed: TandemWing/LevelFlight-v0, TandemWing/Accelerate-v0" in capsys.readouterr().err
    with pytest.raises(
        ValueError, match="allowed: TandemWing/LevelFlight-v0, TandemWing/Accelerate-v0"
    ):
        task_of("Foo-v0")  # the harness's (one-cycle) tasks
    assert env_ids() == (
        "TandemWing/LevelFlight-v0",
        "TandemWing/Accelerate-v0",
        "TandemWing/SpeedChange-v0",
    )


@pytest.mark.parametrize("mode", list(AutoresetMode))
def test_vector_env_reports_its_autoreset_mode(mode: AutoresetMode) -> None:
    envs = gym.make_vec(env_ids()[0], num_envs=np.int64(2), autoreset_mode=mode.value)
    assert envs.metadata["autoreset_mode"] is mode
    assert type(envs).metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP  # class default
