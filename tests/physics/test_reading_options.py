"""The options that make the paper's open readings selectable (docs/model.md §5.5, §6.3, §7.6).

Each is tested by physics: the inequalities its definition implies, the cases where it must
coincide with another option, and a case checkable by hand.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tandem_env.physics import Dragonfly, ModelOptions, cycle, evaluate, stroke_history
from tandem_env.physics.stroke import normalised_to_physical

AERODYNAMIC = ModelOptions(power="aerodynamic")
ELASTIC = ModelOptions(power="elastic")
HOVER_NONE = ModelOptions(hover_inflow="none")


def random_strokes(n: int, seed: int) -> np.ndarray:
    return normalised_to_physical(np.random.default_rng(seed).uniform(-1.0, 1.0, (n, 28)))


def assert_results_equal(a, b) -> None:
    """Every (B,) field bit for bit (the ``options`` metadata aside)."""
    for name, value in a.as_dict().items():
        np.testing.assert_array_equal(value, getattr(b, name), err_msg=name)


# --- validation ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "value", "allowed"),
    [
        ("power", "positive", "'absolute', 'elastic', 'aerodynamic'"),
        ("hover_inflow", "zero", "'momentum', 'none'"),
    ],
)
def test_bad_reading_option_names_value_and_allowed(field: str, value: str, allowed: str) -> None:
    with pytest.raises(ValueError, match=rf"ModelOptions\.{field} = '{value}'; allowed: {allowed}"):
        ModelOptions(**{field: value})


# --- power = "aerodynamic" (docs/model.md §6.3) ------------------------------------------------


def test_positive_part_mean_by_hand() -> None:
    """P_aero(s) = sin s + c over one cycle: mean(max(P, 0)) = [2·sqrt(1 − c²) + c·(π + 2·asin c)]
    / (2π), the positive arc running from s = −asin c to π + asin c."""
    n = 64
    s = 2.0 * np.pi * np.arange(n) / n
    tables = cycle.fourier_tables(n)
    for c in (-0.7, -0.2, 0.0, 0.3, 0.9):
        histories = np.zeros((n, 5))
        histories[:, 3] = np.sin(s) + c
        out = np.zeros(cycle.N_WING_OUT)
        cycle.cycle_means(histories, np.ones(n), out, *tables)
        expected = (2.0 * np.sqrt(1.0 - c * c) + c * (np.pi + 2.0 * np.arcsin(c))) / (2.0 * np.pi)
        assert out[cycle.W_P_AERO_POSITIVE] == pytest.approx(expected, rel=1e-10)
        # and the inertial power (zero here) does not enter it: elastic storage gives the same
        assert out[cycle.W_P_ELASTIC] == pytest.approx(expected, rel=1e-10)


@pytest.mark.parametrize("speed", [0.0, 1.0])
def test_aerodynamic_power_bounds(speed: float) -> None:
    """mean(a⁺) ≤ mean|a| ≤ mean|a| + mean|i| (aerodynamic ≤ absolute), and, since the inertial
    power i averages to zero over a cycle (mean i⁺ = mean|i|/2) and (a + i)⁺ ≤ a⁺ + i⁺,
    a⁺ ≤ (a + i)⁺ + (−i)⁺: |aerodynamic − elastic| ≤ N_w·mean|P_iner|/2 per wing pair. Neither
    of aerodynamic and elastic bounds the other in general."""
    strokes = random_strokes(64, seed=11)
    absolute = evaluate(strokes, speed)
    elastic = evaluate(strokes, speed, options=ELASTIC)
    aero = evaluate(strokes, speed, options=AERODYNAMIC)
    assert np.all(aero.power > 0.0)
    assert np.all(aero.power <= absolute.power * (1.0 + 1e-12))
    for pair in ("fore", "hind"):
        p_aero = getattr(aero, f"{pair}_power")
        assert np.all(p_aero <= getattr(absolute, f"{pair}_aero_power") * (1.0 + 1e-12))
        gap = np.abs(p_aero - getattr(elastic, f"{pair}_power"))
        half_inertial = 0.5 * getattr(absolute, f"{pair}_inertial_power")
        assert np.all(gap <= half_inertial * (1.0 + 1e-9) + 1e-15)
    # every other metric is the same: only the accounting of the power changes
    np.testing.assert_array_equal(aero.lift_to_weight, absolute.lift_to_weight)
    np.testing.assert_array_equal(aero.thrust, absolute.thrust)


def test_aerodynamic_and_elastic_power_are_not_ordered() -> None:
    """Inertial power that cancels the aerodynamic power (i = −a) is stored and given back:
    elastic 0 < aerodynamic 1/π; a positive aerodynamic power (a = 1 + ½ sin s) with inertial
    power i = 2 sin s is not: aerodynamic 1 < elastic."""
    n = 64
    s = 2.0 * np.pi * np.arange(n) / n
    tables = cycle.fourier_tables(n)
    out = np.zeros(cycle.N_WING_OUT)
    histories = np.zeros((n, 5))
    histories[:, 3], histories[:, 4] = np.sin(s), -np.sin(s)
    cycle.cycle_means(histories, np.ones(n), out, *tables)
    assert out[cycle.W_P_AERO_POSITIVE] == pytest.approx(1.0 / np.pi, rel=1e-10)
    assert abs(out[cycle.W_P_ELASTIC]) < 1e-12
    histories[:, 3], histories[:, 4] = 1.0 + 0.5 * np.sin(s), 2.0 * np.sin(s)
    cycle.cycle_means(histories, np.ones(n), out, *tables)
    assert out[cycle.W_P_AERO_POSITIVE] == pytest.approx(1.0, rel=1e-12)
    assert out[cycle.W_P_ELASTIC] > 1.1


def test_massless_wings_make_aerodynamic_equal_elastic() -> None:
    """With no inertial power the positive part of P_aero + P_iner is that of P_aero."""
    massless = Dragonfly(
        fore=dataclasses.replace(Dragonfly().fore, mass=0.0),
        hind=dataclasses.replace(Dragonfly().hind, mass=0.0),
    )
    strokes = random_strokes(16, seed=12)
    aero = evaluate(strokes, 0.5, insect=massless, options=AERODYNAMIC)
    elastic = evaluate(strokes, 0.5, insect=massless, options=ELASTIC)
    np.testing.assert_array_equal(aero.power, elastic.power)


def test_aerodynamic_power_from_the_time_history() -> None:
    """N_w·mean(max(P_aero, 0)) of each pair, from stroke_history's uniform samples (a plain
    mean, second order at the kinks, on a fine grid; the inflow is solved on that grid too):
    the result's power per pair. Measured agreement 1e-7 to 4e-6 on 12 random cases. The mean
    reading: the vortex reading's own interpolation onto its wake grid differs between the two
    grids by ~1e-4."""
    options = ModelOptions(power="aerodynamic", slipstream="mean")
    strokes = random_strokes(3, seed=13)
    for stroke in strokes:
        history = stroke_history(stroke, 1.0, n_samples=2048, options=options)
        for pair in ("fore", "hind"):
            wing = getattr(history, pair)
            expected = np.mean(np.maximum(wing.aero_power, 0.0))
            got = float(getattr(history.result, f"{pair}_power")[0])
            assert got == pytest.approx(expected, rel=3e-5)


# --- hover_inflow (docs/model.md §5.5) ----------------------------------------------------------


def test_hover_inflow_none_in_hover_is_no_induction() -> None:
    strokes = random_strokes(16, seed=21)
    literal = evaluate(strokes, 0.0, options=HOVER_NONE)
    none = evaluate(strokes, 0.0, options=ModelOptions(induction="none"))
    assert_results_equal(literal, none)
    assert np.all(literal.fore_inflow == 0.0) and np.all(literal.hind_inflow == 0.0)
    # and it is a change wherever a wing pushes air down (the momentum inflow is then > 0)
    momentum = evaluate(strokes, 0.0)
    lifting = momentum.fore_inflow > 0.0
    assert lifting.sum() >= 8
    assert np.all(literal.fore_lift_to_weight[lifting] != momentum.fore_lift_to_weight[lifting])


def test_hover_inflow_none_in_forward_flight_is_momentum() -> None:
    strokes = random_strokes(16, seed=22)
    for speed in (0.25, 1.5):
        assert_results_equal(evaluate(strokes, speed, options=HOVER_NONE), evaluate(strokes, speed))


def test_hover_inflow_none_in_a_mixed_batch_is_each_stroke_alone() -> None:
    strokes = random_strokes(10, seed=23)
    speeds = np.array([0.0, 1.0, 0.0, 0.0, 2.0, 0.5, 0.0, 1.25, 0.0, 0.75])
    mixed = evaluate(strokes, speeds, options=HOVER_NONE)
    hover = speeds == 0.0
    alone_hover = evaluate(strokes[hover], 0.0, options=ModelOptions(induction="none"))
    alone_flight = evaluate(strokes[~hover], speeds[~hover])
    for name, value in mixed.as_dict().items():
        np.testing.assert_array_equal(value[hover], getattr(alone_hover, name), err_msg=name)
        np.testing.assert_array_equal(value[~hover], getattr(alone_flight, name), err_msg=name)


def test_hover_inflow_none_is_decided_per_wing() -> None:
    """A path angle γ = −β_fore puts the fore-wing's stroke plane along the path (V_n = 0 on it
    only): the fore-wing has no induced velocity and the hind-wing none from upstream, so the
    hind-wing is the isolated one of the momentum model, and the fore-wing the one without
    inflow."""
    strokes = random_strokes(6, seed=24)
    gamma = -np.deg2rad(strokes[:, 13])
    literal = evaluate(strokes, 1.0, flight_path_angle=gamma, options=HOVER_NONE)
    isolated = evaluate(
        strokes, 1.0, flight_path_angle=gamma, options=ModelOptions(induction="isolated")
    )
    none = evaluate(strokes, 1.0, flight_path_angle=gamma, options=ModelOptions(induction="none"))
    assert np.all(literal.fore_inflow == 0.0)
    for name in ("lift_to_weight", "horizontal_force", "power", "inflow", "mean_angle_of_attack"):
        np.testing.assert_array_equal(
            getattr(literal, f"hind_{name}"), getattr(isolated, f"hind_{name}")
        )
        np.testing.assert_array_equal(
            getattr(literal, f"fore_{name}"), getattr(none, f"fore_{name}")
        )


def test_hover_inflow_none_in_the_time_history() -> None:
    stroke = random_strokes(1, seed=25)[0]
    history = stroke_history(stroke, 0.0, n_samples=64, options=HOVER_NONE)
    bare = stroke_history(stroke, 0.0, n_samples=64, options=ModelOptions(induction="none"))
    for pair in ("fore", "hind"):
        assert np.all(getattr(history, pair).inflow == 0.0)
        np.testing.assert_array_equal(
            getattr(history, pair).vertical_force, getattr(bare, pair).vertical_force
        )


# --- Eq. 24 read literally: excess_horizontal_literal (docs/model.md §7.6) ---------------------


@pytest.mark.parametrize("speed", [0.0, 1.0])
def test_literal_horizontal_force_is_the_wings_rearward_parts(speed: float) -> None:
    """(D_f + D_h)/W from stroke_history's uniform samples of each pair's horizontal force (a
    plain mean of max(−F_x, 0) on a fine grid, independent of the kernel's quadrature; measured
    agreement 1e-7 to 4e-6 on 12 random cases; the mean reading, as above)."""
    strokes = random_strokes(4, seed=31 + int(speed))
    for stroke in strokes:
        history = stroke_history(
            stroke, speed, n_samples=2048, options=ModelOptions(slipstream="mean")
        )
        rearward = sum(
            np.mean(np.maximum(-getattr(history, pair).horizontal_force, 0.0))
            for pair in ("fore", "hind")
        )
        weight = Dragonfly().weight
        got = float(history.result.excess_horizontal_literal[0])
        assert got == pytest.approx(rearward / weight, rel=3e-5)
        assert got >= 0.0


def test_literal_horizontal_force_whatever_the_thrust_split() -> None:
    """It is the wings' own drag: the `sign` split's D/W, and the same under `body`, while the
    net F̄_h is another quantity (T − D can have either sign, the literal one cannot)."""
    strokes = random_strokes(32, seed=33)
    sign = evaluate(strokes, 1.0)
    body = evaluate(strokes, 1.0, options=ModelOptions(thrust_split="body"))
    np.testing.assert_array_equal(sign.excess_horizontal_literal, sign.drag / Dragonfly().weight)
    np.testing.assert_array_equal(body.excess_horizontal_literal, sign.excess_horizontal_literal)
    assert np.all(sign.excess_horizontal_literal >= 0.0)
    assert np.any(sign.excess_horizontal < 0.0)
    # D_f + D_h ≥ −(net horizontal force)/W: the rearward parts bound the net force from below
    assert np.all(sign.excess_horizontal_literal >= -sign.excess_horizontal - 1e-12)


def test_model_presets_are_options_over_the_defaults() -> None:
    from tandem_env.physics.options import PRESETS

    for name, changes in PRESETS.items():
        options = ModelOptions.preset(name)
        changed = {
            k: v for k, v in dataclasses.asdict(options).items() if getattr(ModelOptions(), k) != v
        }
        assert changed == dict(changes) and changed  # each preset changes something, no more
        assert ModelOptions.preset(name, n_time=64) == dataclasses.replace(options, n_time=64)
    with pytest.raises(ValueError, match=r"preset\('nope'\); allowed: 'paper'"):
        ModelOptions.preset("nope")
    with pytest.raises(ValueError, match=r"unknown field\(s\) \['nope'\]; allowed: hover_inflow"):
        ModelOptions.preset("paper", nope=1)
    with pytest.raises(ValueError, match=r"ModelOptions.spin = 'x'"):
        ModelOptions.preset("paper", spin="x")
