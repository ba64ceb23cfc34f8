"""The harness: analytic objectives through the vector-env path, and the real LevelFlight env.

Tolerances on the analytic objectives (28-D, optimum at x*_j = 0.3·(−1)^j, maximum 0):

* sphere, PSO 40 × 500 through the harness: best reward > −1e-6 and every coordinate within
  1e-3 of x* (the same PSO on the bare function reaches −1.6e-8 at worst over 200 seeds);
* Rastrigin (box mapped onto ±5.12 around x*), PSO 40 × 500: gbest PSO in 28-D settles in a
  local minimum near the global one rather than on it (measured −31 to −95 over 10 seeds, the
  same as driving the PSO directly), so the stated tolerance is the low-lying region: best
  reward > −150 (uniform random points score about −525) and less than half the random
  search's loss at the same budget and seed.
"""

from __future__ import annotations

import importlib
import itertools
import json
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import tandem_env
from agents import harness, methods
from agents.evaluator import BudgetExceededError, VectorEnvEvaluator
from agents.jobs import SCHEMA, Job
from agents.methods import (
    AskTellMethod,
    SearchContext,
    SearchOutcome,
    available_methods,
    get_method,
    register_method,
)
from agents.pso import PSOConfig
from agents.records import Record
from agents.runner import run_jobs
from agents.store import RecordStore, read_record_files
from agents.tasks import LEVEL_TASK, get_task

sys.path.insert(0, str(Path(__file__).parent))
from analytic_envs import ACTION_LOG, DIM, optimum, register_analytic

SPECS = register_analytic()
SHIFT = 0.3


def run_analytic(method: str, function: str, budget: int, seed: int, **kwargs) -> Record:
    (record,) = harness.run(method, function, SHIFT, budget, [seed], progress=False, **kwargs)
    return record


# --- analytic objectives through the same path ---------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1])
def test_pso_reaches_sphere_optimum_through_vector_env(seed: int) -> None:
    ACTION_LOG.clear()
    record = run_analytic("pso", "sphere", 20_000, seed)
    assert record.reward > -1e-6
    np.testing.assert_allclose(record.normalised_stroke, optimum(SHIFT), atol=1e-3)
    assert record.evaluations == 20_000
    # Every batch was one vector-env step of the whole swarm; the last log entry is the
    # single-env re-evaluation.
    batches = ACTION_LOG[:-1]
    assert len(batches) == 500 and all(b.shape == (40, DIM) for b in batches)
    assert ACTION_LOG[-1].shape == (1, DIM)
    every = np.concatenate(ACTION_LOG)
    assert every.min() >= -1.0 and every.max() <= 1.0  # never left the box
    assert record.reward == record.search_reward == record.objective
    assert record.condition.to_dict() == {"name": "shift", "value": SHIFT, "unit": "-"}


@pytest.mark.parametrize("boundary", ["clip", "reflect"])
def test_pso_never_leaves_box_on_rastrigin(boundary: str) -> None:
    # Shift 1 puts the optimum in a corner, so the swarm keeps pushing against the walls.
    ACTION_LOG.clear()
    harness.run(
        "pso", "rastrigin", 1.0, 4_000, [3], progress=False, method_config={"boundary": boundary}
    )
    every = np.concatenate(ACTION_LOG)
    assert every.shape == (4_001, DIM)
    assert every.min() >= -1.0 and every.max() <= 1.0
    assert np.abs(every).max() > 0.999  # the walls were reached, and respected


@pytest.mark.parametrize("seed", [0, 1])
def test_pso_reaches_rastrigin_low_region_and_beats_random(seed: int) -> None:
    pso = run_analytic("pso", "rastrigin", 20_000, seed)
    rs = run_analytic("random", "rastrigin", 20_000, seed)
    assert pso.reward > -150.0
    assert -pso.reward < 0.5 * -rs.reward
    assert pso.evaluations == rs.evaluations == 20_000


def test_same_seed_same_history_different_seed_different() -> None:
    a = run_analytic("pso", "rastrigin", 2_000, 7)
    b = run_analytic("pso", "rastrigin", 2_000, 7)
    c = run_analytic("pso", "rastrigin", 2_000, 8)
    assert a.history == b.history
    assert a.normalised_stroke == b.normalised_stroke
    assert a.history != c.history


