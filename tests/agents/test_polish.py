"""The local polish (agents/polish.py): optimum, optimality residual, constraints, budget.

The analytic problem: maximise f(x) = −Σ_free (x_j − 0.6)² over the 26 free coordinates of
[-1, 1]^28 (coordinates 11 and 25 fixed, like the wings' harmonic N) subject to
Σ_free x_j <= 7.8. Its optimum is the projection of the unconstrained one onto the constraint:
x_j = 0.3 for every free j, f* = −26·0.09 = −2.34, the constraint active with multiplier
λ = 2·0.3 = 0.6; the fixed coordinates keep their start values.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from agents.harness import finish, prepare, run
from agents.polish import (
    UNCERTIFIED,
    BatchEvaluation,
    CentralDifferences,
    Certificate,
    PolishConfig,
    Problem,
    certified,
    describe,
    kkt_residual,
    polish,
    split_settings,
)
from agents.records import SELECTION_POLISHED, SELECTION_REWARD_POLISHED, Record

DIM = 28
FIXED = (11, 25)
FREE = tuple(j for j in range(DIM) if j not in FIXED)
TARGET, CAP = 0.6, 7.8
X_STAR = 0.3  # (26·0.6 − 7.8)/26 below the target on every free coordinate
F_STAR = -len(FREE) * (TARGET - X_STAR) ** 2
# The polish holds one float32 step of every coordinate inside the constraint (|∂g/∂x_j| = 1)
# and reports float32 values: the optimum of the cap lowered by that margin, within the cast.
MARGIN = 1e-9 + len(FREE) * float(np.finfo(np.float32).eps)
X_MARGIN = X_STAR - MARGIN / len(FREE)
F_MARGIN = -len(FREE) * (TARGET - X_MARGIN) ** 2
ROUNDING = len(FREE) * 2 * (TARGET - X_MARGIN) * 2.0**-25  # |Δf| of half a float32 step


class Counted:
    """The analytic problem's batch function, counting evaluated strokes."""

    def __init__(self, nan_objective: bool = False, scale: float = 1.0) -> None:
        self.count = 0
        self.nan_objective = nan_objective
        self.scale = scale  # of the constraint's margin: its float32 step grows with it

    def __call__(self, x: np.ndarray) -> BatchEvaluation:
        assert np.all(np.abs(x) <= 1.0), "the polish left the box"
        self.count += x.shape[0]
        free = x[:, FREE]
        objective = -np.sum((free - TARGET) ** 2, axis=1)
        if self.nan_objective:
            objective = np.full_like(objective, np.nan)
        margins = self.scale * (CAP - free.sum(axis=1))[:, None]
        return BatchEvaluation(objective, margins, margins[:, 0] >= 0.0, ("sum",))


def problem(evaluate: Counted) -> Problem:
    return Problem(evaluate, DIM, FREE)


def start() -> np.ndarray:
    x = np.zeros(DIM)
    x[list(FIXED)] = 0.5  # a bin centre, as CMA-ES leaves the harmonic N
    return x


def test_reaches_the_known_constrained_optimum_and_certifies_it():
    evaluate = Counted()
    result = polish(problem(evaluate), start(), 5_000, PolishConfig())
    c = result.certificate
    assert c.status == "improved" and c.converged
    assert PolishConfig().margin == 1e-9
    assert F_STAR - F_MARGIN == pytest.approx(2 * 0.3 * MARGIN, rel=1e-3)  # λ·margin: ~2e-6
    np.testing.assert_allclose(result.stroke[list(FREE)], X_MARGIN, atol=1e-6)
    np.testing.assert_array_equal(result.stroke, result.stroke.astype(np.float32))
    np.testing.assert_array_equal(result.stroke[list(FIXED)], 0.5)  # N stays fixed
    assert result.objective == pytest.approx(F_MARGIN, abs=ROUNDING + 1e-9)
    f_start = -len(FREE) * TARGET**2
    assert c.gain == pytest.approx((F_MARGIN - f_start) / abs(f_start), abs=ROUNDING)
    assert c.kkt_residual < 1e-6
    assert c.active_constraints == ("sum",)
    # the reported stroke satisfies the constraint (held at the margin inside it)
    assert CAP - result.stroke[list(FREE)].sum() >= 0.0
    assert c.evaluations == evaluate.count <= 5_000


