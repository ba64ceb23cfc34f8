"""The SpeedChange baselines of ``python -m eval speed-change``: the steady-optimum schedule from
the harness (cached), episodes flown on fixed seeds, their metrics, and the command end to end."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

import agents.harness
from agents.store import read_record_files
from eval import speed_change as module
from eval.__main__ import main
from eval.speed_change import (
    RandomPolicy,
    SteadyPolicy,
    episode_metrics,
    policy_summary_rows,
    run_episodes,
    steady_optima,
)
from tandem_env.envs import SpeedChangeConfig

SEEDS = [1000, 1001, 1002]
SHORT = {"max_cycles": 6}


def test_steady_optima_come_from_the_harness_and_are_cached(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = SpeedChangeConfig()
    assert module.level_kwargs(config) == {"thrust_split": "body"}
    policy = steady_optima(
        config, speeds=(0.5, 1.5), method="pso", budget=40, cache_dir=tmp_path, progress=False
    )
    assert policy.actions.shape == (2, 28) and np.all(np.abs(policy.actions) <= 1.0)
    records = read_record_files([tmp_path])
    assert sorted(r.condition.value for r in records) == [0.5, 1.5]
    assert all(r.task == "level" and r.budget == 40 for r in records)
    assert all(r.config["env"]["options"]["thrust_split"] == "body" for r in records)

    def no_search(*args, **kwargs):
        raise AssertionError("the stored optimum was searched again")

    monkeypatch.setattr(agents.harness, "run_job", no_search)
    again = steady_optima(
        config, speeds=(1.5, 0.5), method="pso", budget=40, cache_dir=tmp_path, progress=False
    )
    np.testing.assert_array_equal(again.actions, policy.actions[::-1])


def test_steady_policy_plays_the_optimum_nearest_the_target() -> None:
    actions = np.stack([np.full(28, -0.5), np.full(28, 0.5)])
    policy = SteadyPolicy(np.array([0.5, 1.5]), actions)
    envs = module.gym.make_vec("TandemWing/SpeedChange-v0", num_envs=3)
    observations, _ = envs.reset(
        seed=0, options={"target_speed": 0.9}
    )  # every sub-env: u* = 0.9 m/s, nearer 0.5
    chosen = policy.act(observations, envs.unwrapped.flight)
    np.testing.assert_array_equal(chosen, np.repeat(actions[:1], 3, axis=0))


def test_episodes_use_the_seeds_and_log_the_first_episode_of_each() -> None:
    logs = run_episodes(RandomPolicy(seed=0), SEEDS, SHORT)
    other = run_episodes(RandomPolicy(seed=1), SEEDS, SHORT)
    for log, again in zip(logs, other, strict=True):
        # same seed, same episode: start and target speeds do not depend on the policy
        assert log.forward_speed[0] == again.forward_speed[0]
        assert log.target_speed == again.target_speed
        assert 1 <= log.reward.size <= 6 and log.time.size == log.reward.size + 1
        assert log.reward.size == 6 or log.terminated  # ended early only by leaving a band
        assert sum(log.terms.values()) == pytest.approx(log.reward.sum(), rel=1e-12)


def test_episode_metrics() -> None:
    log = module.EpisodeLog(
        policy="p",
        seed=0,
        target_speed=1.0,
        time=np.array([0.0, 0.03, 0.06, 0.09]),
        forward_speed=np.array([0.5, 0.8, 0.97, 1.1]),
        altitude=np.array([0.0, 0.002, -0.004, 0.006]),
        distance=np.array([0.0, 0.02, 0.05, 0.08]),
        power_per_mass=np.array([50.0, 60.0, 70.0]),
        energy=np.array([1e-4, 2e-4, 3e-4]),
        reward=np.array([-0.1, -0.2, -0.3]),
        terminated=False,
    )
    m = episode_metrics(log)
    assert m["time_to_target_s"] == 0.06  # 0.97 is within 5 % of 1.0, 0.8 is not
    assert m["energy_per_metre_mJ_m"] == pytest.approx(1e3 * 6e-4 / 0.08)
    assert m["mean_abs_altitude_mm"] == pytest.approx(4.0)
    assert m["return"] == pytest.approx(-0.6) and m["cycles"] == 3
    assert m["final_speed_error_m_s"] == pytest.approx(0.1)
    row = policy_summary_rows([m, {**m, "time_to_target_s": float("nan"), "return": -1.6}])[0]
    assert row["reached_share"] == 0.5 and row["time_to_target_median_s"] == 0.06
    assert row["return_mean"] == pytest.approx(-1.1) and row["return_std"] == pytest.approx(0.5)


def test_command_writes_tables_and_the_figure(tmp_path: Path) -> None:
    figure = tmp_path / "episode.png"
    status = main(
        [
            "speed-change",
            "--episodes",
            "2",
            "--optimiser",
            "pso",
            "--optima-budget",
            "40",
            "--grid",
            "0.5",
            "1.5",
            "--out",
            str(tmp_path),
            "--figure",
            str(figure),
            "--quiet",
        ]
    )
    assert status == 0
    with (tmp_path / "episodes.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    assert [r["policy"] for r in rows] == ["random", "random", "steady", "steady"]
    assert (tmp_path / "summary.md").read_text().startswith("| policy |")
    assert figure.stat().st_size > 10_000


def test_command_rejects_a_folder_that_is_no_training_run(tmp_path: Path) -> None:
    with pytest.raises(SystemExit):
        main(["speed-change", "--ppo", str(tmp_path), "--out", str(tmp_path), "--quiet"])