def test_record_reports_the_best_feasible_stroke_not_a_better_infeasible_one() -> None:
    """The constrained sphere's optimum (x_0 = 0.3) is infeasible and its reward unpenalised:
    the search's best reward is infeasible, the record must report the best feasible stroke."""
    record = run_analytic("pso", "constrained", 4_000, 0)
    assert record.feasible
    assert record.selection == "best feasible stroke seen"
    assert record.normalised_stroke[0] <= 0.0
    assert record.reward == record.search_reward
    assert record.history[-1][1] > record.reward  # the best reward seen was infeasible
    free = run_analytic("pso", "sphere", 4_000, 0)
    assert free.selection == "best feasible stroke seen" and free.reward == free.history[-1][1]


def test_history_is_best_so_far_per_iteration() -> None:
    record = run_analytic("random", "sphere", 1_000, 0, method_config={"swarm_size": 30})
    evaluations = [e for e, _ in record.history]
    best = [b for _, b in record.history]
    # 33 full batches of 30 and a truncated last one of 10: the budget is never exceeded.
    assert evaluations == [*range(30, 1_000, 30), 1_000]
    assert all(x <= y for x, y in itertools.pairwise(best))
    assert best[-1] == record.search_reward


def test_budget_is_enforced_by_the_evaluator() -> None:
    spec = SPECS["sphere"]
    with VectorEnvEvaluator(spec, spec.condition(SHIFT), {"shift": SHIFT}, 0, 50) as ev:
        ev(np.zeros((40, DIM)))
        with pytest.raises(BudgetExceededError, match="budget of 50"):
            ev(np.zeros((11, DIM)))
        ev(np.zeros((10, DIM)))
        assert ev.evaluations == 50 and ev.iterations == 2


# --- the method registry ------------------------------------------------------------------------
def test_registry_validates_settings_and_names() -> None:
    assert {"pso", "random", "ppo", "sac", "policy"} <= set(available_methods())
    with pytest.raises(ValueError, match=r"unknown method 'cma'.*allowed: cmaes, .*pso, random"):
        get_method("cma")
    with pytest.raises(ValueError, match=r"unknown setting.*allowed: swarm_size"):
        get_method("pso", {"swarmsize": 10})
    with pytest.raises(ValueError, match="budget"):
        get_method("pso", {"iterations": 10})
    with pytest.raises(ValueError, match="swarm_size = 1; allowed: an integer >= 2"):
        get_method("pso", {"swarm_size": 1})
    with pytest.raises(ValueError, match="takes no ':' argument"):
        get_method("pso:x")
    method = get_method("random", {"swarm_size": 16})
    assert isinstance(method, AskTellMethod)
    assert method.config(100).batch_size == 16


def _plug_in(monkeypatch: pytest.MonkeyPatch, name: str, module: str) -> None:
    """Method ``name`` named by an installed entry point with value ``module``."""
    installed = methods.providers()
    monkeypatch.setattr(methods, "providers", lambda: {**installed, name: module})


def test_lazy_provider_missing_raises_not_implemented(monkeypatch: pytest.MonkeyPatch) -> None:
    _plug_in(monkeypatch, "ghost", "no_such_package_for_tests.methods")
    with pytest.raises(NotImplementedError, match="provided by module no_such_package_for_tests"):
        get_method("ghost")


def test_ppo_sac_policy_come_from_train_or_say_so() -> None:
    for name in ("ppo", "policy:runs/x"):
        try:
            get_method(name)
        except NotImplementedError as error:
            assert "train" in str(error)
        except (ValueError, FileNotFoundError, OSError):
            pass  # provided by train/, which rejected the arguments: the hook works


