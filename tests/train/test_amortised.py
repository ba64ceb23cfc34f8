"""The amortised stroke policy (train.amortised): the canonical targets' invariance, the
regression, the run folder, the harness method, the envelope and the refusals.

Fast: tiny networks, the fine-tuning at n_time = 32, n_blade = 8, and a synthetic reference
table (the packaged one is not read, so nothing here depends on its numbers).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch
import yaml

import tandem_env.envs.reference as reference_module
from agents.harness import run
from agents.records import RecordError
from tandem_env.envs.reference import (
    REFERENCE_GRID,
    ReferenceSeries,
    ReferenceTable,
    default_fingerprint,
    held_out_conditions,
    training_conditions,
)
from tandem_env.envs.registration import ACCELERATE_ID, LEVEL_FLIGHT_ID
from tandem_env.physics.stroke import normalised_to_physical, physical_to_normalised
from train import amortised_policy
from train.__main__ import main
from train.amortised import (
    Settings,
    between,
    branch_segments,
    check_env_kwargs,
    make_problem,
    train_policy,
)
from train.amortised_policy import (
    CANONICAL_SWEEP_PHASE,
    CONTINUOUS,
    PHASES,
    Targets,
    canonicalise,
    delay,
    load_policy,
    reference_targets,
)
from train.envelope import evaluate_envelope
from train.trained_policy import load_policy as load_any_policy

TINY = {"n_time": 32, "n_blade": 8}
#: A tiny training: the regression to convergence, two fine-tuning steps at low resolution.
TINY_SETTINGS = {
    "hidden": [16, 16],
    "regression_steps": 1500,
    "regression_lr": 1e-2,
    "finetune_steps": 2,
    "batch": 2,
    "finetune_n_time": 32,
    "finetune_n_blade": 8,
}


def _strokes(seed: int, count: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (count, 28))


def _synthetic_series(env_id: str = LEVEL_FLIGHT_ID) -> ReferenceSeries:
    """A series over the env's grid: smooth strokes at the training conditions, NaN strokes at
    the held-out ones (reading them would fail)."""
    objectives, conditions = REFERENCE_GRID[env_id]
    base = np.random.default_rng(3).uniform(-0.7, 0.7, 28)
    base[[11, 25]] = [-0.5, 0.5]
    held = set(held_out_conditions(env_id))
    points = []
    for k, c in enumerate(conditions):
        stroke = base.copy()
        stroke[[0, 1, 3, 8, 16, 22]] += 0.2 * np.sin(k / 3.0)
        if c in held:
            stroke[:] = np.nan
        points.append(
            {
                "condition": c,
                "objective": 0.3 + 0.01 * k,
                "feasible": True,
                "normalised_stroke": stroke.tolist(),
            }
        )
    return ReferenceSeries(
        env_id=env_id,
        objective=objectives[0],
        planform="tear-drop",
        fingerprint=default_fingerprint(env_id, "tear-drop"),
        conditions=tuple(conditions),
        objectives=tuple(p["objective"] for p in points),
        points=tuple(points),
    )


@pytest.fixture
def synthetic_table(monkeypatch: pytest.MonkeyPatch) -> ReferenceSeries:
    series = _synthetic_series()
    table = ReferenceTable((series,), {"command": "test"})
    monkeypatch.setattr(reference_module, "load_reference_table", lambda: table)
    return series


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run folder written by ``python -m train --algo amortised`` on the synthetic table."""
    series = _synthetic_series()
    table = ReferenceTable((series,), {"command": "test"})
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(reference_module, "load_reference_table", lambda: table)
        folder = tmp_path_factory.mktemp("logs")
        pairs = [f"{k}={v}" for k, v in TINY_SETTINGS.items()]
        command = ["--algo", "amortised", "--env", LEVEL_FLIGHT_ID, "--seed", "1"]
        status = main([*command, "-f", str(folder), "--hyperparams", *pairs, "--verbose", "0"])
    assert status == 0
    [run_dir] = (folder / "amortised").iterdir()
    return run_dir