def test_a_steep_constraint_stays_active_after_the_float32_cast():
    # |∂g/∂x_j| = 1000: the margin held for the cast is ~3e-3, and rounding the optimum to
    # float32 moves the constraint by up to half that, far beyond the 1e-6 of ``active``: the
    # certificate must still see the constraint as active and the optimum as one.
    result = polish(problem(Counted(scale=1000.0)), start(), 5_000, PolishConfig())
    c = result.certificate
    assert c.status == "improved" and c.converged
    assert c.active_constraints == ("sum",)
    assert c.kkt_residual < 1e-4


def test_the_polish_stops_where_the_kkt_test_passes_and_says_so():
    config = PolishConfig()  # the default stop: 1e-5
    assert config.optimality == 1e-5
    stopped = polish(problem(Counted()), start(), 5_000, config).certificate
    assert stopped.converged and stopped.kkt_residual <= config.optimality
    assert stopped.message.startswith("KKT residual <= 1e-05")
    own = polish(problem(Counted()), start(), 5_000, PolishConfig(optimality=0.0)).certificate
    assert own.converged and not own.message.startswith("KKT")  # scipy's own test
    assert stopped.evaluations <= own.evaluations
    assert certified(stopped) and describe(stopped).count("\n") == 0


def test_an_uncertified_number_says_what_it_means():
    # an allowance for three gradients: the polish gains but cannot converge
    c = polish(problem(Counted()), start(), 3 * 53, PolishConfig()).certificate
    assert not certified(c)
    assert UNCERTIFIED in describe(c)
    with pytest.raises(ValueError, match="polish optimality"):
        PolishConfig(optimality=0.5)


def test_kkt_residual_is_large_away_from_the_optimum():
    grad = CentralDifferences(problem(Counted()), 1e-5)
    # interior point: nothing active, the gradient is unbalanced -> residual 1
    g = grad(start())
    residual, active, _ = kkt_residual(
        g.objective_gradient, g.margins, g.jacobian, np.zeros(26), 1e-6
    )
    assert residual == pytest.approx(1.0) and not active.any()
    # on the constraint but not at its optimum: the multiplier balances only part of ∇f
    x = start()
    x[list(FREE)] = np.linspace(0.0, 0.6, 26)
    x[list(FREE)] *= CAP / x[list(FREE)].sum()
    g = grad(x)
    residual, active, _ = kkt_residual(
        g.objective_gradient, g.margins, g.jacobian, x[list(FREE)], 1e-6
    )
    assert active.all() and residual > 0.3
    # at the optimum it vanishes (to the differences' error)
    x[list(FREE)] = X_STAR
    g = grad(x)
    residual, _, _ = kkt_residual(g.objective_gradient, g.margins, g.jacobian, x[list(FREE)], 1e-6)
    assert residual < 1e-8


def test_CentralDifferences_use_one_batch_and_are_exact_on_a_quadratic():
    evaluate = Counted()
    grad = CentralDifferences(problem(evaluate), 1e-4)
    x = start()
    x[list(FREE)] = np.linspace(-0.9, 0.9, 26)
    g = grad(x)
    assert evaluate.count == grad.cost == 53  # x and x ± h e_j, j free, in one call
    np.testing.assert_allclose(g.objective_gradient, -2.0 * (x[list(FREE)] - TARGET), atol=1e-9)
    np.testing.assert_allclose(g.jacobian, -np.ones((1, 26)), atol=1e-9)


@pytest.mark.parametrize("budget", [120, 400, 1_000])
def test_budget_is_never_exceeded(budget):
    evaluate = Counted()
    result = polish(problem(evaluate), start(), budget, PolishConfig())
    assert evaluate.count <= budget
    assert result.certificate.evaluations == evaluate.count


