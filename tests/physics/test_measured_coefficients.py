"""Force-coefficient models per wing: the paper's (default), a C_t override, Dickinson et al.'s
(1999) fit and tabulated C_L(α), C_D(α), evaluated in the compiled kernel over 0-180°."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import tandem_env as te
from tandem_env import (
    Dragonfly,
    MeasuredWing,
    ModelOptions,
    PaperCoefficients,
    SinusoidalFit,
    TabulatedCoefficients,
    evaluate,
    evaluate_measured,
)
from tandem_env.physics.blade import element_force
from tandem_env.physics.bundle import Section

RHO = 1.225
NO_INFLOW = ModelOptions(induction="none")
DICKINSON = SinusoidalFit.dickinson_1999()


def random_strokes(n: int, seed: int) -> np.ndarray:
    return te.normalised_to_physical(np.random.default_rng(seed).uniform(-1, 1, (n, 28)))


def with_model(model, insect: Dragonfly = te.DRAGONFLY, **wing_fields) -> Dragonfly:
    fore = dataclasses.replace(insect.fore, coefficients=model, **wing_fields)
    hind = dataclasses.replace(insect.hind, coefficients=model, **wing_fields)
    return dataclasses.replace(insect, fore=fore, hind=hind)


def plate_coefficients(table: np.ndarray | None, alpha_deg: float, ct=2.0, cd0=0.1, cd90=3.0):
    """(C_L, C_D) the kernel's element force implies for a plate moving at α [deg] to its chord
    (+e_c edge leading below 90°), lift taken towards the side the leading edge is tilted to."""
    alpha = np.deg2rad(alpha_deg)
    speed, chord = 3.0, 0.006
    u, v = speed * np.cos(alpha), -speed * np.sin(alpha)
    plate = Section(chord=chord, rho=RHO, ct=ct, cd0=cd0, cd90=cd90, cr=np.pi)
    args = (u, v, 0.0, 0.0, 0.0, plate)
    force = np.array(element_force(*args) if table is None else element_force(*args, table))
    motion = np.array([u, v]) / speed
    normal = np.array([-motion[1], motion[0]])
    q = 0.5 * RHO * speed**2 * chord
    return force @ normal / q, -(force @ motion) / q


# --- Dickinson, Lehmann & Sane (1999) -----------------------------------------------------------

#: C_L = 0.225 + 1.58·sin(2.13α − 7.20°), C_D = 1.92 − 1.55·cos(2.04α − 9.82°) at 10°, 45°, 80°
#: (Dickinson et al. 1999, Science 284: 1954, Fig. 3 fit), to the 3 decimals worked out by hand.
PUBLISHED = {10.0: (0.610, 0.396), 45.0: (1.805, 1.704), 80.0: (0.682, 3.306)}


@pytest.mark.parametrize("alpha", sorted(PUBLISHED))
def test_dickinson_fit_reproduces_its_published_coefficients_in_the_kernel(alpha: float) -> None:
    lift, drag = plate_coefficients(DICKINSON.table(), alpha)
    assert lift == pytest.approx(PUBLISHED[alpha][0], abs=6e-4)
    assert drag == pytest.approx(PUBLISHED[alpha][1], abs=6e-4)
    np.testing.assert_allclose(DICKINSON.lift(alpha), lift, rtol=1e-12)
    np.testing.assert_allclose(DICKINSON.drag(alpha), drag, rtol=1e-12)


@pytest.mark.parametrize("alpha", sorted(PUBLISHED))
def test_dickinson_fit_on_a_whole_steady_wing(alpha: float) -> None:
    """A motionless wing at α in the free stream carries ½ρV²S·C_L(α) up and ½ρV²S·C_D(α) back."""
    insect = with_model("dickinson1999")
    n, speed = 32, 2.0
    zeros = np.zeros(n)
    steady = MeasuredWing(zeros, zeros, np.full(n, np.deg2rad(90.0 - alpha)), 40.0, 0.0)
    result = evaluate_measured(steady, steady, speed, insect=insect, options=NO_INFLOW)
    lift_coefficient, drag_coefficient = PUBLISHED[alpha]
    for name in ("fore", "hind"):
        area = getattr(insect, name).area
        q_area = 0.5 * RHO * speed**2 * area
        lift = getattr(result, f"{name}_lift_to_weight")[0] * insect.weight
        back = -getattr(result, f"{name}_horizontal_force")[0]
        assert lift == pytest.approx(2 * q_area * lift_coefficient, rel=2e-3)
        assert back == pytest.approx(2 * q_area * drag_coefficient, rel=2e-3)


# --- conventions over 0-180° ----------------------------------------------------------------------

MODELS = {
    "paper": None,
    "dickinson": DICKINSON.table(),
    "table": TabulatedCoefficients(
        [0.0, 20.0, 45.0, 70.0, 90.0], [0.1, 1.2, 1.6, 0.9, 0.2], [0.2, 0.8, 1.9, 2.9, 3.2]
    ).table(),
}


@pytest.mark.parametrize("model", sorted(MODELS))
@pytest.mark.parametrize("alpha", [5.0, 30.0, 60.0, 85.0])
def test_plate_symmetries(model: str, alpha: float) -> None:
    """A flat plate: mirroring the motion about the chord line (v → −v) mirrors the force, and
    moving it the other way along the chord (u → −u: the other edge leads, α → 180° − α) mirrors
    it about the chord normal."""
    table = MODELS[model]
    a = np.deg2rad(alpha)
    u, v = 2.0 * np.cos(a), -2.0 * np.sin(a)
    common = (0.0, 0.0, 0.0, Section(chord=0.006, rho=RHO, ct=2.0, cd0=0.1, cd90=3.0, cr=np.pi))

    def force(uu, vv):
        args = (uu, vv, *common)
        return np.array(element_force(*args) if table is None else element_force(*args, table))

    fc, fn = force(u, v)
    np.testing.assert_allclose(force(u, -v), [fc, -fn], rtol=1e-13)
    np.testing.assert_allclose(force(-u, v), [-fc, fn], rtol=1e-13)
    lift, drag = plate_coefficients(table, alpha)
    assert lift > 0.0 and drag > 0.0  # leading edge up: lift up, drag against the motion
    assert plate_coefficients(table, 180.0 - alpha)[0] == pytest.approx(-lift, rel=1e-12)


def test_paper_form_as_a_fit_is_the_paper_model() -> None:
    """C_L = C_t·sin 2α, C_D = C_d(0)cos²α + C_d(π/2)sin²α written as a sinusoidal fit
    (a = 0, b = C_t, c = 2, e = (C_d0 + C_d90)/2, f = (C_d90 − C_d0)/2, g = 2) gives the paper's
    results through the other code path, over random strokes (every α in 0-180°), the vortex
    reading's shed circulation included (``blade.translational_terms``)."""
    geometry = {"drag_coefficient_0": 0.4, "drag_coefficient_90": 2.4}
    paper = with_model(PaperCoefficients(translational=1.2), **geometry)
    fit = with_model(SinusoidalFit(0.0, 1.2, 2.0, 0.0, 1.4, 1.0, 2.0, 0.0), **geometry)
    strokes, speeds = random_strokes(24, 1), np.linspace(0.0, 2.0, 24)
    vortex = ModelOptions(slipstream="vortex")
    for options, rtol in ((NO_INFLOW, 1e-12), (ModelOptions(), 1e-9), (vortex, 1e-9)):
        a = evaluate(strokes, speeds, insect=paper, options=options)
        b = evaluate(strokes, speeds, insect=fit, options=options)
        for name in ("lift_to_weight", "thrust", "drag", "power", "fore_inflow", "hind_inflow"):
            scale = np.abs(getattr(a, name)).max()
            np.testing.assert_allclose(
                getattr(b, name), getattr(a, name), rtol=rtol, atol=rtol * scale, err_msg=name
            )