# --- the canonical targets ----------------------------------------------------------------------
@pytest.mark.parametrize("pairs_independent", [True, False])
def test_canonical_strokes_fly_exactly_as_the_originals(pairs_independent: bool) -> None:
    """The model's invariance the targets rely on: delaying each pair by whole time-grid steps
    (the hind pair on its own under the default mean slipstream) changes the objective and
    the constraint margins by rounding only (1e-9 relative)."""
    problem = make_problem(LEVEL_FLIGHT_ID, {}, **TINY)
    actions = _strokes(0, 8)
    speeds = np.linspace(0.3, 1.9, 8)
    physical = normalised_to_physical(actions)
    canonical = canonicalise(physical, TINY["n_time"], pairs_independent=pairs_independent)
    before = problem.evaluate(actions, speeds)
    after = problem.evaluate(np.clip(physical_to_normalised(canonical), -1, 1), speeds)
    np.testing.assert_allclose(after.objective, before.objective, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(after.margins, before.margins, rtol=1e-9, atol=1e-11)
    np.testing.assert_array_equal(after.feasible, before.feasible)
    step = 360.0 / TINY["n_time"]
    assert np.all(np.abs(canonical[:, 7] - CANONICAL_SWEEP_PHASE) <= step / 2 + 1e-9)
    if pairs_independent:
        assert np.all(np.abs(canonical[:, 21] - CANONICAL_SWEEP_PHASE) <= step / 2 + 1e-9)
    else:  # one common delay of both pairs
        shift = physical[:, 7] - canonical[:, 7]
        wrapped = (physical[:, 21] - canonical[:, 21] - shift + 180.0) % 360.0 - 180.0
        np.testing.assert_allclose(wrapped, 0.0, atol=1e-9)


def test_a_delay_moves_the_elevation_phase_by_n_times_the_delay() -> None:
    physical = normalised_to_physical(_strokes(1, 2))
    physical[:, 11], physical[:, 25] = 2, 1
    out = delay(physical, 10.0, -20.0)
    wrap = lambda a: (a + 180.0) % 360.0 - 180.0  # noqa: E731
    np.testing.assert_allclose(wrap(physical[:, 8] - out[:, 8]), 20.0, atol=1e-9)
    np.testing.assert_allclose(wrap(physical[:, 22] - out[:, 22]), -20.0, atol=1e-9)
    np.testing.assert_allclose(wrap(physical[:, 9] - out[:, 9]), 10.0, atol=1e-9)
    untouched = [j for j in range(28) if j not in PHASES]
    np.testing.assert_array_equal(out[:, untouched], physical[:, untouched])


def test_the_targets_are_the_training_conditions_only(synthetic_table: ReferenceSeries) -> None:
    targets = reference_targets(synthetic_table, 32, pairs_independent=True)
    np.testing.assert_allclose(targets.conditions, training_conditions(LEVEL_FLIGHT_ID))
    assert np.all(np.isfinite(targets.strokes))  # the held-out points' NaN were never read


# --- training ---------------------------------------------------------------------------------
def test_regression_reproduces_the_training_targets(synthetic_table: ReferenceSeries) -> None:
    targets = reference_targets(synthetic_table, 32, pairs_independent=True)
    settings = Settings(**{**TINY_SETTINGS, "finetune_steps": 0})
    policy, training = train_policy(LEVEL_FLIGHT_ID, {}, targets, settings, seed=0)
    strokes = policy.strokes(targets.conditions)
    difference = strokes - targets.strokes
    phases = list(PHASES)
    difference[:, phases] = (difference[:, phases] + 1.0) % 2.0 - 1.0
    assert np.max(np.abs(difference)) < 0.02, training.regression_loss
    np.testing.assert_array_equal(strokes[:, [11, 25]], targets.strokes[:, [11, 25]])
    # every training condition is served by its own branch; N between them: the branch's
    assert [b["training_conditions"] for b in training.branches] == [
        list(targets.conditions[policy.branch_at(targets.conditions) == i])
        for i in range(policy.n_branches)
    ]
    middle = np.linspace(targets.conditions[0], targets.conditions[-1], 41)
    np.testing.assert_array_equal(
        policy.strokes(middle)[:, [11, 25]], policy.harmonics[policy.branch_at(middle)]
    )


def test_training_is_deterministic_for_a_seed(synthetic_table: ReferenceSeries) -> None:
    targets = reference_targets(synthetic_table, 32, pairs_independent=True)
    settings = Settings(**{**TINY_SETTINGS, "regression_steps": 50})
    a, _ = train_policy(LEVEL_FLIGHT_ID, {}, targets, settings, seed=4)
    b, _ = train_policy(LEVEL_FLIGHT_ID, {}, targets, settings, seed=4)
    conditions = [0.3, 1.1, 1.9]
    np.testing.assert_array_equal(a.strokes(conditions), b.strokes(conditions))
    assert a.num_timesteps == settings.finetune_steps * settings.batch * a.n_branches


def test_fine_tuning_moves_the_network(synthetic_table: ReferenceSeries) -> None:
    targets = reference_targets(synthetic_table, 32, pairs_independent=True)
    base = {**TINY_SETTINGS, "regression_steps": 50}
    still, _ = train_policy(
        LEVEL_FLIGHT_ID, {}, targets, Settings(**{**base, "finetune_steps": 0}), seed=2
    )
    moved, training = train_policy(LEVEL_FLIGHT_ID, {}, targets, Settings(**base), seed=2)
    assert len(training.history) == 2
    assert not np.array_equal(still.strokes([1.0]), moved.strokes([1.0]))


class _Found:
    def __init__(self, objective: np.ndarray, margins: np.ndarray) -> None:
        self.objective, self.margins = objective, margins


class _MidwayProblem:
    """Stands in for the problem view: the objectives and margins of the midway strokes."""

    def __init__(self, objective: list[float], margin: list[float]) -> None:
        self.objective, self.margin = np.array(objective), np.array(margin)
        self.asked: list[np.ndarray] = []

    def evaluate(self, strokes: np.ndarray, conditions: np.ndarray) -> _Found:
        self.asked.append(conditions)
        return _Found(self.objective, np.column_stack([self.margin, np.ones_like(self.margin)]))


def test_between_goes_the_short_way_round_and_keeps_n() -> None:
    first, second = np.zeros((1, 28)), np.zeros((1, 28))
    first[0, [0, 7, 11]], second[0, [0, 7, 11]] = [0.2, 0.9, -0.5], [0.6, -0.9, 0.5]
    middle = between(first, second)[0]
    assert middle[0] == pytest.approx(0.4)  # a plain coordinate: the mean
    assert abs(middle[7]) == pytest.approx(1.0)  # 162° and -162°: halfway is 180°, not 0°
    assert middle[11] == -0.5  # N: the first's


def test_branches_split_where_the_midway_stroke_fails() -> None:
    conditions = np.array([0.25, 0.5, 0.75, 1.0, 1.25])
    strokes = np.zeros((5, 28))
    strokes[:, [11, 25]] = -0.5
    strokes[4, 11] = 0.5  # N changes between the last two
    targets = Targets(conditions, strokes, np.full(5, 0.4))
    # the midway strokes: fine, 15 % short, a margin 0.2 violated, fine (but N differs)
    problem = _MidwayProblem([0.399, 0.34, 0.4, 0.4], [0.0, 0.0, -0.2, 0.0])
    segments = branch_segments(problem, targets, tolerance=0.1)
    assert segments == [(0, 2), (2, 3), (3, 4), (4, 5)]
    np.testing.assert_allclose(problem.asked[0], [0.375, 0.625, 0.875, 1.125])
    assert branch_segments(problem, targets, tolerance=0.25) == [(0, 4), (4, 5)]


def test_each_branch_keeps_its_training_conditions_and_hands_over_between(
    synthetic_table: ReferenceSeries,
) -> None:
    targets = reference_targets(synthetic_table, 32, pairs_independent=True)
    settings = Settings(**{**TINY_SETTINGS, "regression_steps": 50, "branch_tolerance": 1.0})
    policy, training = train_policy(LEVEL_FLIGHT_ID, {}, targets, settings, seed=0)
    assert policy.n_branches == len(training.branches) >= 1
    for i, branch in enumerate(training.branches):
        own = np.array(branch["training_conditions"])
        assert np.all(policy.branch_at(own) == i)
        assert branch["serves_from"] <= own[0] <= own[-1] <= branch["serves_to"]
    assert np.all(np.diff(policy.switches) > 0)


# --- the run folder ----------------------------------------------------------------------------
def test_run_folder_round_trips(tiny_run: Path) -> None:
    policy = load_policy(tiny_run)
    name = "TandemWing-LevelFlight-v0"
    state = torch.load(tiny_run / f"{name}.pt", weights_only=True)
    assert all(isinstance(v, torch.Tensor) for v in state.values())
    args = yaml.safe_load((tiny_run / name / "args.yml").read_text())
    assert args["algo"] == "amortised" and args["env"] == LEVEL_FLIGHT_ID and args["seed"] == 1
    config = yaml.safe_load((tiny_run / name / "config.yml").read_text())
    assert config["hidden"] == [16, 16] and config["finetune_n_time"] == 32
    result = json.loads((tiny_run / "result.json").read_text())
    branches = len(result["branches"])
    assert result["num_timesteps"] == 4 * branches and len(result["training_evaluation"]) == 8
    # the same network rebuilt from the state_dict gives the same strokes
    features = json.loads((tiny_run / "policy.json").read_text())["features"]
    assert features == Settings().features
    rebuilt = amortised_policy.build_networks([16, 16], features, branches)
    rebuilt.load_state_dict(state)
    [branch] = policy.branch_at(np.array([0.7]))
    with torch.no_grad():
        z = rebuilt[branch](torch.as_tensor(policy.inputs([0.7], [branch])))
    direct = policy.assemble(torch.tanh(z), np.array([branch])).numpy()
    np.testing.assert_array_equal(np.clip(direct, -1, 1), policy.strokes([0.7]))
    again = load_any_policy(tiny_run)
    np.testing.assert_array_equal(again.strokes([0.3, 1.5]), policy.strokes([0.3, 1.5]))
    assert again.algo == "amortised" and again.training_conditions == (0.25, 2.0)
    assert np.all(np.abs(policy.strokes(np.linspace(0.25, 2.0, 9))) <= 1.0)


def test_policy_method_gives_a_record(tiny_run: Path) -> None:
    [record] = run(f"policy:{tiny_run}", "level", 0.8, budget=3, seeds=[0], progress=False)
    assert record.evaluations == 1
    np.testing.assert_allclose(
        record.normalised_stroke, load_policy(tiny_run).strokes([0.8])[0], atol=1e-6
    )
    assert record.config["method"]["algo"] == "amortised"
    assert "amortized optimization" in record.config["method"]["citation"]


def test_envelope_evaluates_an_amortised_run(tiny_run: Path, tmp_path: Path) -> None:
    rows = evaluate_envelope(tiny_run, tmp_path, conditions=[0.5, 1.5])
    assert [row["condition_value"] for row in rows] == [0.5, 1.5]
    assert all(row["trained_at"] and row["evaluations"] == 1 for row in rows)
    assert (tmp_path / "envelope.csv").is_file()


# --- refusals ----------------------------------------------------------------------------------
def test_an_env_without_a_reference_table_is_refused() -> None:
    with pytest.raises(ValueError, match=r"SpeedChange-v0.*no reference table.*allowed: "):
        check_env_kwargs("TandemWing/SpeedChange-v0", {})


@pytest.mark.parametrize(
    ("env_kwargs", "match"),
    [
        ({"n_time": 64}, r"change the problem.*options.*allowed: the default"),
        ({"speed": 1.0}, r"\['speed'\].*allowed: none of speed, speed_range"),
        ({"planform": "round"}, r"planform = 'round'; allowed: 'tear-drop', 'real'"),
    ],
)
def test_env_options_the_table_does_not_describe_are_refused(
    synthetic_table: ReferenceSeries, env_kwargs: dict[str, Any], match: str
) -> None:
    with pytest.raises(ValueError, match=match):
        check_env_kwargs(LEVEL_FLIGHT_ID, env_kwargs)


def test_a_series_the_table_lacks_is_refused(synthetic_table: ReferenceSeries) -> None:
    with pytest.raises(ValueError, match=r"no reference for .*planform 'real'.*allowed"):
        check_env_kwargs(LEVEL_FLIGHT_ID, {"planform": "real"})


@pytest.mark.parametrize(
    ("values", "match"),
    [
        ({"hidden": [0]}, r"hidden = \[0\]; allowed: 1 to 8 layer widths"),
        ({"batch": 0}, r"batch = 0; allowed: an integer from 1"),
        ({"finetune_lr": -1.0}, r"finetune_lr = -1.0; allowed: a number above 0"),
        ({"finetune_n_time": 3}, r"finetune_n_time = 3; allowed: None .* from 8"),
        ({"epochs": 3}, r"unknown amortised setting\(s\) \['epochs'\]; allowed: hidden"),
    ],
)
def test_bad_settings_are_refused(values: dict[str, Any], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        Settings.from_mapping(values)


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--n-envs", "4"], r"--n-envs: option\(s\) of ppo and sac.*allowed with amortised"),
        (["--hyperparams", "batch=0"], r"batch = 0; allowed"),
        (["--env-kwargs", "n_blade=12"], r"change the problem the reference table describes"),
        (["--seed", "-1"], r"seed = -1; allowed"),
    ],
)
def test_the_command_refuses_bad_input_before_any_work(
    synthetic_table: ReferenceSeries,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    match: str,
) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["--algo", "amortised", "--env", LEVEL_FLIGHT_ID, "-f", str(tmp_path), *extra])
    assert stop.value.code == 2
    assert pytest.importorskip("re").search(match, capsys.readouterr().err)
    assert not (tmp_path / "amortised").exists()


