"""``python -m eval crosscheck`` with the solver: one real, coarse case end to end (the
``tiny`` grid: 8 steps per beat, 2x5 panels, 2 beats; under a minute) and the solver's wing
geometry against the mapping's. Skipped where the ``uvlm`` extra is not installed."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip(
    "pterasoftware",
    reason='Ptera Software (the uvlm extra) is not installed: pip install -e ".[uvlm]"',
)

from eval.__main__ import main
from eval.crosscheck.case import (
    Case,
    Resolution,
    base_stroke,
    case_runs,
    wing_surface,
)
from eval.crosscheck.uvlm import build
from tandem_env.physics import DRAGONFLY


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("crosscheck")
    assert main(["crosscheck", "--grid", "tiny", "--quiet", "--out", str(out)]) == 0
    return out


def test_a_tiny_case_runs_and_writes_its_table(tiny: Path) -> None:
    with open(tiny / "crosscheck.csv", encoding="utf-8") as handle:
        (row,) = list(csv.DictReader(handle))
    assert float(row["lag_deg"]) == 90.0 and row["panels"] == "2x5"
    assert (tiny / "crosscheck.png").stat().st_size > 10_000
    assert "UVLM hind" in (tiny / "crosscheck.md").read_text()
    # The mapping's signs: each pair alone lifts, as the model's isolated pair does, and within
    # a factor of two of it (an inviscid lattice has no leading-edge vortex: no closer target).
    for pair in ("fore", "hind"):
        uvlm, model = float(row[f"uvlm_{pair}_alone_mN"]), float(row[f"ours_isolated_{pair}_mN"])
        assert 0.5 < uvlm / model < 2.0, pair
    # The fore-wing's wake takes lift from the hind-wing, as in the model (the sign).
    assert float(row["uvlm_hind_change_pct"]) < 0.0
    assert float(row["ours_mean_hind_change_pct"]) < 0.0


def test_left_and_right_wings_mirror_each_other(tiny: Path) -> None:
    records = [json.loads(p.read_text()) for p in (tiny / "records").glob("*.json")]
    assert sorted(r["run"]["kind"] for r in records) == ["fore", "hind", "tandem"]
    for record in records:
        for pair in ("fore", "hind"):
            if pair in record["result"]:
                forces = record["result"][pair]
                assert abs(forces["lateral"]) < 1e-6 * abs(forces["vertical"])
                assert len(forces["vertical_history"]) == 8  # the last beat's steps


def test_a_rerun_reuses_every_record(tiny: Path, capsys: pytest.CaptureFixture) -> None:
    before = {p: p.stat().st_mtime_ns for p in (tiny / "records").glob("*.json")}
    assert main(["crosscheck", "--grid", "tiny", "--out", str(tiny)]) == 0
    assert "3 solver runs: 0 run, 3 reused from" in capsys.readouterr().err
    assert {p: p.stat().st_mtime_ns for p in (tiny / "records").glob("*.json")} == before


def test_the_solvers_wing_is_the_mappings() -> None:
    # Every panel corner of the solver's right hind wing, at a few steps of the tandem, lies on
    # the surface the clearance check uses (and which test_crosscheck.py checks against
    # docs/model.md's frames): the rotation order, signs and pitch axis agree.
    stroke = base_stroke(hind_sweep_offset=10.0, hind_pitch_offset=-15.0)
    case = Case(tuple(stroke), 1.0, DRAGONFLY.root_spacing, DRAGONFLY.root_drop, (45.0,))
    resolution = Resolution(steps_per_beat=8, chordwise=2, spanwise=5, beats=2)
    run = case_runs(case, DRAGONFLY, resolution)["tandem 45"]
    problem, _, names = build(run)
    assert names == ["fore", "hind"]
    origin = problem.steady_problems[0].airplanes[1].Cg_GP1_CgP1
    for step in (1, 3, 6):
        t = np.array([step / (8 * run.hind.frequency)])
        # Finely along the span (0.07 mm apart), at the leading edge, mid-chord and trailing
        # edge: the solver's chordwise corners at 2 uniform panels.
        expected = wing_surface(run.hind, np.asarray(origin), t, run.root_offset, (400, 3))[0]
        wings = problem.steady_problems[step].airplanes[1].wings
        right = max(wings, key=lambda w: np.mean([p.Cpp_GP1_CgP1[1] for p in w.panels.ravel()]))
        corners = np.array(
            [
                corner
                for panel in right.panels.ravel()
                for corner in (panel.Frpp_GP1_CgP1, panel.Flpp_GP1_CgP1, panel.Brpp_GP1_CgP1)
            ]
        )
        gaps = np.min(np.linalg.norm(corners[:, None, :] - expected[None, :, :], axis=-1), axis=1)
        assert np.max(gaps) < 0.1e-3, step  # within 0.1 mm of the mapping's surface


def test_the_prescribed_wake_runs_apart_from_the_free_wake(tiny: Path, tmp_path: Path) -> None:
    out = tmp_path / "prescribed"
    assert (
        main(["crosscheck", "--grid", "tiny", "--wake", "prescribed", "--quiet", "--out", str(out)])
        == 0
    )
    with open(out / "crosscheck.csv", encoding="utf-8") as handle:
        (row,) = list(csv.DictReader(handle))
    with open(tiny / "crosscheck.csv", encoding="utf-8") as handle:
        (free,) = list(csv.DictReader(handle))
    assert row["wake"] == "prescribed" and free["wake"] == "free"
    assert float(row["uvlm_hind_change_pct"]) < 0.0  # the fore-wing's wake still costs lift
    # Another solver: other forces, under other keys.
    assert float(row["uvlm_hind_tandem_mN"]) != float(free["uvlm_hind_tandem_mN"])
    keys = {p.name for p in (out / "records").glob("*.json")}
    assert len(keys) == 3 and not keys & {p.name for p in (tiny / "records").glob("*.json")}
