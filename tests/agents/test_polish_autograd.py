"""The polish's autograd gradient (agents.polish.AutogradGradient, the torch backend on the CPU).

Its value, objective gradient and margin Jacobian w.r.t. the free normalised coordinates equal
central differences of the numba model (the default gradient) at feasible strokes of both
tasks, and the harness uses it, and says so, when the backend is torch.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from agents.polish import AutogradGradient, CentralDifferences, kkt_residual, task_problem
from agents.store import read_record_files
from agents.tasks import ACCELERATE_TASK, LEVEL_TASK
from eval.__main__ import main

pytest.importorskip("torch")


def _env_strokes():
    # the env tests' known feasible strokes, from their one home (tests/envs/conftest.py)
    path = Path(__file__).resolve().parents[1] / "envs" / "conftest.py"
    spec = importlib.util.spec_from_file_location("env_test_strokes", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


STROKES = _env_strokes()
# (task, condition, env keywords, feasible normalised stroke); the scaled strokes move every
# coordinate off the box's faces, where central differences are one-sided (O(h) error).
CASES = [
    (LEVEL_TASK, STROKES.LEVEL_SPEED, {}, STROKES.LEVEL_FEASIBLE_ACTION),
    (
        LEVEL_TASK,
        STROKES.LEVEL_SPEED,
        {"constraint_tolerance": 0.05},
        0.99 * STROKES.LEVEL_FEASIBLE_ACTION,
    ),
    (ACCELERATE_TASK, STROKES.ACCELERATE_POWER, {}, 0.97 * STROKES.ACCELERATE_FEASIBLE_ACTION),
    (ACCELERATE_TASK, 90.0, {"objective": "resultant"}, 0.97 * STROKES.ACCELERATE_FEASIBLE_ACTION),
    # the wings' gap: autograd at the search's place held (the envelope theorem) against
    # central differences of the whole search
    (
        LEVEL_TASK,
        STROKES.LEVEL_SPEED,
        {"insect": {"min_wing_gap": 1e-3}},
        STROKES.LEVEL_FEASIBLE_ACTION,
    ),
]


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.mark.parametrize(("task", "value", "kwargs", "action"), CASES)
def test_autograd_gradient_equals_central_differences(task, value, kwargs, action):
    condition = task.condition(value)
    numba = task_problem(task, condition, kwargs)
    torch = task_problem(task, condition, {**kwargs, "backend": "torch"})
    reference = CentralDifferences(numba)(action)
    gradient = AutogradGradient(torch)
    assert gradient.cost == 1 and gradient.name == "autograd"
    got = gradient(action)
    assert reference.feasible and got.feasible
    assert got.names == reference.names
    # the same model (numba and torch agree to 1e-8, docs/model.md §12.1) and declaration
    assert got.objective == pytest.approx(reference.objective, rel=1e-8)
    np.testing.assert_allclose(got.margins, reference.margins, rtol=1e-8, atol=1e-10)
    assert got.objective_gradient.shape == (len(numba.free),)
    assert _relative(got.objective_gradient, reference.objective_gradient) < 1e-5
    for row, expected in zip(got.jacobian, reference.jacobian, strict=True):
        assert _relative(row, expected) < 1e-5


#: Seed 3's optimum of level flight at 1 m/s under the vortex reading with min_wing_gap 1 mm
#: (``python -m eval optimize --task level --speed 1.0 --method cmaes --budget 16000 --seeds 3
#: --env-kwargs slipstream=vortex --insect FILE``, 2026-12-07), normalised, as reported
#: (float32): the wings 1 mm apart at two places, a quarter of the cycle apart.
TWO_PLACES = [
    0.6653721928596497, -1.0, 1.0, 0.4176170229911804, -0.7586610317230225, -1.0,
    0.5042100548744202, -0.25917530059814453, 0.7602487802505493, 0.5882997512817383,
    0.46186891198158264, -0.5, -1.0, -1.0, 0.06683076918125153, -1.0, 0.7153194546699524,
    0.5751096606254578, 0.9060747027397156, 1.0, 0.259639710187912, -0.02665281854569912,
    0.009799890220165253, 0.4929269850254059, 0.44053980708122253, -0.5, -0.629252016544342, -1.0,
]  # fmt: skip


def test_an_optimum_on_the_gap_at_two_places_needs_a_margin_at_each():
    """At that optimum both gap margins are active, and the first-order conditions hold with
    both (KKT residual 4.4e-6, as its certificate says) but not with the least distance's
    alone (0.057; the polish with that one margin ended there uncertified, at 0.056)."""
    kwargs = {"insect": {"min_wing_gap": 1e-3}, "slipstream": "vortex", "backend": "torch"}
    problem = task_problem(LEVEL_TASK, LEVEL_TASK.condition(1.0), kwargs)
    at = AutogradGradient(problem)(np.array(TWO_PLACES))
    names = ("wing_gap_violation", "wing_gap_next_violation")
    assert at.names[-2:] == names and np.all(np.abs(at.margins[-2:]) < 1e-5)
    x = np.array(TWO_PLACES)[list(problem.free)]
    both = kkt_residual(at.objective_gradient, at.margins, at.jacobian, x, 1e-5)[0]
    one = kkt_residual(at.objective_gradient, at.margins[:-1], at.jacobian[:-1], x, 1e-5)[0]
    assert both < 1e-4 < 1e-2 < one


def test_a_torch_polish_through_eval_optimize_certifies_autograd(tmp_path):
    # a small budget at a coarse resolution: a feasible start (seed 1 finds one at 90 W/kg;
    # seed 0 no longer does since the positive parts' crossing pairs are found) and three
    # SLSQP iterations
    argv = ["optimize", "--task", "accelerate", "--power", "90", "--method", "cmaes"]
    argv += ["--budget", "300", "--seeds", "1", "--out", str(tmp_path), "--quiet"]
    argv += ["--backend", "torch", "--method-config", "polish_iterations=3"]
    argv += ["--env-kwargs", "n_time=32", "n_blade=8"]
    assert main(argv) == 0
    (record,) = read_record_files([tmp_path])
    certificate = record.certificate
    assert certificate["gradient"] == "autograd", certificate
    assert certificate["status"] in ("improved", "no gain"), certificate
    assert record.feasible and record.evaluations <= record.budget
    # one model evaluation per gradient: all its steps cost less than ONE central-difference
    # gradient (1 + 2·26 strokes)
    assert 0 < certificate["evaluations"] < 1 + 2 * 26
