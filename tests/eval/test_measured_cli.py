"""``python -m eval measured KINEMATICS.yaml``: the shipped examples (hover, level forward flight,
a 60° climb with the stroke planes 100° from the path, twisted wings from a CSV) run end to end,
agree with the public API, and bad files get errors that name the field."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

import tandem_env as te
from eval.__main__ import main
from eval.measured import load_case

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
CASES = ("hover", "forward_flight", "climb", "twisted_wing")


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("measured")
    for case in CASES:
        assert main(["measured", str(EXAMPLES / f"{case}.yaml"), "--out", str(out)]) == 0
    return out


@pytest.mark.parametrize("case", CASES)
def test_example_writes_a_record_and_a_figure(runs: Path, case: str) -> None:
    record = json.loads((runs / f"{case}.json").read_text())
    assert (runs / f"{case}.png").stat().st_size > 10_000
    summary, result = record["summary"], record["result"]
    assert summary["total"]["lift_to_weight"] == result["lift_to_weight"]
    # the pairs add up to the total (earth axes; T and D split by sign)
    for key in ("lift_to_weight", "thrust", "drag", "power"):
        parts = summary["fore"][key] + summary["hind"][key]
        assert parts == pytest.approx(summary["total"][key], rel=1e-12), key
    history = record["histories"]["fore"]
    assert len(history["vertical_force"]) == len(history["cycle_fraction"])
    weight = te.DRAGONFLY.weight
    assert np.mean(history["vertical_force"]) / weight == pytest.approx(
        summary["fore"]["lift_to_weight"], rel=1e-12
    )


def test_cli_prints_the_table(capsys: pytest.CaptureFixture, tmp_path: Path) -> None:
    assert main(["measured", str(EXAMPLES / "climb.yaml"), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "flight path +60.0°" in out and "40.0° / 40.0° from the horizontal" in out
    for label in ("L/W", "T [mN]", "D [mN]", "P [mW]", "P/m [W/kg]", "fore pair", "hind pair"):
        assert label in out
    assert main(["measured", str(EXAMPLES / "climb.yaml"), "--out", str(tmp_path)]) == 0
    assert "replacing" in capsys.readouterr().err  # nothing overwritten without a word


def test_the_cli_is_the_public_api() -> None:
    """The climb example through the API: MeasuredWing.from_fourier with the file's numbers."""
    case = load_case(EXAMPLES / "climb.yaml")
    fore = te.MeasuredWing.from_fourier(
        35.0,
        (0.0, [(42.0, 0.0)]),
        (0.0, [(7.0, 90.0)]),
        (-20.0, [(37.0, 90.0), (0.0, 0.0), (7.4, 270.0)]),
        40.0,
    )
    hind = te.MeasuredWing.from_fourier(
        35.0,
        (0.0, [(42.0, 148.0)]),
        (0.0, [(7.0, 238.0)]),
        (-20.0, [(37.0, 238.0), (0.0, 0.0), (7.4, 354.0)]),
        40.0,
    )
    api = te.evaluate_measured(fore, hind, 0.7, flight_path_angle=math.radians(60.0))
    cli = te.evaluate_measured(
        case.fore, case.hind, case.speed, flight_path_angle=case.flight_path_angle
    )
    for name, arr in api.as_dict().items():
        assert np.array_equal(arr, getattr(cli, name)), name
    # the stroke plane is 100° from the path: the flow sees β + γ
    assert math.degrees(case.fore.stroke_plane_angle + case.flight_path_angle) == pytest.approx(100)


def test_twisted_example_reads_the_csv_stations() -> None:
    case = load_case(EXAMPLES / "twisted_wing.yaml")
    assert case.hind.pitch.shape == (60, 3) and case.hind.twisted
    np.testing.assert_array_equal(case.hind.pitch_stations, [0.25, 0.5, 0.75])
    assert case.fore.n_samples == case.hind.n_samples == 60


def write(tmp_path: Path, text: str, csv: str | None = None) -> Path:
    if csv is not None:
        (tmp_path / "wing.csv").write_text(csv)
    path = tmp_path / "case.yaml"
    path.write_text(text)
    return path


WING = """\
    frequency: 35.0
    stroke_plane_angle: 40.0
    sweep: {mean: 0.0, harmonics: [[42.0, 0.0]]}
    elevation: {mean: 0.0, harmonics: [[7.0, 90.0]]}
    pitch: {mean: -20.0, harmonics: [[37.0, 90.0]]}
"""


def good(extra: str = "", fore: str = WING, degrees: str = "true") -> str:
    return f"flight: {{speed: 0.5}}\n{extra}kinematics:\n  degrees: {degrees}\n  fore:\n{fore}  hind:\n{WING}"


@pytest.mark.parametrize(
    "text, message",
    [
        (good("flihgt: {}\n"), r"file.flihgt: unknown field; allowed: description, insect"),
        (
            good("insect: {fore: {coefficients: dickson}}\n"),
            r"insect.fore: coefficients.model = 'dickson' is not a known force-coefficient model",
        ),
        (good("insect: {fore: {lenght: 0.03}}\n"), r"insect.fore.lenght: unknown field"),
        (good("options: {n_blade: 1}\n"), r"options: ModelOptions.n_blade = 1"),
        (good(fore=WING.replace("sweep:", "sweeep:")), r"kinematics.fore.sweeep: unknown field"),
        (
            good(degrees="false"),
            r"kinematics.fore: from_fourier: sweep has a mean or amplitude of 42 rad.*degrees=True",
        ),
        (
            good(fore=WING.replace("[[42.0, 0.0]]", "[[42.0]]")),
            r"kinematics.fore.sweep.harmonics\[0\] = \[42.0\]; allowed: \[amplitude, phase\]",
        ),
        (good().replace("speed: 0.5", "speed: fast"), r"flight.speed = 'fast'; allowed: a finite"),
    ],
)
def test_bad_files_name_the_field(
    tmp_path: Path, capsys: pytest.CaptureFixture, text: str, message: str
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["measured", str(write(tmp_path, text)), "--out", str(tmp_path)])
    assert exit_info.value.code == 2
    assert re.search(message, capsys.readouterr().err), message


def csv_wing(columns: str) -> str:
    return (
        "    frequency: 40.0\n    stroke_plane_angle: 40.0\n    csv: wing.csv\n"
        f"    columns: {columns}\n"
    )


def test_bad_csv_input_is_named(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    n, f = 16, 40.0
    t = np.arange(n) / (n * f)
    t[3] += 0.3 / (n * f)  # a dropped frame shifts one time stamp
    rows = "\n".join(
        f"{ti:.9f},{10 * np.cos(2 * np.pi * i / n):.4f},0,30" for i, ti in enumerate(t)
    )
    text = good(fore=csv_wing("{time: t, sweep: phi, elevation: theta, pitch: eta}"))
    with pytest.raises(SystemExit):
        main(["measured", str(write(tmp_path, text, "t,phi,theta,eta\n" + rows)), "--out", "x"])
    assert "kinematics.fore: from_samples: time is not uniform (step 2" in capsys.readouterr().err
    text = good(fore=csv_wing("{time: t, sweep: phi, elevation: theta, pitch: angle}"))
    with pytest.raises(SystemExit):
        main(["measured", str(write(tmp_path, text, "t,phi,theta,eta\n" + rows)), "--out", "x"])
    assert "kinematics.fore.columns.pitch = 'angle': not a column" in capsys.readouterr().err
