"""A reported optimum survives the env's own action type: every record's stroke, stepped
through a fresh env as a float32 action (the action space's dtype, what an SB3 policy outputs),
is the stroke the record reports, with its feasibility and objective.

By default this runs a subset of the quick preset (one seed of level flight at 1.5 m/s, on
the lift band's edge, and of accelerating flight at 90 W/kg, on the power limit) and replays
its records. ``TANDEM_REPLAY_STORE=DIR`` replays every record stored in DIR instead (e.g. the
whole quick preset: ``python -m eval study all --out DIR`` first)."""

from __future__ import annotations

import os
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import tandem_env  # noqa: F401 - registers the envs
from agents.records import Record
from agents.runner import run_jobs
from agents.store import RecordStore
from eval.studies.base import StudyPlan
from eval.studies.presets import QUICK


def replay(record: Record) -> dict:
    """The record's stroke stepped once through a fresh single env as a float32 action."""
    kwargs = {k: v for k, v in record.job.env_kwargs}
    env = gym.make(record.env_id, disable_env_checker=True, **kwargs)
    try:
        env.reset(seed=record.seed, options={record.condition.name: record.condition.value})
        action = np.asarray(record.normalised_stroke, dtype=env.action_space.dtype)
        assert action.dtype == np.float32
        _, reward, _, _, info = env.step(action)
    finally:
        env.close()
    return {"reward": float(reward), **info}


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    given = os.environ.get("TANDEM_REPLAY_STORE")
    if given:
        return Path(given)
    out = tmp_path_factory.mktemp("quick-subset")
    plan = StudyPlan(QUICK)
    jobs = [
        *plan.jobs("level", [1.5], seeds=[0]),
        *plan.jobs("accelerate", [90.0], objective="vertical", seeds=[0]),
    ]
    run_jobs(jobs, out, progress=False)
    return out


def test_every_record_is_feasible_as_a_float32_action(store: Path) -> None:
    records = RecordStore(store).records()
    assert records, f"no records in {store}"
    failures = []
    for record in records:
        stroke = np.asarray(record.normalised_stroke)
        # the stroke is one the action type carries, so the cast changes nothing
        assert np.array_equal(stroke.astype(np.float32).astype(np.float64), stroke)
        again = replay(record)
        if not (again["feasible"] == record.feasible and again["objective"] == record.objective):
            failures.append(
                f"{record.label()}: replayed feasible {again['feasible']}, objective "
                f"{again['objective']!r}; recorded {record.feasible}, {record.objective!r}"
            )
    assert not failures, "\n".join(failures)
    assert all(r.feasible for r in records), [r.label() for r in records if not r.feasible]
