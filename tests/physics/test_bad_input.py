"""Bad input gets one clear error (the argument, its value, what is allowed) and nothing else.

Strings (also numeric ones), booleans, complex numbers and ragged lists used to be converted
by NumPy without a word; an ``atol`` of NaN accepted any stroke; an empty batch got a
different answer from each entry point. NumPy integers and floats are accepted wherever a
Python number is.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest

import tandem_env as te
from tandem_env.physics.stroke import ATOL_MAX, LOWER, UPPER

LEVEL = "TandemWing/LevelFlight-v0"
STROKE = np.where(te.physics.stroke.DISCRETE, 1.0, 0.5 * (LOWER + UPPER))
ALLOWED_STROKES = re.escape("allowed: real numbers of shape (28,) or (B, 28) with B >= 1")


@pytest.fixture(autouse=True)
def _no_warnings():
    # "nothing else": no ComplexWarning, no DeprecationWarning beside the error.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        yield


# --- strokes ---------------------------------------------------------------------------------
STROKE_ENTRY_POINTS = {
    "evaluate": (lambda x: te.evaluate(x, 1.5), "strokes"),
    "validate_physical": (te.validate_physical, "strokes"),
    "physical_to_normalised": (te.physical_to_normalised, "strokes"),
    "normalised_to_physical": (te.normalised_to_physical, "action"),
}


@pytest.mark.parametrize("entry", sorted(STROKE_ENTRY_POINTS))
@pytest.mark.parametrize(
    ("bad", "what"),
    [
        ([str(v) for v in STROKE], r"\[0\] = '37.5' is a string"),
        (np.array([str(v) for v in STROKE]), r"\[0\] = '37.5' is a string"),
        ([True] * 28, r"\[0\] = True is a boolean"),
        (STROKE + 0j, r"\[0\] = \(37.5\+0j\) is a complex number"),
        (
            [list(STROKE), list(STROKE[:5])],
            r" is a ragged sequence \(its rows have different lengths\)",
        ),
        ([*STROKE[:27], None], r"\[27\] = None is not a number"),
        ("fast", " = 'fast' is a string"),
    ],
    ids=["numeric-strings", "string-array", "booleans", "complex", "ragged", "none", "string"],
)
def test_strokes_that_are_not_real_numbers(entry: str, bad, what: str) -> None:
    function, name = STROKE_ENTRY_POINTS[entry]
    # normalised_to_physical takes [-1, 1]: the type is refused before the range is looked at.
    with pytest.raises(ValueError, match=f"^{name}{what}; {ALLOWED_STROKES}"):
        function(bad)


@pytest.mark.parametrize("entry", sorted(STROKE_ENTRY_POINTS))
@pytest.mark.parametrize("empty", [np.zeros((0, 28)), [], np.zeros(0)], ids=["0x28", "[]", "(0,)"])
def test_an_empty_batch_gets_the_same_answer_everywhere(entry: str, empty) -> None:
    function, name = STROKE_ENTRY_POINTS[entry]
    shape = re.escape(str(np.shape(empty)))
    with pytest.raises(
        ValueError, match=f"^{name} is empty \\(shape {shape}\\); {ALLOWED_STROKES}"
    ):
        function(empty)


def test_numpy_numbers_are_strokes() -> None:
    as_int = np.minimum(np.ceil(STROKE), UPPER).astype(np.int64)  # every entry inside Table 4
    np.testing.assert_array_equal(te.validate_physical(as_int)[0], as_int.astype(float))
    objects = np.array([np.float32(v) for v in STROKE], dtype=object)
    np.testing.assert_allclose(te.validate_physical(objects)[0], STROKE, rtol=1e-6)


# --- atol ------------------------------------------------------------------------------------
@pytest.mark.parametrize("atol", [np.nan, np.inf, -1e-9, "1e-9", None, True, 10.0, 1 + 0j])
def test_atol_must_be_a_small_number(atol) -> None:
    fast = STROKE.copy()
    fast[0] = 100.0  # a 100 Hz stroke, far outside Table 4: NaN used to accept it
    for stroke in (STROKE, fast):
        with pytest.raises(ValueError, match=r"^atol = .*; allowed: a number from 0 to 0\.001"):
            te.validate_physical(stroke, atol=atol)


def test_atol_still_works() -> None:
    above = STROKE.copy()
    above[0] = UPPER[0] + 0.5 * ATOL_MAX
    table_4 = te.TABLE_4_BOUNDS  # a flyer's bounds; the default is the model's wider limits
    te.validate_physical(above, atol=ATOL_MAX, bounds=table_4)
    te.validate_physical(above, atol=np.float32(ATOL_MAX), bounds=table_4)
    with pytest.raises(ValueError, match="outside Table 4"):
        te.validate_physical(above, bounds=table_4)


# --- flight conditions -----------------------------------------------------------------------
@pytest.mark.parametrize("name", ["speed", "available_power"])
@pytest.mark.parametrize(
    ("bad", "what"),
    [
        ("1.5", r" = '1.5' is a string"),
        (True, r" = True is a boolean"),
        (1.5 + 0j, r" = \(1.5\+0j\) is a complex number"),
        ([1.5, "2"], r"\[1\] = '2' is a string"),
        ([[1.5], [1.0, 2.0]], r" is a ragged sequence \(its rows have different lengths\)"),
        (np.array(["1", "2"]), r"\[0\] = '1' is a string"),
    ],
    ids=["string", "bool", "complex", "mixed", "ragged", "string-array"],
)
def test_conditions_that_are_not_real_numbers(name: str, bad, what: str) -> None:
    kwargs = {"speed": 1.0, "available_power": 90.0, name: bad}
    with pytest.raises(ValueError, match=f"^{name}{what}; allowed: a real number or a \\(2,\\)"):
        te.evaluate(np.stack([STROKE, STROKE]), **kwargs)


@pytest.mark.parametrize("speed", [np.int64(1), np.float32(1.0), np.array(1), np.array([1, 1])])
def test_numpy_numbers_are_conditions(speed) -> None:
    result = te.evaluate(np.stack([STROKE, STROKE]), speed, available_power=np.int32(90))
    np.testing.assert_array_equal(result.speed, [1.0, 1.0])
    assert result.speed.dtype == np.float64


@pytest.mark.parametrize(
    ("name", "bad", "allowed"),
    [
        ("speed", 20.5, "0 to 20 m/s"),
        ("speed", -0.1, "0 to 20 m/s"),
        ("available_power", 0.011, "1 to 1000 W/kg"),  # 90 W/kg given in W
        ("available_power", 1001.0, "1 to 1000 W/kg"),
        ("flight_path_angle", 1.6, "-1.5708 to 1.5708 rad"),
    ],
)
def test_conditions_outside_the_model_limits(name: str, bad: float, allowed: str) -> None:
    # evaluate and stroke_history share one set of limits (tandem_env.SPEED_LIMITS, ...).
    kwargs = {"speed": 1.0, name: bad}
    message = f"^{name} = {bad:g} .*{re.escape(allowed)}$"
    with pytest.raises(ValueError, match=message):
        te.evaluate(STROKE, **kwargs)
    with pytest.raises(ValueError, match=message):
        te.stroke_history(STROKE, **kwargs, n_samples=16)


# --- environments ----------------------------------------------------------------------------
@pytest.mark.parametrize("speed", ["1.5", True, 1.5 + 0j, [1.5]])
def test_env_speed_that_is_not_a_number(speed) -> None:
    with pytest.raises(
        ValueError, match=r"^LevelFlightConfig.speed = .*; allowed: a finite number"
    ):
        gym.make(LEVEL, speed=speed)


@pytest.mark.parametrize(
    ("action", "what"),
    [
        ([str(v) for v in np.zeros(28)], r"\[0\] = '0.0' is a string"),
        (np.zeros(28, dtype=bool), r"\[0\] = False is a boolean"),
        (np.zeros(28, dtype=complex), r"\[0\] = 0j is a complex number"),
        ([[0.0] * 28, [0.0]], r" is a ragged sequence \(its rows have different lengths\)"),
    ],
)
def test_env_actions_that_are_not_real_numbers(action, what: str) -> None:
    env = gym.make(LEVEL)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=f"^action{what}; allowed: 28 real numbers"):
        env.step(action)
    vec = gym.make_vec(LEVEL, num_envs=1)
    vec.reset(seed=0)
    in_batch = what.replace(r"\[0\]", r"\[0, 0\]")
    with pytest.raises(ValueError, match=f"^actions{in_batch}; allowed: real numbers of shape"):
        vec.step([action])


def test_numpy_integers_where_an_int_is_expected() -> None:
    vec = gym.make_vec(LEVEL, num_envs=np.int64(2), n_time=np.int64(64), n_blade=np.int32(12))
    assert vec.num_envs == 2 and vec.unwrapped.config.options.n_time == 64
    vec.reset(seed=np.int64(3))
    insect = replace(te.DRAGONFLY, wings_per_pair=np.int64(2))
    assert type(insect.wings_per_pair) is int
    history = te.stroke_history(STROKE, 1.0, n_samples=np.int64(16))
    assert history.fore.time.shape == (16,)


# --- the harness's condition -----------------------------------------------------------------
@pytest.mark.parametrize("condition", ["1.5", True, None, 1.5 + 0j])
def test_harness_condition_that_is_not_a_number(condition) -> None:
    from agents.tasks import get_task

    with pytest.raises(
        ValueError, match=r"^level: condition speed = .*; allowed: a number \[m/s\]"
    ):
        get_task("level").condition(condition)


def test_harness_condition_accepts_numpy_numbers() -> None:
    from agents.tasks import get_task

    for value in (np.int64(1), np.float32(1.5), 1):
        assert type(get_task("level").condition(value).value) is float


def test_training_settings_accept_numpy_integers() -> None:
    from train.config import TrainConfig
    from train.policies import TrainingMethod

    config = TrainConfig(
        algo="ppo",
        env_id=LEVEL,
        n_timesteps=np.int64(100),
        n_envs=np.int32(4),
        seed=np.int64(3),
        eval_freq=np.int64(0),
        save_freq=np.int16(64),
        log_interval=np.int64(2),
    )
    assert (config.n_timesteps, config.n_envs, config.seed, config.save_freq) == (100, 4, 3, 64)
    assert all(type(v) is int for v in (config.seed, config.eval_freq, config.log_interval))
    assert TrainingMethod("ppo", n_envs=np.int64(8)).n_envs == 8
    with pytest.raises(
        ValueError, match=r"^seed = True; allowed: an integer from 0 to 2\*\*32 - 1"
    ):
        TrainConfig(algo="ppo", env_id=LEVEL, seed=True)
    with pytest.raises(ValueError, match=r"^n_timesteps = '100'; allowed: an integer >= 1"):
        TrainConfig(algo="ppo", env_id=LEVEL, n_timesteps="100")


# --- numbers shown rounded into range ------------------------------------------------------------
def test_a_value_just_outside_a_limit_is_shown_with_the_digits_that_make_it_so() -> None:
    from tandem_env.physics.checks import shown

    stroke = STROKE.copy()
    stroke[0] = UPPER[0] + 1e-5  # fore_frequency 45.00001 Hz: %g would print 45
    with pytest.raises(ValueError, match=r"= 45\.00001 Hz is outside Table 4: allowed 30 to 45"):
        te.validate_physical(stroke, bounds=te.TABLE_4_BOUNDS)
    with pytest.raises(ValueError, match=r"speed = 20\.0000000001 m/s; allowed"):
        te.evaluate(STROKE, 20.0000000001)
    action = np.zeros(28)
    action[3] = 1.0 + 1e-7
    with pytest.raises(ValueError, match=r"= 1\.0000001 is outside"):
        te.normalised_to_physical(action)
    # the helper: %g where that tells the value from its bounds, more digits where not
    assert shown(37.5, 30, 45) == "37.5" and shown(45, 30, 45) == "45"
    assert shown(45.00001, 30, 45) == "45.00001"
    assert float(shown(1 + 2**-52, 1)) != 1.0  # down to the last bit


@pytest.mark.parametrize(
    ("above", "value", "message"),
    [
        (False, -0.5, "step = -0.5; allowed: a finite number from 0 to 2"),
        (True, 0.0, "step = 0; allowed: a finite number above 0 and up to 2"),
        (True, 2.5, "step = 2.5; allowed: a finite number above 0 and up to 2"),
        (True, np.nan, "step = nan; allowed: a finite number above 0 and up to 2"),
    ],
)
def test_a_real_setting_names_its_range_and_whether_the_low_end_is_allowed(
    above: bool, value: float, message: str
) -> None:
    from tandem_env.physics.checks import finite_real

    with pytest.raises(ValueError, match=rf"^{message}$"):
        finite_real(value, "step", 0.0, 2.0, above=above)
    assert finite_real(0.0, "step", 0.0, 2.0) == 0.0  # the low end itself, unless ``above``
    assert finite_real(np.float32(2.0), "step", 0.0, 2.0, above=True) == 2.0


# --- type laxity -------------------------------------------------------------------------------
def test_switches_are_booleans_and_counts_are_any_integer() -> None:
    torch = pytest.importorskip("torch")
    from tandem_env.physics.torch_model import evaluate_torch, resolve_device

    strokes = torch.tensor(STROKE)
    with pytest.raises(ValueError, match=r"compiled = 'no' is a string; allowed: True or False"):
        evaluate_torch(strokes, compiled="no")
    with pytest.raises(ValueError, match=r"compiled = 1 is a int; allowed: True or False"):
        evaluate_torch(strokes, compiled=1)
    with pytest.raises(ValueError, match=r"chunk_size = True; allowed: an integer >= 1"):
        evaluate_torch(strokes, chunk_size=True)
    evaluate_torch(strokes, chunk_size=np.int64(2), compiled=np.False_)  # NumPy's are fine
    with pytest.raises(ValueError, match=r"device = 'cpu:1': there is one CPU device"):
        resolve_device("cpu:1")
    with pytest.raises(ValueError, match=r"device = 'cpu:1'"):
        te.evaluate(STROKE, 1.0, backend="torch", device="cpu:1")
    assert str(resolve_device("cpu:0")) == "cpu:0"


@pytest.mark.parametrize("degrees", ["yes", 1, None])
def test_measured_angle_units_are_a_boolean(degrees) -> None:
    with pytest.raises(ValueError, match=r"from_fourier: degrees = .*; allowed: True or False"):
        te.MeasuredWing.from_fourier(
            frequency=40, sweep=(0.0, [(30.0, 0.0)]), elevation=(0.0, []),
            pitch=(90.0, [(40.0, 90.0)]), stroke_plane_angle=60.0, degrees=degrees,
        )  # fmt: skip
    n = 64
    t = np.arange(n) / (n * 40.0)
    with pytest.raises(ValueError, match=r"from_samples: degrees = .*; allowed: True or False"):
        te.MeasuredWing.from_samples(t, t, t, t, 60.0, frequency=40.0, degrees=degrees)


# --- raw errors from the torch helpers -----------------------------------------------------------
def test_the_torch_helpers_name_what_a_metric_may_be() -> None:
    torch = pytest.importorskip("torch")
    from tandem_env.physics.torch_model import normalised_jacobian, value_and_grad

    strokes = torch.tensor(STROKE)
    with pytest.raises(ValueError, match=r"metric = 'foo' is not a Result field; allowed: .*power"):
        value_and_grad(strokes, "foo")
    with pytest.raises(ValueError, match=r"'induction_converged' gives torch.bool values"):
        value_and_grad(strokes, "induction_converged")
    with pytest.raises(ValueError, match=r"gives \(\); allowed: a \(1,\) tensor"):
        value_and_grad(strokes, lambda r: r.power.sum())
    for metrics in ([], "efficiency", [None]):
        with pytest.raises(ValueError, match=r"metrics = .*; allowed: a non-empty sequence"):
            normalised_jacobian(np.zeros((2, 28)), metrics)
    values, gradient = value_and_grad(strokes, "power_per_mass")
    assert values.shape == (1,) and gradient.shape == (28,)


# --- limits applied wherever they enter ----------------------------------------------------------
@pytest.mark.parametrize("num_envs", [10_001, 10**9, True, 0])
def test_the_batch_limit_holds_for_every_vector_env(num_envs) -> None:
    from tandem_env.physics.model import MAX_BATCH_STROKES

    with pytest.raises(ValueError, match=rf"num_envs = .*<= {MAX_BATCH_STROKES:,}"):
        gym.make_vec(LEVEL, num_envs=num_envs)
    with pytest.raises(ValueError, match=rf"num_envs = .*<= {MAX_BATCH_STROKES:,}"):
        gym.make_vec("TandemWing/SpeedChange-v0", num_envs=num_envs)