def test_tables_converge_to_the_curve_they_sample_at_second_order() -> None:
    """Linear interpolation of the paper's curves on a grid of step h: the error in the results
    falls by 4× per halving of h."""
    strokes, speeds = random_strokes(16, 2), np.linspace(0.5, 2.0, 16)
    paper = evaluate(strokes, speeds, options=NO_INFLOW)
    errors = []
    for step in (10.0, 5.0, 2.5):
        alpha = np.arange(0.0, 180.0 + step / 2, step)
        models = [
            TabulatedCoefficients(alpha, *wing.force_coefficients(alpha))
            for wing in (te.DRAGONFLY.fore, te.DRAGONFLY.hind)
        ]
        insect = te.DRAGONFLY.with_coefficients(*models)
        table = evaluate(strokes, speeds, insect=insect, options=NO_INFLOW)
        errors.append(np.abs(table.lift_to_weight - paper.lift_to_weight).max())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 3.0) & (ratios < 5.5)), ratios


def test_a_quarter_table_is_read_from_the_leading_edge() -> None:
    """A 0-90° table is the full 0-180° table mirrored by the plate symmetry (equal where the
    mirrored table is continuous, C_L(90°) = 0)."""
    alpha = [0.0, 30.0, 60.0, 90.0]
    lift, drag = [0.0, 1.0, 0.8, 0.0], [0.2, 1.0, 2.5, 3.0]
    quarter = TabulatedCoefficients(alpha, lift, drag)
    full = TabulatedCoefficients(
        [*alpha, 120.0, 150.0, 180.0], [*lift, -0.8, -1.0, -0.0], [*drag, 2.5, 1.0, 0.2]
    )
    assert quarter.from_leading_edge and not full.from_leading_edge
    for angle in (0.0, 15.0, 45.0, 89.0, 91.0, 100.0, 135.0, 170.0, 180.0):
        np.testing.assert_allclose(
            plate_coefficients(quarter.table(), angle),
            plate_coefficients(full.table(), angle),
            rtol=1e-12,
            atol=1e-15,
        )
        assert quarter.lift_at(angle) == pytest.approx(full.lift_at(angle), abs=1e-15)