def test_no_gain_or_failure_keeps_the_start():
    # already at the optimum: nothing to gain, the start is returned as it was
    x = start()
    x[list(FREE)] = X_STAR
    result = polish(problem(Counted()), x, 5_000, PolishConfig())
    assert result.certificate.status == "no gain" and result.certificate.gain == 0.0
    np.testing.assert_array_equal(result.stroke, x)
    assert result.certificate.kkt_residual < 1e-6
    # a model that returns NaN: no feasible improvement, the start is kept
    result = polish(problem(Counted(nan_objective=True)), start(), 2_000, PolishConfig())
    assert not result.improved
    np.testing.assert_array_equal(result.stroke, start())
    # an infeasible start is kept and said so
    x = start()
    x[list(FREE)] = 0.9
    result = polish(problem(Counted()), x, 2_000, PolishConfig())
    assert result.certificate.status.startswith("failed: the start is infeasible")
    np.testing.assert_array_equal(result.stroke, x)
    # an allowance below two gradients does not start
    result = polish(problem(Counted()), start(), 100, PolishConfig())
    assert result.certificate.status.startswith("failed: allowance")
    assert result.certificate.evaluations == 0


@pytest.mark.parametrize(
    "settings",
    [
        {"polish": "bfgs"},
        {"polish_share": 0.95},
        {"polish_share": "0.3"},
        {"polish_step": 0.0},
        {"polish_tolerance": math.nan},
        {"polish_iterations": 0},
    ],
)
def test_bad_settings_are_rejected_before_any_computation(settings):
    with pytest.raises(ValueError, match="polish"):
        split_settings("cmaes", settings)
    with pytest.raises(ValueError, match="polish"):
        prepare("cmaes", "accelerate", 60.0, 2_000, [0], method_config=settings)


def test_defaults_and_the_method_setting_that_turns_it_off():
    assert split_settings("cmaes", {})[0].method == "slsqp"
    assert split_settings("pso", {"swarm_size": 20}) == (PolishConfig(), {"swarm_size": 20})
    assert not split_settings("random", {})[0].enabled
    assert not split_settings("cmaes", {"polish": "none"})[0].enabled
    assert PolishConfig().reserve(12_000, 53) == 4_800
    assert PolishConfig().reserve(250, 53) == 0  # below two gradients: no polish
    assert PolishConfig(method="none").reserve(12_000, 53) == 0


def test_task_constraints_are_the_penalised_ones():
    # The margins the polish holds are those whose negative parts the reward penalises: the
    # env's normalised violation sum is their sum, and its feasibility test is all of them >= 0.
    rng = np.random.default_rng(3)
    actions = rng.uniform(-1.0, 1.0, (256, DIM))
    for env_id, value in (("TandemWing/LevelFlight-v0", 1.5), ("TandemWing/Accelerate-v0", 60.0)):
        env = gym.make(env_id, disable_env_checker=True)
        problem = env.unwrapped.problem()
        evaluation = problem.evaluate(actions, value)
        violation = problem.declaration.score(evaluation.result, problem.config).total
        margins = evaluation.margins
        np.testing.assert_allclose(
            np.maximum(0.0, -margins).sum(axis=1), violation, rtol=1e-12, atol=1e-15
        )
        np.testing.assert_array_equal(np.all(margins >= 0.0, axis=1), evaluation.feasible)
        env.close()