def test_the_command_names_the_envs_with_a_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        main(["--algo", "amortised", "--env", "TandemWing/SpeedChange-v0", "-f", str(tmp_path)])
    err = capsys.readouterr().err
    assert "no reference table" in err and LEVEL_FLIGHT_ID in err and ACCELERATE_ID in err


def test_targets_are_checked() -> None:
    with pytest.raises(ValueError, match="allowed: K >= 1 increasing conditions"):
        Targets(np.array([1.0, 0.5]), np.zeros((2, 28)), np.ones(2))
    assert len(CONTINUOUS) == 26


# --- the held-out evaluation -------------------------------------------------------------------
def test_held_out_evaluation_reports_gaps_and_times(
    tiny_run: Path, synthetic_table: ReferenceSeries
) -> None:
    from train.amortised_eval import evaluate_held_out, format_report

    report = evaluate_held_out(tiny_run, conditions=[0.5, 1.5], repeats=2)
    [first, second] = report["rows"]
    assert (first["condition"], second["condition"]) == (0.5, 1.5)
    for row in report["rows"]:
        expected = 100.0 * row["objective"] / row["reference"] if row["feasible"] else None
        if expected is not None:
            assert row["gap"] == pytest.approx(100.0 - expected)
        else:
            assert row["gap"] >= 100.0
    summary = report["summary"]
    assert summary["count"] == 2 and summary["stroke_seconds"] > 0
    assert summary["worst_gap"] == max(first["gap"], second["gap"])
    assert "time to a stroke" in format_report(report)


