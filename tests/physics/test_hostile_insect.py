"""Hostile insect and kinematics input, by class: YAML that expands without bound,
YAML merge keys, every value of an insect checked before use, ``--insect`` given twice, and
a measured sweep that is a step."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml

from tandem_env.io.datafile import MAX_YAML_NODES, BoundedLoader, DataLoader, parse_yaml
from tandem_env.io.keyvalue import parse_value
from tandem_env.physics.insect import DRAGONFLY, load_insect
from tandem_env.physics.measured import SMOOTH_HARMONICS, MeasuredWing, unresolved_share


def _alias_bomb(levels: int = 9) -> str:
    """A few lines of YAML that expand to 10**levels items."""
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    for i in range(1, levels):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]")
    return "\n".join(lines) + "\n"


# --- YAML that expands without bound ------------------------------------------------------------
@pytest.mark.parametrize("loader", [BoundedLoader, DataLoader])
def test_an_alias_bomb_is_refused_before_it_is_built(loader: type[BoundedLoader]) -> None:
    # 10^9 items: building them would hang; counting distinct nodes takes a few hundred
    with pytest.raises(yaml.YAMLError, match=f"expands to more than {MAX_YAML_NODES:,} values"):
        parse_yaml(_alias_bomb(), loader)
    # just under the limit is read (aliases share, so the size is counted, not the text)
    assert len(parse_yaml(_alias_bomb(5), loader)["a4"]) == 10


def test_an_alias_that_holds_itself_is_refused() -> None:
    with pytest.raises(yaml.YAMLError, match="an alias refers to a value that holds it"):
        parse_yaml("a: &a [1, *a]\n", DataLoader)


def test_an_alias_bomb_in_an_insect_file_or_on_the_command_line_is_refused(
    tmp_path: Path,
) -> None:
    path = tmp_path / "bomb.yaml"
    # under a field the insect reads (converting it used to expand all 10^9 items and hang)
    levels = ["&a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    levels += [f"&a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 9)]
    path.write_text(f"fore:\n  real_edges: [{', '.join(levels)}]\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"bomb\.yaml' is refused: it expands to more than"):
        load_insect(path)
    # a command-line value that is no YAML it may read stays the text it is (then no such file)
    text = "{" + _alias_bomb().replace("\n", ", ").rstrip(", ") + "}"
    assert parse_value(text) == text


def test_a_file_larger_than_any_data_file_is_refused_unread(tmp_path: Path) -> None:
    path = tmp_path / "huge.yaml"
    with path.open("wb") as handle:  # sparse: 70 MB of nothing, never read
        handle.truncate(70 * 2**20)
    with pytest.raises(ValueError, match=r"huge\.yaml' holds 73,400,320 bytes; allowed"):
        load_insect(path)


# --- merge keys -------------------------------------------------------------------------------
def test_merge_keys_are_read(tmp_path: Path) -> None:
    path = tmp_path / "merged.yaml"
    path.write_text(
        "fore: &wing\n  length: 0.03\n  mean_chord: 0.006\nhind:\n  <<: *wing\n"
        "  mean_chord: 0.008   # overrides the merged value: not a duplicate\n",
        encoding="utf-8",
    )
    insect = load_insect(path)
    assert (insect.fore.length, insect.fore.mean_chord) == (0.03, 0.006)
    assert (insect.hind.length, insect.hind.mean_chord) == (0.03, 0.008)
    # a key given twice beside a merge is still a duplicate
    path.write_text("fore: &w {length: 0.03}\nhind:\n  <<: *w\n  mass: 1e-6\n  mass: 2e-6\n")
    with pytest.raises(ValueError, match="duplicate key 'mass' on lines 4 and 5"):
        load_insect(path)


# --- every value of an insect -----------------------------------------------------------------
@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ({"fore": {"real_edges": "junk"}}, r"insect\.fore: Wing\.real_edges = 'junk'; allowed: "
         r"None or \(upper, lower\), two sequences of 1 to 6 finite numbers"),
        ({"hind": {"real_edges": [[0.1, 0.2], [0.0, "x"]]}}, r"Wing\.real_edges = .*allowed"),
        ({"fore": {"real_edges": [[0.0] * 7, [0.0] * 7]}}, r"Wing\.real_edges = .*1 to 6"),
        ({"fore": {"thickness": 1.0}}, r"insect\.fore: Wing\.thickness = 1 m; allowed: 0 <= "
         r"thickness <= 0\.000588 m \(a thin plate: at most 0\.1 of the mean chord\)"),
        ({"hind": {"length": 5.0}}, r"Wing\.length = 5 m; allowed: 0 < length <= 1 m"),
        ({"fore": {"mean_chord": math.nan}}, r"Wing\.mean_chord = nan m; allowed: 0 < "),
        ({"fore": {"drag_coefficient_90": 40}}, r"drag_coefficient_90 = 40; allowed: 0 <= "
         r"drag_coefficient_90 <= 5 \(a plate broadside"),
        ({"fore": {"damping_linear": True}}, r"damping_linear = True; allowed: 0 <= "),
        ({"gravity": 1e9}, r"Dragonfly\.gravity = 1e\+09 m/s²; allowed: 0 < gravity <= 30"),
        ({"air_density": 0}, r"Dragonfly\.air_density = 0 kg/m³; allowed: 0 < air_density"),
        ({"body_mass": "heavy"}, r"Dragonfly\.body_mass = 'heavy'; allowed: 0 < body_mass"),
        ({"muscle_specific_power": 1e5}, r"muscle_specific_power = 100000 W/kg; allowed: 0 <"),
        ({"root_drop": -1e-3}, r"Dragonfly\.root_drop = -0\.001 m; allowed: 0 <= root_drop"),
        ({"hind": {"coefficients": {"model": "table", "alpha": [0, 45, 90], "lift": [0, 1e9, 0],
                                    "drag": [0.1, 1, 2]}}},
         r"insect\.hind: TabulatedCoefficients gives C_L = 1e\+09 at α = 45°; allowed: -10 <= "),
        ({"fore": {"coefficients": {"model": "sinusoidal", "lift_offset": 0, "lift_amplitude": 1,
                                    "lift_rate": 2, "lift_phase": 0, "drag_offset": 60,
                                    "drag_amplitude": 1, "drag_rate": 2, "drag_phase": 0}}},
         r"SinusoidalFit gives C_D = 59 at α = 0°; allowed: 0 <= C_D <= 10"),
        ({"fore": {"mass": 1e-4}}, r"the 4 wings weigh 0\.0002017 kg, not less than "
         r"Dragonfly\.body_mass = 0\.0001219 kg"),
    ],
)  # fmt: skip
def test_each_bad_value_is_refused_naming_the_field_value_and_range(
    spec: dict, message: str
) -> None:
    with pytest.raises(ValueError, match=message):
        load_insect(spec)


def test_the_example_insects_keep_their_values() -> None:
    examples = Path(__file__).resolve().parents[2] / "examples"
    for name in ("scaled_dragonfly.yaml", "orthetrum_cancellatum.yaml"):
        assert load_insect(examples / name) != DRAGONFLY
    edges = load_insect({"fore": {"real_edges": [[0, 1], [0, -1]]}}).fore.real_edges
    assert edges == ((0.0, 1.0), (0.0, -1.0))  # floats, hashable: part of a record's key


# --- --insect and --env-kwargs insect= --------------------------------------------------------
@pytest.mark.parametrize("file", ["specimen.yaml", "heavier.yaml"])
def test_insect_given_twice_on_the_command_line_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], file: str
) -> None:
    from eval.__main__ import main

    (tmp_path / "specimen.yaml").write_text("body_mass: 121.9e-6\n", encoding="utf-8")
    (tmp_path / "heavier.yaml").write_text("body_mass: 150e-6\n", encoding="utf-8")
    argv = ["optimize", "--task", "level", "--speed", "1", "--method", "random", "--budget"]
    argv += ["16", "--seeds", "0", "--out", str(tmp_path / "o"), "--insect", str(tmp_path / file)]
    argv += ["--env-kwargs", "insect={'body_mass': 2e-4}"]
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert "give --insect FILE or --env-kwargs insect=..., not both" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


# --- a measured sweep that is a step -----------------------------------------------------------
def _wing(sweep_deg: np.ndarray) -> MeasuredWing:
    n = sweep_deg.shape[0]
    phase = 2 * np.pi * np.arange(n) / n
    return MeasuredWing.from_samples(
        time=np.arange(n) / (30.0 * n),
        sweep=sweep_deg,
        elevation=5.0 * np.sin(phase),
        pitch=40.0 * np.tanh(5.0 * np.cos(phase)) / np.tanh(5.0),  # Table 4's sharpest pitch
        frequency=30.0,
        stroke_plane_angle=10.0,
    )


def _step(n: int, ramp: int) -> np.ndarray:
    """A ±40° square sweep, each edge ramped linearly over ``ramp`` samples."""
    phase = 2 * np.pi * (np.arange(n) + 0.5) / n
    square = np.where(np.cos(phase) > 0, 40.0, -40.0)
    kernel = np.ones(ramp) / ramp
    return np.convolve(np.tile(square, 3), kernel, "same")[n : 2 * n]


@pytest.mark.parametrize("n", [256, 1024, 4096])
def test_a_step_sweep_is_warned_about_however_finely_sampled(n: int) -> None:
    # ramped over 1/64 of the cycle: 4 to 64 samples, never a jump between two samples, and
    # with many samples resolved by them; its rate is still 20 times a sinusoid's
    sweep = _step(n, n // 64)
    assert unresolved_share(sweep)[0] > 0.5
    with pytest.warns(UserWarning, match=r"MeasuredWing\.sweep: \d+% of its mean-square rate "
                      rf"lies in harmonics above {SMOOTH_HARMONICS} .*it is not smooth"):  # fmt: skip
        _wing(sweep)


@pytest.mark.parametrize("n", [64, 256, 4096])
def test_smooth_sweeps_are_not_warned_about(n: int) -> None:
    phase = 2 * np.pi * np.arange(n) / n
    triangle = np.degrees(np.arcsin(np.cos(phase)))  # Table 4's sharpest sweep (K = 1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for sweep in (40.0 * np.cos(phase), triangle, 30 * np.cos(phase) + 5 * np.cos(3 * phase)):
            _wing(sweep)