def test_harness_polish_counts_in_the_budget_and_certifies_the_record():
    polished, plain = (
        run(
            "cmaes",
            "accelerate",
            60.0,
            2_500,
            [0],
            objective="vertical",
            progress=False,
            method_config=config,
        )[0]
        for config in ({}, {"polish": "none"})
    )
    for record in (polished, plain):
        assert record.feasible and record.evaluations <= record.budget == 2_500
        assert Record.from_dict(record.to_dict()) == record  # the certificate round-trips
    assert plain.certificate == Certificate.off().to_dict()
    c = polished.certificate
    assert c["method"] == "slsqp" and c["allowance"] >= PolishConfig().reserve(2_500, 53)
    if c["status"] == "improved":
        assert polished.selection == SELECTION_POLISHED
        assert polished.objective == pytest.approx(c["objective_after"], rel=1e-12)
        assert polished.objective > c["objective_before"]
    else:  # the search's stroke is kept and the record says so
        assert polished.objective == c["objective_before"]


def test_a_search_that_saw_no_feasible_stroke_is_polished_onto_the_constraints(recwarn):
    # random search at V = 1 m/s, seed 1: none of its 1 600 strokes flies (most random strokes
    # miss the weight by far); the polish starts from its best-reward stroke all the same
    (record,) = run(
        "random", "level", 1.0, 2_000, [1], progress=False,
        method_config={"polish": "slsqp", "swarm_size": 20},
    )  # fmt: skip
    c = record.certificate
    assert record.selection == SELECTION_REWARD_POLISHED and c["status"] == "improved"
    assert c["gain"] is None  # no feasible objective before to compare with
    # the re-evaluation in the env (the stroke as a float32 action) flies, with the polish's value
    assert record.feasible and record.evaluations <= record.budget == 2_000
    assert record.objective == c["objective_after"]
    assert not [w for w in recwarn if "differs from the search" in str(w.message)]


def test_central_differences_evaluate_a_bound_neighbour_once():
    # on a bound the one-sided difference's outer neighbour is the point itself: evaluated
    # once (row 0), the gradient the one-sided difference all the same (f'' = −2: error ∓h)
    evaluate, h = Counted(), 1e-4
    grad = CentralDifferences(problem(evaluate), h)
    x = start()
    x[list(FREE)] = np.linspace(-0.9, 0.9, 26)
    x[[0, 1, 2]], x[[3, 4]] = 1.0, -1.0
    g = grad(x)
    assert evaluate.count == g.evaluations == grad.cost - 5
    side = np.where(x[list(FREE)] == 1.0, h, np.where(x[list(FREE)] == -1.0, -h, 0.0))
    np.testing.assert_allclose(
        g.objective_gradient, side - 2.0 * (x[list(FREE)] - TARGET), atol=1e-9
    )
    np.testing.assert_allclose(g.jacobian, -np.ones((1, 26)), atol=1e-9)


def test_the_default_tolerance_certifies_an_ill_conditioned_slope():
    # SLSQP's own stop, |Δf| < ftol (absolute), fires on a small objective with curvatures
    # 1 to 100 while its KKT residual is still 1e-3: at ftol 1e-10 the polish ends there,
    # uncertified (and says why); at the default (1e-14) it runs on and certifies
    curvature = np.logspace(0, 2, len(FREE))

    def evaluate(x: np.ndarray) -> BatchEvaluation:
        free = x[:, FREE]
        objective = -1e-4 * np.sum(curvature * (free - TARGET) ** 2, axis=1)
        margins = (CAP - free.sum(axis=1))[:, None]
        return BatchEvaluation(objective, margins, margins[:, 0] >= 0.0, ("sum",))

    ill = Problem(evaluate, DIM, FREE)
    early = polish(ill, start(), 20_000, PolishConfig(tolerance=1e-10)).certificate
    assert early.message == "Optimization terminated successfully" and not certified(early)
    assert early.kkt_residual > 1e-3 and "(KKT residual above 1e-04: " in describe(early)
    default = polish(ill, start(), 20_000, PolishConfig()).certificate
    assert certified(default) and default.kkt_residual < early.kkt_residual / 30


CURVATURE = np.logspace(0, 2, len(FREE))
"""Curvatures of the ill-conditioned problem below, 1 to 100."""