def test_held_out_evaluation_refuses_a_large_polish(tiny_run: Path) -> None:
    from train.amortised_eval import evaluate_held_out

    with pytest.raises(
        ValueError, match=r"polish = 501; allowed: an integer from 0 \(none\) to 500"
    ):
        evaluate_held_out(tiny_run, polish_budget=501)


def test_a_run_folder_that_holds_files_is_refused(
    synthetic_table: ReferenceSeries, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    taken = tmp_path / "run"
    taken.mkdir()
    (taken / "notes.txt").write_text("mine")
    with pytest.raises(SystemExit):
        main(["--algo", "amortised", "--env", LEVEL_FLIGHT_ID, "--run-dir", str(taken)])
    assert "not an empty folder" in capsys.readouterr().err
    assert sorted(p.name for p in taken.iterdir()) == ["notes.txt"]


def test_a_run_folder_another_command_trains_in_is_refused_before_training(
    synthetic_table: ReferenceSeries, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two commands given one empty --run-dir: the second finds the first's lock and stops
    before it trains, instead of both training and the later one overwriting the other's files."""
    from train.run_folder import run_lock

    run_dir = tmp_path / "run"
    run_dir.mkdir()
    pairs = [f"{k}={v}" for k, v in TINY_SETTINGS.items()]
    command = ["--algo", "amortised", "--env", LEVEL_FLIGHT_ID, "--run-dir", str(run_dir)]
    with run_lock(run_dir), pytest.raises(SystemExit):
        main([*command, "--hyperparams", *pairs])
    captured = capsys.readouterr()
    assert "is in use: another python -m train" in captured.err
    assert "fine-tuning step" not in captured.out
    assert sorted(p.name for p in run_dir.iterdir()) == [".train.lock"]
    # once the other command has finished, the folder (its lock file aside) is empty: it trains
    assert main([*command, "--hyperparams", *pairs, "--verbose", "0"]) == 0
    assert (run_dir / "policy.json").is_file()


def test_record_times_reads_the_tables_records_through_the_store(tmp_path: Path) -> None:
    """The optimiser's time to an optimum at a condition: the best feasible record's wall time,
    the sum and the count over the records there (other conditions and planforms left out),
    the records read and checked by the store; a damaged record is named, not skipped."""
    from agents.jobs import Job
    from agents.runner import run_jobs
    from agents.store import read_record_files
    from train.amortised_eval import record_times

    small = {"env_kwargs": {"n_time": 16, "n_blade": 4}}
    jobs = [
        Job("random", "level", v, 8, seed, **small) for v, seed in ((1.0, 0), (1.0, 1), (1.5, 0))
    ]
    jobs.append(
        Job("random", "level", 1.0, 8, 0, env_kwargs={**small["env_kwargs"], "planform": "real"})
    )
    records = run_jobs(jobs, tmp_path, progress=False).records
    at_one = [records[job.key] for job in jobs[:2]]
    best = max([r for r in at_one if r.feasible] or at_one, key=lambda r: r.objective)
    stored = read_record_files([tmp_path / "records"])
    found = record_times(stored, LEVEL_FLIGHT_ID, "efficiency", "tear-drop", 1.0)
    assert found == (best.wall_time, sum(r.wall_time for r in at_one), 2)
    assert record_times(stored, LEVEL_FLIGHT_ID, "efficiency", "tear-drop", 0.5) is None
    damaged = tmp_path / "records" / f"{jobs[0].key}.json"
    damaged.write_text(damaged.read_text(encoding="utf-8")[:-20], encoding="utf-8")
    with pytest.raises(RecordError, match=f"{damaged}: not a record file"):
        read_record_files([tmp_path / "records"])  # as evaluate_held_out reads them


# --- a hostile run folder ----------------------------------------------------------------------
def _copy(tiny_run: Path, tmp_path: Path) -> Path:
    import shutil

    return Path(shutil.copytree(tiny_run, tmp_path / tiny_run.name))


def _edit_policy(run_dir: Path, **changes: Any) -> Path:
    path = run_dir / "policy.json"
    data = json.loads(path.read_text(encoding="utf-8"))
    for key, change in changes.items():
        data[key] = change(data[key]) if callable(change) else change
    path.write_text(json.dumps(data), encoding="utf-8")  # NaN and Infinity as Python writes them
    return path


def _set(index: tuple[int, ...], value: float) -> Any:
    def change(values: Any) -> Any:
        array = np.array(values, dtype=object)
        array[index] = value
        return array.tolist()

    return change


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        # the size limits of training (Settings, their one home), before anything is allocated
        ({"hidden": [40000, 40000]}, r"hidden = \[40000, 40000\]; allowed: 1 to 8 layer widths"),
        ({"features": 10**10}, r"features = 10000000000; allowed: an integer from 0 to 1,024"),
        ({"hidden": "64"}, r"hidden = '64'; allowed"),
        ({"num_timesteps": float("inf")}, r"num_timesteps = inf; allowed: an integer >= 0"),
        ({"num_timesteps": -5}, r"num_timesteps = -5; allowed: an integer >= 0"),
        ({"centres": _set((8,), float("nan"))}, r"its arrays are not finite"),
        ({"harmonics": _set((0, 0), float("nan"))}, r"its arrays are not finite"),
        ({"domains": _set((0, 1), float("nan"))}, r"its arrays are not finite"),
        ({"switches": _set((0,), float("nan"))}, r"its arrays are not finite"),
        ({"harmonics": _set((0, 1), 7.0)}, r"harmonics other than -0.5 \(N = 1\) and 0.5"),
        ({"domains": lambda d: [[b, a] for a, b in d]}, r"domains not increasing ranges inside"),
        ({"domains": _set((0, 0), -50.0)}, r"domains not increasing ranges inside the grid"),
        ({"switches": lambda s: [v + 5.0 for v in s]}, r"switches not increasing inside both"),
        ({"centres": _set((0,), 3.0)}, r"centres outside \[-1, 1\]"),
        ({"centres": lambda c: c[:-1]}, r"shapes \[\(25,\).*allowed: \(26,\)"),
        ({"harmonics": 0.5}, r"shapes \[.*\(\)\]; allowed: \(26,\)"),
        ({"centres": _set((0,), "0")}, r"centres\[0\] = '0' is a string"),
        ({"env_kwargs": {"wingspan": 3}}, r"unknown argument\(s\) 'wingspan'"),
        ({"env_kwargs": [1]}, r"env_kwargs = \[1\]; allowed: a mapping"),
        ({"env_id": "TandemWing/Accelerate-v0"}, r"env_id = .*Accelerate.*args.yml says"),
        ({"format": "x"}, r"format 'x'; allowed: 'tandem_env.amortised-policy/2'"),
    ],
)
def test_a_bad_policy_file_is_refused_naming_it_before_any_work(
    tiny_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, changes: dict, match: str
) -> None:
    run_dir = _copy(tiny_run, tmp_path)
    path = _edit_policy(run_dir, **changes)
    # nothing is built: a network of the refused sizes would allocate gigabytes
    monkeypatch.setattr(amortised_policy, "build_networks", None)
    with pytest.raises(ValueError, match=match) as info:
        load_policy(run_dir)
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)