def test_lazy_provider_registers_on_first_use(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A provider module, like train.policies, registers its method when imported.
    (tmp_path / "fake_provider_for_tests.py").write_text(
        textwrap.dedent(
            """
            from agents.methods import AskTellMethod, register_method
            from agents.random_search import RandomSearchConfig

            def factory(argument, config):
                size = int(argument) if argument else 8
                return AskTellMethod(f"fake:{argument}", RandomSearchConfig, {"batch_size": size})

            register_method("fake", factory)
            """
        )
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    _plug_in(monkeypatch, "fake", "fake_provider_for_tests")
    try:
        record = run_analytic("fake:5", "sphere", 20, 0)
        assert record.method == "fake:5"
        assert [e for e, _ in record.history] == [5, 10, 15, 20]
        assert (
            record.job.method == "fake:5" and Job.from_dict(record.job.to_dict()).key == record.key
        )
    finally:
        from agents import methods

        methods._REGISTRY.pop("fake", None)
        sys.modules.pop("fake_provider_for_tests", None)


def test_a_method_running_its_own_loop_plugs_in() -> None:
    """What an RL method does: its own env steps, its own history, the harness re-evaluates."""

    class Constant:
        name = "constant"

        def search(self, context: SearchContext) -> SearchOutcome:
            context.report(1, 10, -1.0)
            return SearchOutcome(
                best_action=np.full(context.dim, 0.1),
                best_reward=float(context.evaluate(np.full((1, context.dim), 0.1))[0]),
                evaluations=10,
                history=((10, -1.0),),
                config={"citation": "a fixed stroke"},
            )

    register_method("constant", lambda argument, config: Constant(), replace=True)
    record = run_analytic("constant", "sphere", 10, 0)
    assert record.evaluations == 10
    assert record.reward == pytest.approx(-np.sum((0.1 - optimum(SHIFT)) ** 2))
    assert record.config["method"] == {"citation": "a fixed stroke"}


# --- input validation -----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"task": "hover"}, "unknown task 'hover'; allowed: 'level', 'accelerate'"),
        ({"condition": 5.0}, "speed"),
        ({"budget": 0}, "budget = 0; allowed: an integer >= 1 and <= 100,000,000"),
        # refused before a method sizes its tables by it (PSO's inertia schedule: TiB)
        ({"budget": 10**8 + 1}, "budget = 100000001; allowed: an integer >= 1 and <= 100,000,000"),
        ({"budget": 2**63}, "budget = 9223372036854775808; allowed"),
        ({"seeds": []}, "seeds is empty"),
        ({"seeds": [1, 1]}, "repeat"),
        ({"seeds": [-1]}, "seed = -1; allowed: an integer >= 0"),
        ({"objective": "vertical"}, "one objective"),
        ({"env_kwargs": {"speed": 1.0}}, "set by the harness"),
        ({"env_kwargs": {"speed_range": (0.5, 1.0)}}, "set by the harness"),
        ({"env_kwargs": {"bogus": 1}}, "unknown argument.*bogus"),
        ({"method": "nope"}, "unknown method"),
    ],
)
def test_prepare_rejects_bad_input(kwargs: dict, message: str) -> None:
    args = {"method": "pso", "task": "level", "condition": 1.5, "budget": 10, "seeds": [0]}
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        harness.prepare(
            args.pop("method"), args.pop("task"), args.pop("condition"), args.pop("budget"),
            args.pop("seeds"), **args,
        )  # fmt: skip


def test_accelerate_objective_goes_to_the_env() -> None:
    (plan,) = harness.prepare("random", "accelerate", 70.0, 10, [0], objective="horizontal")
    assert plan.env_kwargs == {"objective": "horizontal", "available_power": 70.0}
    assert plan.objective_name == "excess_horizontal"
    assert plan.condition.to_dict() == {"name": "available_power", "value": 70.0, "unit": "W/kg"}
    with pytest.raises(ValueError, match="allowed: 'vertical', 'horizontal', 'resultant'"):
        harness.prepare("random", "accelerate", 70.0, 10, [0], objective="up")


# --- the real LevelFlight env with a tiny budget --------------------------------------------------
SPEED = 1.5
TINY = {"method_config": {"swarm_size": 8}, "progress": False}


@pytest.fixture(scope="module")
def level_records(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[Record]]:
    # What `eval optimize` does: prepare the seeds' jobs, run them through the runner (the one
    # writer of the store), write the summary once at the end.
    out = tmp_path_factory.mktemp("level")
    prepared = harness.prepare("pso", "level", SPEED, 20, [0, 1], method_config={"swarm_size": 8})
    run_jobs(prepared, out, progress=False)
    store = RecordStore(out)
    store.write_summary()
    return out, [store.load(p.job) for p in prepared]