def ill_conditioned(counted: list[int]) -> Problem:
    """Maximise −Σ c_j (x_j − 0.6)² (c: :data:`CURVATURE`) subject to Σ x_j <= 7.8, with the
    exact derivatives an autograd model gives (``differentiate``, one evaluation a stroke); its
    optimum x_j = 0.6 − λ/(2 c_j), λ from the active constraint. ``counted[0]`` counts strokes."""

    def evaluate(x: np.ndarray) -> BatchEvaluation:
        counted[0] += x.shape[0]
        free = x[:, FREE]
        margins = (CAP - free.sum(axis=1))[:, None]
        objective = -np.sum(CURVATURE * (free - TARGET) ** 2, axis=1)
        return BatchEvaluation(objective, margins, margins[:, 0] >= 0.0, ("sum",))

    def differentiate(x: np.ndarray) -> tuple[BatchEvaluation, np.ndarray, np.ndarray]:
        gradient, jacobian = np.zeros_like(x), np.zeros((x.shape[0], 1, DIM))
        gradient[:, FREE] = -2.0 * CURVATURE * (x[:, FREE] - TARGET)
        jacobian[:, 0, FREE] = -1.0
        return evaluate(x), gradient, jacobian

    return Problem(evaluate, DIM, FREE, differentiate=differentiate)


def test_a_climb_short_of_the_kkt_stop_is_finished_by_exact_gradients():
    # 1 000 evaluations: the climb by central differences (53 a gradient) runs out short of
    # the KKT stop on the ill-conditioned problem, having kept PolishConfig.finish (0.1) of its
    # allowance back; finish() goes on from its stroke at one evaluation a gradient and
    # certifies the known optimum. With nothing kept back the same budget leaves it uncertified.
    unfinished = polish(ill_conditioned([0]), start(), 1_000, PolishConfig(finish=0.0))
    assert unfinished.certificate.message == "allowance used up"
    assert not certified(unfinished.certificate)
    counted = [0]
    problem = ill_conditioned(counted)
    climbed = polish(problem, start(), 1_000, PolishConfig())
    assert not certified(climbed.certificate)
    assert climbed.certificate.evaluations <= 0.9 * (1_000 - 53) + 53  # the share kept back
    finished = finish(problem, climbed, 1_000 - climbed.certificate.evaluations, PolishConfig())
    c = finished.certificate
    assert certified(c) and c.gradient == "central differences, then autograd", c
    assert "(finished by autograd)" in describe(c)
    assert counted[0] == c.evaluations <= 1_000
    assert c.objective_before == climbed.certificate.objective_before
    multiplier = (len(FREE) * TARGET - CAP + MARGIN) / np.sum(0.5 / CURVATURE)
    np.testing.assert_allclose(
        finished.stroke[list(FREE)], TARGET - multiplier / (2 * CURVATURE), atol=1e-4
    )


def test_a_certified_polish_is_not_finished():
    # the share is held back, not spent: a climb that certifies on the rest is left as it is
    climbed = polish(ill_conditioned([0]), start(), 2_000, PolishConfig())
    assert certified(climbed.certificate)
    assert climbed.certificate.gradient == "central differences"
    assert finish(ill_conditioned([0]), climbed, 1_000, PolishConfig()) is climbed


def test_a_finish_that_fails_leaves_the_climb_by_differences_and_says_so():
    # a model that cannot differentiate at the finish (it raises): the differences' climb and
    # its stroke stand, and the message says what became of the finish
    problem = ill_conditioned([0])

    def broken(x: np.ndarray) -> tuple[BatchEvaluation, np.ndarray, np.ndarray]:
        raise ValueError("no derivatives here")

    problem = Problem(problem.evaluate, DIM, FREE, differentiate=broken)
    climbed = polish(problem, start(), 1_000, PolishConfig())
    finished = finish(problem, climbed, 200, PolishConfig())
    c = finished.certificate
    assert c.gradient == "central differences" and c.status == "improved"
    assert c.message == "allowance used up; the finish failed: ValueError: no derivatives here"
    np.testing.assert_array_equal(finished.stroke, climbed.stroke)
    assert not certified(c)