def test_a_policy_file_without_a_field_or_not_json_is_refused_naming_it(
    tiny_run: Path, tmp_path: Path
) -> None:
    run_dir = _copy(tiny_run, tmp_path)
    path = run_dir / "policy.json"
    data = json.loads(path.read_text(encoding="utf-8"))
    del data["domains"]
    for text in (json.dumps(data), "{not json", "[" * 100_000):
        path.write_text(text, encoding="utf-8")
        with pytest.raises(ValueError, match=rf"^{path}: (no domains|not readable JSON)"):
            load_policy(run_dir)


@pytest.mark.parametrize(
    ("damage", "match"),
    [
        ("pickle", r"not a state_dict that torch.load\(weights_only=True\) reads"),
        ("garbage", r"not a state_dict that torch.load\(weights_only=True\) reads"),
        ("shape", r"its tensors do not match the network policy.json describes"),
        ("nan", r"weights that are not finite"),
    ],
)
def test_a_tampered_weights_file_is_refused_in_one_line(
    tiny_run: Path, tmp_path: Path, damage: str, match: str
) -> None:
    import pickle

    run_dir = _copy(tiny_run, tmp_path)
    weights = run_dir / "TandemWing-LevelFlight-v0.pt"
    state = torch.load(weights, weights_only=True)
    if damage == "pickle":  # a payload that would run code if unpickled
        torch.save({"x": _Payload()}, weights, pickle_module=pickle)
    elif damage == "garbage":
        weights.write_bytes(b"PK\x03\x04" + b"\x00" * 64)
    else:
        key = next(iter(state))
        state[key] = torch.zeros(3) if damage == "shape" else state[key] * np.nan
        torch.save(state, weights)
    with pytest.raises(ValueError, match=match) as info:
        load_policy(run_dir)
    message = str(info.value)
    assert message.startswith(f"{weights}: ") and "\n" not in message
    assert "weights_only=False" not in message