def test_level_records_have_every_field(level_records) -> None:
    _, records = level_records
    for seed, record in zip((0, 1), records, strict=True):
        assert record.method == "pso" and record.task == "level"
        assert record.env_id == "TandemWing/LevelFlight-v0"
        assert record.objective_name == "efficiency"
        assert record.condition.to_dict() == {"name": "speed", "value": 1.5, "unit": "m/s"}
        assert record.seed == seed and record.budget == 20
        assert record.evaluations == 20  # batches of 8, 8 and a truncated 4
        assert [e for e, _ in record.history] == [8, 16, 20]
        assert record.objective == record.metrics["efficiency"]
        assert record.feasible == record.metrics["feasible"]
        assert record.reward == record.objective - record.metrics["penalty"]
        assert record.reward == record.search_reward
        assert list(record.stroke) == list(tandem_env.PARAMETER_NAMES)
        assert len(record.normalised_stroke) == 28
        assert all(-1.0 <= a <= 1.0 for a in record.normalised_stroke)
        assert set(tandem_env.METRIC_NAMES) <= set(record.metrics)
        assert record.wall_time > 0.0
        method = record.config["method"]
        assert method["swarm_size"] == 8 and method["max_evaluations"] == 20
        assert "Clerc & Kennedy (2002)" in method["citation"]
        assert record.job.env_kwargs == () and record.job.condition == 1.5
        assert record.config["env"]["options"]["thrust_split"] == "sign"
        assert record.config["env"]["penalty"] == {"weight": 10.0, "offset": 0.0}
        assert {"numpy", "gymnasium", "torch", "python", "tandem_env"} <= set(record.versions)


def test_level_reevaluation_equals_direct_model_call(level_records) -> None:
    _, records = level_records
    for record in records:
        physical = np.array([record.stroke[name] for name in tandem_env.PARAMETER_NAMES], float)
        np.testing.assert_array_equal(
            physical,
            tandem_env.normalised_to_physical(np.array(record.normalised_stroke)),
        )
        direct = tandem_env.evaluate(physical[None], SPEED).row(0)
        for name, value in direct.items():
            assert record.metrics[name] == value, name


def test_level_json_round_trip_and_files(level_records) -> None:
    out, records = level_records
    assert sorted(p.name for p in out.iterdir()) == ["records", "summary.csv"]
    # One file per seed, named by the configuration's key; no temporary files left behind.
    names = sorted(p.name for p in (out / "records").iterdir())
    assert names == sorted(f"{r.key}.json" for r in records)
    for record in records:
        data = json.loads((out / "records" / f"{record.key}.json").read_text())
        assert data["schema"] == SCHEMA
        assert Record.from_dict(data) == record
    assert sorted(read_record_files([out]), key=lambda r: r.seed) == records
    summary = (out / "summary.csv").read_text().splitlines()
    assert summary[0].startswith("method,task,objective_name,condition,condition_value")
    assert len(summary) == 3


def test_level_deterministic_per_seed(level_records) -> None:
    _, records = level_records
    (again,) = harness.run("pso", "level", SPEED, 20, [1], **TINY)
    assert again.job == records[1].job and again.key == records[1].key
    assert {**again.results, "wall_time": 0.0} == {**records[1].results, "wall_time": 0.0}
    assert records[0].history != records[1].history


def test_one_batched_model_call_per_iteration(monkeypatch: pytest.MonkeyPatch) -> None:
    task_module = importlib.import_module("tandem_env.envs.base")
    calls: list[int] = []
    real = task_module.evaluate

    def counting(strokes, *args, **kwargs):
        calls.append(len(strokes))
        return real(strokes, *args, **kwargs)

    monkeypatch.setattr(task_module, "evaluate", counting)
    harness.run("random", "level", SPEED, 20, [0], **TINY)
    # Three iterations (8, 8, 4 strokes) in one model call each, then the re-evaluation.
    assert calls == [8, 8, 4, 1]


def test_unknown_env_condition_out_of_range_is_reported() -> None:
    with pytest.raises(ValueError, match="speed"):
        harness.prepare("pso", LEVEL_TASK, 25.0, 10, [0])
    assert get_task("level") == LEVEL_TASK  # derived from the declaration when asked, equal


def test_pso_config_defaults_are_recorded() -> None:
    method = get_method("pso")
    assert isinstance(method, AskTellMethod)
    assert method.config(12_000) == PSOConfig(max_evaluations=12_000)
