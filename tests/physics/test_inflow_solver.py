"""The per-annulus inflow solver (docs/model.md §5.6): its slope, its
tolerance, the reuse of its last force sweep, and its cost in force sweeps."""

from __future__ import annotations

import numpy as np
import pytest

import tandem_env as te
from tandem_env import ModelOptions, evaluate
from tandem_env.physics import blade, cycle, induction, model
from tandem_env.physics.bundle import Section, WingStroke
from tandem_env.physics.kinematics import fill_angle_history, wing_params_radians

INSECT = te.DRAGONFLY
OPTIONS = ModelOptions()
RHO = INSECT.air_density
SETTINGS = model.kernel_settings(INSECT, OPTIONS, OPTIONS.n_time)


def random_strokes(n: int, seed: int) -> np.ndarray:
    return te.normalised_to_physical(np.random.default_rng(seed).uniform(-1.0, 1.0, (n, 28)))


def fore_wing_frames(stroke: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frame coefficients (n_time, N_COEF) of the fore-wing and its parameters (Hz, rad, -)."""
    params = wing_params_radians(stroke[:14])
    angles = np.empty((OPTIONS.n_time, 9))
    weight = np.empty(OPTIONS.n_time)
    fill_angle_history(params, OPTIONS.n_time, angles, weight)
    coef = np.empty((OPTIONS.n_time, blade.N_COEF))
    blade.fill_frame_coefficients(angles, weight, params[13], False, 1, coef)
    return coef, params


def annuli():
    nodes, consts = model.wing_tables(INSECT.fore, OPTIONS.n_blade, RHO)
    for j in range(OPTIONS.n_blade):
        yield cycle.section_at(nodes, j, consts, RHO)


def test_slope_of_the_mean_normal_force_matches_finite_differences() -> None:
    """The analytic dF̄_n/dv of a sweep is the derivative of the swept mean force."""
    samples = np.empty((induction.N_SAMPLE, OPTIONS.n_time))
    errors = []
    for stroke in random_strokes(6, seed=11):
        coef, _ = fore_wing_frames(stroke)
        for annulus in annuli():
            for v_t, v_n in ((0.0, 0.0), (0.8, 0.3), (1.9, 1.4)):
                induction.normal_force_sweep(coef, annulus, v_t, v_n, samples)
                slope = induction.normal_force_slope(coef, annulus, samples)
                # a step small against the element's speeds (they vanish at the root in hover)
                flapping = annulus.r * np.abs(coef[:, [blade.C_AU, blade.C_AV]]).max()
                step = 1e-4 * max(flapping, v_t, v_n)
                above = induction.mean_normal_force(coef, annulus, v_t, v_n + step)
                below = induction.mean_normal_force(coef, annulus, v_t, v_n - step)
                central = (above - below) / (2.0 * step)
                errors.append(abs(slope - central) / max(abs(central), 1e-9))
    assert len(errors) >= 400
    assert max(errors) < 1e-6


def coefficient_models() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Kernel tables of non-paper force-coefficient models and the angles of attack [deg] where
    their force jumps (Dickinson's C_L(90°) ≠ 0 changes sign there) or has a kink (table nodes)."""
    fit = te.SinusoidalFit.dickinson_1999()
    quarter = np.linspace(0.0, 90.0, 19)
    half = np.linspace(0.0, 180.0, 37)
    leading_edge = te.TabulatedCoefficients(quarter, fit.lift(quarter), fit.drag(quarter))
    full = te.TabulatedCoefficients(
        half, 1.5 * np.sin(np.deg2rad(2.0 * half)), 0.2 + 3.0 * np.sin(np.deg2rad(half)) ** 2
    )
    return {
        "dickinson1999": (fit.table(), np.array([90.0])),
        "table 0-90": (leading_edge.table(), np.union1d(quarter, 180.0 - quarter)),
        "table 0-180": (full.table(), half),
    }


def breaks_crossed(before: np.ndarray, after: np.ndarray, breaks: np.ndarray) -> bool:
    """Whether any sample's α crossed a break, or its v changed sign (sign(v) in Γ_t), between
    two sweeps' samples."""

    def cells(samples):
        alpha = np.rad2deg(np.arctan2(np.abs(samples[induction.S_V]), samples[induction.S_U]))
        return np.searchsorted(breaks, alpha), np.sign(samples[induction.S_V])

    (cell_a, side_a), (cell_b, side_b) = cells(before), cells(after)
    return not (np.array_equal(cell_a, cell_b) and np.array_equal(side_a, side_b))


@pytest.mark.parametrize("name", ["dickinson1999", "table 0-90", "table 0-180"])
def test_slope_with_a_coefficient_model_matches_finite_differences(name: str) -> None:
    """With a force-coefficient model other than the paper's, the slope (from the model's C_L,
    C_D and their α-rates) is the derivative of the swept mean force wherever it has one: cases where a sample's α crosses a jump or kink of the model
    within the difference step are left out (the mean force has no derivative there)."""
    table, breaks = coefficient_models()[name]
    samples = np.empty((induction.N_SAMPLE, OPTIONS.n_time))
    shifted = np.empty_like(samples)
    errors = []
    for stroke in random_strokes(6, seed=11):
        coef, _ = fore_wing_frames(stroke)
        for annulus in annuli():
            for v_t, v_n in ((0.0, 0.0), (0.8, 0.3), (1.9, 1.4)):
                induction.normal_force_sweep(coef, annulus, v_t, v_n, samples, table)
                slope = induction.normal_force_slope(coef, annulus, samples, table)
                flapping = annulus.r * np.abs(coef[:, [blade.C_AU, blade.C_AV]]).max()
                step = 1e-4 * max(flapping, v_t, v_n)
                above = induction.normal_force_sweep(coef, annulus, v_t, v_n + step, shifted, table)
                record = shifted.copy()
                below = induction.normal_force_sweep(coef, annulus, v_t, v_n - step, shifted, table)
                if breaks_crossed(record, shifted, breaks):
                    continue
                central = (above - below) / (2.0 * step)
                errors.append(abs(slope - central) / max(abs(central), 1e-9))
    print(f"{name}: {len(errors)} of 432 cases smooth, max error {max(errors):.1e}")
    assert len(errors) >= 300
    assert max(errors) < 1e-6


def test_model_slope_of_the_paper_formula_restated_as_a_fit_is_the_analytic_slope() -> None:
    """The paper's C_t·sin 2α and C_d0·cos²α + C_d90·sin²α written as a SinusoidalFit: the
    model slope of an element (from C_L, C_D and their α-rates) equals the paper's analytic
    one, at any state and across v = 0, where the fit's sign(v)·C_L(α) is smooth."""
    wing = INSECT.fore
    ct, cd0, cd90 = (
        wing.translational_coefficient,
        wing.drag_coefficient_0,
        wing.drag_coefficient_90,
    )
    fit = te.SinusoidalFit(0.0, ct, 2.0, 0.0, 0.5 * (cd0 + cd90), 0.5 * (cd90 - cd0), 2.0, 0.0)
    table = fit.table()
    rng = np.random.default_rng(3)
    chord = 0.008
    m11, m22 = 0.0, 0.25 * np.pi * RHO * chord**2
    section = Section(0.0, chord, 0.0, m11, m22, 0.0, 0.0, RHO, ct, cd0, cd90, 0.0, 0.0, 0.0)
    errors = []
    for i in range(2000):
        speed = rng.uniform(0.05, 5.0)
        if i % 2:  # on or next to the chord line, either edge leading
            u = speed * rng.choice([-1.0, 1.0])
            v = speed * rng.choice([0.0, 1e-9, -1e-9, 3e-7, -3e-7])
        else:
            angle = rng.uniform(-np.pi, np.pi)
            u, v = speed * np.cos(angle), speed * np.sin(angle)
        a, b = rng.uniform(-1.0, 1.0, 2)
        c, d, spin = rng.normal(0.0, 50.0, 3)
        state = (u, v, a, b, c, d, spin, section)
        exact = induction.normal_force_rate(*state)
        model_rate = induction.normal_force_rate_model(*state, table)
        scale = RHO * chord * speed * (ct + cd90)  # size of the translational slope
        errors.append(abs(model_rate - exact) / scale)
    assert max(errors) < 1e-12


@pytest.mark.parametrize("speed", [0.0, 1.0, 2.0])
def test_default_solve_agrees_with_a_tight_solve_to_its_tolerance(speed: float) -> None:
    """L/W, T, D and P at the default tolerance (1e-4) against a solve to 1e-10, relative to
    the value with a floor of 0.1·W for forces (0.1 for L/W; docs/model.md §11)."""
    strokes = random_strokes(300, seed=1234)
    default = evaluate(strokes, speed, options=ModelOptions(slipstream="mean"))
    tight_solve = ModelOptions(tolerance=1e-10, max_evaluations=100, slipstream="mean")
    tight = evaluate(strokes, speed, options=tight_solve)
    assert default.induction_converged.all() and tight.induction_converged.all()
    weight = INSECT.weight
    for name, floor in (("lift_to_weight", 0.1), ("thrust", 0.1 * weight), ("drag", 0.1 * weight)):
        reference = getattr(tight, name)
        error = np.abs(getattr(default, name) - reference) / np.maximum(np.abs(reference), floor)
        print(f"V={speed}: {name} median {np.median(error):.1e} max {error.max():.1e}")
        assert error.max() < OPTIONS.tolerance, name
    error = np.abs(default.power - tight.power) / tight.power
    print(f"V={speed}: power median {np.median(error):.1e} max {error.max():.1e}")
    assert error.max() < OPTIONS.tolerance


@pytest.mark.parametrize("speed", [0.0, 1.5])
def test_cycle_reuses_the_last_sweep_exactly(speed: float) -> None:
    """The cycle integrals reuse the solver's last sweep: imposing the solved inflow and
    recomputing every element force gives bit-identical cycle means."""
    nodes, consts = model.wing_tables(INSECT.fore, OPTIONS.n_blade, RHO)
    checked = 0
    for stroke in random_strokes(8, seed=21):
        coef, params = fore_wing_frames(stroke)
        v_t, v_n = speed * np.cos(params[13]), speed * np.sin(params[13])
        runs = []
        inflow = np.zeros(OPTIONS.n_blade)
        for solve in (True, False):
            out = np.empty(cycle.N_WING_OUT)
            solved = np.empty(OPTIONS.n_blade)
            histories = np.empty((OPTIONS.n_time, 5))
            wing = WingStroke(
                coef, nodes, consts, None, params[0], params[1], v_t, v_n, coef[:, blade.C_WEIGHT],
                np.empty(0),
            )  # fmt: skip
            cycle.wing_cycle(wing, SETTINGS, inflow.copy(), solve, solved, out, histories)
            if solve:
                inflow = solved.copy()
            runs.append((out, histories))
        checked += int((inflow > 0.0).sum())
        (solved_out, solved_hist), (imposed_out, imposed_hist) = runs
        np.testing.assert_array_equal(solved_hist, imposed_hist)
        np.testing.assert_array_equal(
            solved_out[: cycle.W_CONVERGED], imposed_out[: cycle.W_CONVERGED]
        )
    assert checked >= 40  # not vacuous: many annuli carry an induced velocity


def sweeps_of_solved_annuli(
    strokes: np.ndarray, speed: float, table: np.ndarray | None = None
) -> np.ndarray:
    counts = []
    for stroke in strokes:
        coef, params = fore_wing_frames(stroke)
        v_t, v_n = speed * np.cos(params[13]), speed * np.sin(params[13])
        for annulus in annuli():
            _, sweeps, ok = induction.solve_annulus(
                coef, annulus, v_t, v_n, params[1], SETTINGS, table
            )
            assert ok
            if sweeps > 1:
                counts.append(sweeps)
    return np.array(counts)


@pytest.mark.parametrize("speed", [0.0, 2.0])
def test_newton_needs_few_force_sweeps(speed: float) -> None:
    """With the exact slope, annuli that need a solve take about three sweeps (the one at
    v = 0 included); the bracket fallback keeps the worst case bounded."""
    counts = sweeps_of_solved_annuli(random_strokes(60, seed=5), speed)
    print(f"V={speed}: mean {counts.mean():.2f} sweeps, max {counts.max()}")
    assert counts.size >= 300
    assert counts.mean() < 3.5
    assert counts.max() <= 10


@pytest.mark.parametrize("name", ["dickinson1999", "table 0-90", "table 0-180"])
@pytest.mark.parametrize("speed", [0.0, 2.0])
def test_newton_stays_fast_with_a_coefficient_model(name: str, speed: float) -> None:
    """The model's exact slope keeps Newton's cost of the paper's model: about three sweeps per
    solved annulus, every annulus converged (the jumps of Dickinson's fit at α = 90° cost a few
    annuli some bisections)."""
    counts = sweeps_of_solved_annuli(
        random_strokes(60, seed=5), speed, coefficient_models()[name][0]
    )
    print(f"{name}, V={speed}: mean {counts.mean():.2f} sweeps, max {counts.max()}")
    assert counts.size >= 300
    assert counts.mean() < 3.5


@pytest.mark.parametrize("v_normal", [-1.5, -0.3, 0.0, 2.0])
def test_solver_meets_the_momentum_balance_for_any_free_stream(v_normal: float) -> None:
    """Glauert's balance holds also where the free stream leaves the swept disc (V_n' < 0, a
    descent through the stroke plane), where m(v) is not monotone and the bracket must hold."""
    checked = 0
    tight = model.kernel_settings(INSECT, ModelOptions(tolerance=1e-8, max_evaluations=60), 1)
    for stroke in random_strokes(20, seed=61):
        coef, params = fore_wing_frames(stroke)
        for annulus in annuli():
            v_i, _, ok = induction.solve_annulus(coef, annulus, 0.5, v_normal, params[1], tight)
            assert ok
            f0 = induction.mean_normal_force(coef, annulus, 0.5, v_normal)
            if f0 <= 0.0:
                assert v_i == 0.0
                continue
            force = induction.mean_normal_force(coef, annulus, 0.5, v_normal + v_i)
            momentum = 4 * RHO * params[1] * annulus.r * v_i * np.hypot(0.5, v_normal + v_i)
            assert v_i > 0.0
            assert force == pytest.approx(momentum, rel=1e-6, abs=1e-7 * f0)
            checked += 1
    assert checked >= 40
