"""The model's revision (tandem_env.physics.MODEL_REVISION) in every record's key: a record made
by another model is never served, by ``--out`` or the record cache, and is kept on disk; one of
today's model is (docs/harness.md, "The record cache"). The reference table records it too.

tests/conftest.py points the cache at a fresh folder of each test (``record_cache``).
"""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import tandem_env
from agents.jobs import Job
from agents.records import Record, RecordWarning
from agents.runner import run_jobs
from agents.store import read_record
from eval import reference as make_reference
from eval.reference import candidates
from tandem_env.envs import LEVEL_FLIGHT_ID
from tandem_env.envs import reference as table_module
from tandem_env.io.files import write_json_atomic
from tests.runner_calls import count_harness_calls

SMALL = {"n_blade": 6, "n_time": 32}
JOB = Job("pso", "level", 2.0, 16, 0, env_kwargs=SMALL, method_config={"swarm_size": 8})


def test_a_record_of_another_revision_is_not_served_and_is_kept(
    tmp_path: Path, record_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = count_harness_calls(monkeypatch)
    first = run_jobs([JOB], tmp_path / "a", progress=False).records[JOB.key]
    assert first.model == tandem_env.physics.MODEL_REVISION
    # the same model: served from the cache, nothing computed
    assert run_jobs([JOB], tmp_path / "b", progress=False).cached == 1 and len(calls) == 1
    old_key, moved = JOB.key, tandem_env.physics.MODEL_REVISION + 1
    with monkeypatch.context() as patch:
        patch.setattr(tandem_env.physics, "MODEL_REVISION", moved)  # the model's results moved
        assert JOB.key != old_key
        for out, cache in (("c", True), ("a", False)):  # c: the old record in the cache; a: in a
            with pytest.warns(
                RecordWarning, match=r"made by an earlier model .* run again"
            ) as said:
                summary = run_jobs([JOB], tmp_path / out, progress=False, cache=cache)
            assert len(said) == 1 and (summary.ran, summary.cached) == (1, 0)
        assert len(calls) == 3  # recomputed, not served: the new records are the next revision's
        new = read_record(record_cache / "records" / f"{JOB.key}.json")
        assert new.model == moved and new.key == JOB.key
        assert (record_cache / "records" / f"{old_key}.json").exists()  # kept, never deleted
    # back at today's revision: its record is served again, and the next one's stays readable
    assert run_jobs([JOB], tmp_path / "d", progress=False).cached == 1 and len(calls) == 3
    assert read_record(tmp_path / "c" / "records" / f"{new.key}.json") == new


@pytest.mark.parametrize(
    "given",
    [{"slipstream": "vortex"}, {"options": tandem_env.ModelOptions(slipstream="vortex")}],
)
def test_the_vortex_readings_own_revision_moves_its_records_keys_only(
    given: dict, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a change of the vortex reading alone (its constants) leaves every other reading's records
    # served: the reference table's among them
    vortex = Job("pso", "level", 2.0, 16, 0, env_kwargs={**SMALL, **given})
    mean = Job("pso", "level", 2.0, 16, 0, env_kwargs={**SMALL, "slipstream": "mean"})
    assert (vortex.slipstream(), mean.slipstream(), JOB.slipstream()) == ("vortex", "mean", "mean")
    before = {job: job.key for job in (vortex, mean, JOB)}
    monkeypatch.setattr(
        tandem_env.physics, "VORTEX_REVISION", tandem_env.physics.VORTEX_REVISION + 1
    )
    assert vortex.key != before[vortex]
    assert (mean.key, JOB.key) == (before[mean], before[JOB])


def test_the_gaps_revision_moves_the_keys_of_records_with_a_gap_only(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # a change of the gap's search or constraints leaves the records of flyers without a gap
    gapped = Job("pso", "level", 2.0, 16, 0, env_kwargs={**SMALL, "insect": {"min_wing_gap": 1e-3}})
    before = {job: job.key for job in (gapped, JOB)}
    monkeypatch.setattr(tandem_env.physics, "GAP_REVISION", tandem_env.physics.GAP_REVISION + 1)
    assert gapped.key != before[gapped] and JOB.key == before[JOB]


def test_a_record_from_before_keys_held_the_revision_is_not_served(
    tmp_path: Path, record_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = count_harness_calls(monkeypatch)
    made = run_jobs([JOB], tmp_path / "a", progress=False, cache=False).records[JOB.key]
    # the same record as a version without revisions wrote it: no "model", the key without it
    results = {**made.results, "versions": dict(made.results["versions"])}
    del results["versions"]["model"]
    old = Record(JOB, JOB.key_at(tandem_env.__version__, None), results)
    write_json_atomic(record_cache / "records" / f"{old.key}.json", old.to_dict())
    assert read_record(record_cache / "records" / f"{old.key}.json").model is None  # valid
    with pytest.warns(RecordWarning, match="made by an earlier model"):
        summary = run_jobs([JOB], tmp_path / "b", progress=False)
    assert (summary.ran, summary.cached, len(calls)) == (1, 0, 2)
    assert (record_cache / "records" / f"{old.key}.json").exists()


def test_a_candidate_of_another_revision_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    jobs = make_reference.plan((0,), grid={LEVEL_FLIGHT_ID: (("efficiency",), (2.0,))},
                               env_kwargs=SMALL)  # fmt: skip
    job = next(iter(jobs.values()))[0].job
    with monkeypatch.context() as patch:
        patch.setattr(tandem_env.physics, "MODEL_REVISION", 0)
        record = run_jobs([job], tmp_path, progress=False, cache=False).records[job.key]
    with pytest.raises(
        ValueError,
        match=rf"made by model revision 0, not this model's {tandem_env.physics.MODEL_REVISION}",
    ):
        candidates([record], jobs)


def test_the_table_records_its_revision_and_says_another(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    revision = tandem_env.physics.MODEL_REVISION
    assert make_reference.provenance([], {})["versions"]["model"] == revision
    data = json.loads(table_module.reference_path().read_text(encoding="utf-8"))
    data["provenance"]["versions"]["model"] = revision + 1
    write_json_atomic(tmp_path / "table.json", data)
    monkeypatch.setattr(table_module, "reference_path", lambda: tmp_path / "table.json")
    table_module.load_reference_table.cache_clear()
    try:
        with pytest.warns(UserWarning, match=f"model revision {revision + 1}.* remake it"):
            assert table_module.load_reference_table().model == revision + 1
    finally:
        table_module.load_reference_table.cache_clear()


def test_the_packaged_table_is_this_models() -> None:
    # Its revision is today's (None: made before tables held one), and its optima replay under
    # today's model to the canary's 1e-10 (tests/physics/test_kernel_equal.py).
    table = table_module.load_reference_table()
    assert table.model in (None, tandem_env.physics.MODEL_REVISION), (
        f"the packaged table was made by model revision {table.model}: python -m eval reference"
    )
    for series in table.series:
        objective = table_module.config_class(series.env_id).OBJECTIVES.keyword
        kwargs = {
            "planform": series.planform,
            **({objective: series.objective} if objective else {}),
        }
        problem = gym.make(series.env_id, **kwargs).unwrapped.problem()
        strokes = np.array([p["normalised_stroke"] for p in series.points])
        found = problem.evaluate(strokes, np.array(series.conditions))
        np.testing.assert_allclose(found.objective, series.objectives, rtol=1e-10)