class _Payload:
    def __reduce__(self) -> Any:
        return (print, ("ran",))


def test_an_args_file_naming_another_algorithm_is_refused_clearly(
    tiny_run: Path, tmp_path: Path
) -> None:
    run_dir = _copy(tiny_run, tmp_path)
    args_file = run_dir / "TandemWing-LevelFlight-v0" / "args.yml"
    args_file.write_text(args_file.read_text().replace("algo: amortised", "algo: ppo"))
    # through the loader of every run folder too: the policy.json says it is an amortised run
    for loader in (load_policy, load_any_policy):
        with pytest.raises(ValueError, match=rf"^{args_file}: algo = 'ppo'; allowed: 'amortised'"):
            loader(run_dir)


def test_an_args_file_naming_an_env_without_a_table_is_refused(
    tiny_run: Path, tmp_path: Path
) -> None:
    run_dir = _copy(tiny_run, tmp_path)
    name = "TandemWing-SpeedChange-v0"
    (run_dir / "TandemWing-LevelFlight-v0").rename(run_dir / name)
    args_file = run_dir / name / "args.yml"
    args_file.write_text(args_file.read_text().replace("LevelFlight", "SpeedChange"))
    with pytest.raises(ValueError, match=rf"^{args_file}: env = .*SpeedChange.*; allowed: an env"):
        load_policy(run_dir)


def test_held_out_evaluation_checks_its_out_before_any_work(
    tiny_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from train.amortised_eval import main as evaluate

    for out, match in ((tmp_path, "is a folder; allowed: a file name"),
                       (tmp_path / "file" / "report.json", "is a file; allowed: a directory"),
                       ("", "an empty path")):  # fmt: skip
        (tmp_path / "file").write_text("")
        with pytest.raises(SystemExit) as stop:
            evaluate(["--run", str(tiny_run), "--out", str(out)])
        err = capsys.readouterr()
        assert stop.value.code == 2 and match in err.err and "Traceback" not in err.err
        assert err.out == ""  # no evaluation ran