def test_default_model_and_a_ct_override() -> None:
    strokes = random_strokes(8, 3)
    default = evaluate(strokes, 1.0)
    fore, hind = te.DRAGONFLY.fore, te.DRAGONFLY.hind
    same = te.DRAGONFLY.with_coefficients(
        PaperCoefficients(translational=fore.translational_coefficient),
        PaperCoefficients(translational=hind.translational_coefficient),
    )
    for name, arr in default.as_dict().items():  # the override path is the paper path
        assert np.array_equal(arr, getattr(evaluate(strokes, 1.0, insect=same), name)), name
    # with no flapping and no inflow, the lift is proportional to C_t
    zeros = np.zeros(16)
    steady = MeasuredWing(zeros, zeros, np.full(16, np.deg2rad(60.0)), 40.0, 0.0)
    doubled = te.DRAGONFLY.with_coefficients(
        PaperCoefficients(translational=2 * fore.translational_coefficient),
        PaperCoefficients(translational=2 * hind.translational_coefficient),
    )
    a = evaluate_measured(steady, steady, 2.0, options=NO_INFLOW)
    b = evaluate_measured(steady, steady, 2.0, insect=doubled, options=NO_INFLOW)
    assert b.fore_lift_to_weight[0] == pytest.approx(2 * a.fore_lift_to_weight[0], rel=1e-12)


def test_each_wing_has_its_own_model() -> None:
    """Under the momentum readings the fore-wing flies ahead of the hind-wing's slipstream:
    changing only the hind-wing's model leaves the fore-wing's results as they were. Under the
    vortex reading the hind pair acts on the fore pair too, so its model reaches the fore's."""
    strokes = random_strokes(8, 4)
    mixed_insect = te.DRAGONFLY.with_coefficients(hind="dickinson1999")
    mean = ModelOptions(slipstream="mean")
    base = evaluate(strokes, 1.0, options=mean)
    mixed = evaluate(strokes, 1.0, insect=mixed_insect, options=mean)
    for name in ("fore_lift_to_weight", "fore_horizontal_force", "fore_power", "fore_inflow"):
        np.testing.assert_allclose(getattr(mixed, name), getattr(base, name), rtol=1e-13)
    assert not np.allclose(mixed.hind_lift_to_weight, base.hind_lift_to_weight)
    vortex = ModelOptions(slipstream="vortex")
    base = evaluate(strokes, 1.0, options=vortex)
    mixed = evaluate(strokes, 1.0, insect=mixed_insect, options=vortex)
    assert not np.allclose(mixed.fore_lift_to_weight, base.fore_lift_to_weight, rtol=1e-6)


# --- validation -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "spec, message",
    [
        (
            "dickinson",
            r"coefficients.model = 'dickinson' is not a known.*allowed: paper, dickinson1999",
        ),
        ({"model": "table", "alpha": [0, 90]}, r"model 'table'.*drag"),
        (42, r"coefficients = 42; allowed: a model object"),
        ({"model": "dickinson1999", "lift_offset": 0.3}, r"takes no parameters"),
        ({"model": "paper", "translational": -1.0}, r"PaperCoefficients.translational = -1.0"),
    ],
)
def test_bad_coefficient_models_are_named(spec, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        dataclasses.replace(te.DRAGONFLY.fore, coefficients=spec)


@pytest.mark.parametrize(
    "alpha, lift, drag, message",
    [
        ([0.0, 45.0, 30.0, 90.0], [0, 1, 1, 0], [1, 1, 1, 1], r"alpha is not strictly increasing"),
        ([0.0, 0.8, 1.5708], [0, 1, 0], [1, 1, 1], r"look like radians"),
        ([0.0, 45.0, 100.0], [0, 1, 0], [1, 1, 1], r"from 0 to 90 or from 0 to 180"),
        ([0.0, 90.0], [0, 1], [1, -1], r"C_D = -1.0 < 0"),
        ([0.0, 90.0], [0, 1, 2], [1, 1], r"the same number"),
        ([0.0, 90.0], [0, np.nan], [1, 1], r"lift\[1\] = nan"),
    ],
)
def test_bad_tables_are_named(alpha, lift, drag, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        TabulatedCoefficients(alpha, lift, drag)


def test_a_fit_with_negative_drag_is_rejected() -> None:
    with pytest.raises(ValueError, match=r"C_D < 0"):
        SinusoidalFit(0.0, 1.0, 2.0, 0.0, 0.5, 1.0, 2.0, 0.0)
