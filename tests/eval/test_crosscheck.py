"""``python -m eval crosscheck`` without the solver: the command line, what it refuses before
any work, the mapping's geometry against docs/model.md's frames, the wings' clearance, the
model's side and the run records. The solver's own runs: test_crosscheck_uvlm.py."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from agents.records import RecordWarning
from agents.store import RecordStore
from eval.__main__ import main
from eval.crosscheck import uvlm
from eval.crosscheck.case import (
    MAX_SHAPE,
    MIN_CLEARANCE,
    WAKES,
    Case,
    Resolution,
    base_stroke,
    case_runs,
    check_family,
    clearances,
    earth_axes,
    shifted_stroke,
    wing_motion,
    wing_surface,
)
from eval.crosscheck.cli import GRIDS, STUDY_LAGS, locked
from eval.crosscheck.report import ours
from eval.crosscheck.uvlm import SolverJob, SolverRecord
from tandem_env.physics import DRAGONFLY, PARAMETER_NAMES
from tandem_env.physics.kinematics import pitching, weaving


def _fails(args: list[str], capsys: pytest.CaptureFixture, tmp_path: Path) -> str:
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as stop:
        main(["crosscheck", *args, "--out", str(out)])
    assert stop.value.code == 2
    assert not out.exists()  # refused before any work
    return capsys.readouterr().err


def test_help_lists_the_grids(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["crosscheck", "--help"])
    assert stop.value.code == 0
    text = capsys.readouterr().out
    for word in ("lag-study", "tiny", "--steps-per-beat", "--panels", "--convergence", "uvlm"):
        assert word in text


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--stroke", "fore_sweep_shape=0.5"], "fore_sweep_shape (K) = 0.5"),
        (["--stroke", "hind_pitch_shape=2"], "C_η <= 0.1"),
        (["--stroke", "hind_frequency=40"], "hind_frequency = 40 Hz; allowed: equal"),
        (["--stroke", "hind_stroke_plane_angle=20"], "stroke_plane_angle"),
        (["--stroke", "fore_elevation_offset=20"], "fore elevation reaches 21 deg"),
        (["--stroke", "hind_pitch_offset=60"], "hind pitch reaches 110 deg"),
        (["--stroke", "fore_sweep_amplitude=70"], "outside Table 4"),
        (["--stroke", "wing_span=3"], "unknown parameter(s) ['wing_span']"),
        (["--stroke", "fore_sweep_amplitude"], "allowed: NAME=NUMBER"),
        (["--drop", "0", "--lags", "90"], "come within 0.0"),
        (["--grid", "lag-study", "--speed", "1"], "--speed apply to --grid single"),
        (["--panels", "4by8"], "allowed: CxS"),
        (["--panels", "0x8"], "--panels (chordwise) 0"),
        (["--steps-per-beat", "2"], "--steps-per-beat 2; allowed: a whole number 4 to 256"),
        (["--beats", "1"], "--beats 1"),
        (["--lags", "400"], "--lags 400"),
        (["--speed", "0"], "--speed 0; allowed: above 0"),
        (["--scheduler", "local:0"], "local:N needs a whole number"),
        (["--wake", "none"], "argument --wake: invalid choice: 'none'"),
    ],
)
def test_bad_input_is_refused_before_any_work(
    args: list[str], message: str, capsys: pytest.CaptureFixture, tmp_path: Path
) -> None:
    err = _fails(args, capsys, tmp_path)
    lines = err.strip().splitlines()
    assert message in lines[-1] and sum("error:" in line for line in lines) == 1


def test_a_missing_extra_is_one_line_and_exit_2(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture, tmp_path: Path
) -> None:
    monkeypatch.setattr(uvlm, "solver_version", lambda: None)
    assert main(["crosscheck", "--grid", "tiny", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'pip install -e ".[uvlm]"' in err[0]
    assert not (tmp_path / "out" / "records").exists()


def test_a_second_command_on_the_same_folder_is_refused_before_any_run(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture, tmp_path: Path
) -> None:
    def solve(run: object) -> None:
        raise AssertionError("a run was started")

    monkeypatch.setattr(uvlm, "solver_version", lambda: "0.0")  # with the extra or without
    monkeypatch.setattr(uvlm, "solve", solve)
    out = tmp_path / "out"
    with locked(out), pytest.raises(SystemExit) as stop:
        main(["crosscheck", "--grid", "tiny", "--out", str(out)])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert f"another cross-check (pid {os.getpid()}) is writing there" in err
    assert sorted(p.name for p in out.iterdir()) == [".crosscheck.lock"]


def test_sinusoidal_family_limit_keeps_the_waveforms_within_0_15_percent() -> None:
    # The solver moves each angle as a pure sine; at K = C_η = MAX_SHAPE the project's Eqs. 3
    # and 5 differ from it by under 0.15 % of the amplitude (0.06 % and 0.13 %).
    x = np.linspace(0.0, 2.0 * np.pi, 2001)
    sweep = weaving.py_func(x, 1.0, 1.0, 0.0, 0.0, MAX_SHAPE)[0]
    pitch = pitching.py_func(x, 1.0, 1.0, 0.0, 0.0, MAX_SHAPE)[0]
    assert np.max(np.abs(sweep - np.sin(x))) < 1.5e-3
    assert np.max(np.abs(pitch - np.sin(x))) < 1.5e-3
    # ... and at the largest Table 4 shapes they are far from a sine: refusing them matters.
    assert np.max(np.abs(pitching.py_func(x, 1.0, 1.0, 0.0, 0.0, 5.0)[0] - np.sin(x))) > 0.2


def test_segment_panels_share_the_span_in_proportion() -> None:
    assert Resolution(spanwise=8).segment_panels() == (2, 2, 2, 1, 1)  # the exploratory mesh
    for spanwise in (5, 8, 13, 16, 64):
        counts = Resolution(spanwise=spanwise).segment_panels()
        assert sum(counts) == spanwise and min(counts) >= 1
    assert [r.steps_per_beat for r in Resolution().refined()] == [48, 32, 64, 48]
    assert Resolution().refined()[-1].panels == "6x16"


def _model_frame_point(
    phi: float, eta: float, span: float, along: float, beta: float
) -> np.ndarray:
    """A wing point from docs/model.md §4.2, written independently of the mapping: the frame
    R_z(−φ)·R_y(η) (θ = 0) in stroke-plane axes, the span along y_s, the chord along z_s with
    the leading edge at +z_s; ``along`` from the mid-chord towards the trailing edge; returned
    in the solver's geometry axes through the project's earth axes."""

    def rz(a: float) -> np.ndarray:
        return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])

    def ry(a: float) -> np.ndarray:
        return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])

    local = rz(-phi) @ ry(eta) @ np.array([0.0, span, -along])  # (x_s, y_s, z_s)
    b = math.radians(beta)
    x_s = np.array([math.cos(b), 0.0, -math.sin(b)])  # earth axes, docs/model.md §4.1
    y_s = np.array([0.0, 1.0, 0.0])
    z_s = np.array([math.sin(b), 0.0, math.cos(b)])
    earth = local[0] * x_s + local[1] * y_s + local[2] * z_s
    forward, up = earth_axes(beta)  # the earth axes in geometry axes
    return earth[0] * forward + earth[1] * np.array([0.0, 1.0, 0.0]) + earth[2] * up


def test_the_mapping_puts_the_wing_where_the_model_does() -> None:
    stroke = base_stroke(fore_sweep_offset=10.0, fore_pitch_offset=-20.0, fore_sweep_phase=30.0)
    motion = wing_motion(DRAGONFLY.fore, stroke, "fore")
    t = np.array([0.1, 0.37, 0.8]) / motion.frequency
    points = wing_surface(motion, np.zeros(3), t, 0.0, (5, 3))
    phi, eta = motion.angles(t)
    span = np.linspace(0.0, 0.98, 5) * motion.length
    chord = np.interp(span / motion.length, (0.0, 0.3, 0.55, 0.75, 0.9, 0.98), motion.chords)
    for k in range(len(t)):
        for i in range(5):
            for j, fraction in enumerate((-0.5, 0.0, 0.5)):  # leading edge, mid-chord, trailing
                expected = _model_frame_point(phi[k], eta[k], span[i], fraction * chord[i], 15.0)
                assert points[k, 3 * i + j] == pytest.approx(expected, abs=1e-12)
    # Positive pitch leans the leading edge forward (docs/measured.md's convention).
    lead = _model_frame_point(0.0, math.radians(30.0), 0.0, -1.0, 15.0)
    assert lead @ earth_axes(15.0)[0] > 0.0


def test_the_stroke_plane_tilts_forward_by_beta() -> None:
    forward, up = earth_axes(15.0)
    assert forward @ up == pytest.approx(0.0, abs=1e-15)
    assert np.linalg.norm(forward) == pytest.approx(1.0) == np.linalg.norm(up)
    # The stroke-plane normal (−X_G) leans forward by β from the vertical.
    normal = np.array([-1.0, 0.0, 0.0])
    assert normal @ up == pytest.approx(math.cos(math.radians(15.0)))
    assert normal @ forward == pytest.approx(math.sin(math.radians(15.0)))


def test_the_study_grid_is_clear_and_a_level_tandem_collides() -> None:
    stroke = tuple(base_stroke())
    study = Case(stroke, 1.0, DRAGONFLY.root_spacing, DRAGONFLY.root_drop, STUDY_LAGS)
    for gaps in clearances(study, DRAGONFLY).values():
        assert gaps["pairs"] > MIN_CLEARANCE and gaps["left_right"] > MIN_CLEARANCE
    level = Case(stroke, 1.0, DRAGONFLY.root_spacing, 0.0, (0.0, 90.0, 180.0))
    gaps = clearances(level, DRAGONFLY)
    # In one stroke plane, 1.5 chords apart, the wings pass through each other at 90 and 180 deg.
    assert gaps[90.0]["pairs"] < 0.2e-3 and gaps[180.0]["pairs"] < 0.2e-3
    assert gaps[0.0]["pairs"] > MIN_CLEARANCE


def test_a_lag_shifts_the_hind_wing_only() -> None:
    stroke = base_stroke(hind_elevation_harmonic=2.0)
    assert np.array_equal(shifted_stroke(stroke, 0.0), stroke)
    moved = shifted_stroke(stroke, 135.0)
    changed = {PARAMETER_NAMES[i] for i in np.flatnonzero(moved != stroke)}
    assert changed == {"hind_sweep_phase", "hind_pitch_phase", "hind_elevation_phase"}
    named = dict(zip(PARAMETER_NAMES, moved, strict=True))
    assert named["hind_sweep_phase"] == 135.0 and named["hind_pitch_phase"] == -135.0
    assert named["hind_elevation_phase"] == -90.0  # N·lag = 270, wrapped
    assert check_family(moved) is not None


def test_the_models_side_matches_the_issue() -> None:
    # The issue's exploratory case: coupled − isolated gives −9.4 % on the hind-wing at any lag
    # under the cycle-mean slipstream, and nothing on the fore-wing (no feedback).
    case = Case(tuple(base_stroke()), 1.0, DRAGONFLY.root_spacing, DRAGONFLY.root_drop, (0.0, 90.0))
    found = ours(case, DRAGONFLY)
    isolated, mean = found["isolated"], found["mean"]
    change = (mean["hind"] - isolated["hind"]) / isolated["hind"]
    assert change == pytest.approx([-0.094, -0.094], abs=0.001)
    assert np.array_equal(mean["fore"], isolated["fore"])


def test_records_are_reused_and_damage_is_detected(tmp_path: Path) -> None:
    case = Case(tuple(base_stroke()), 1.0, 8.8e-3, 9e-3, (90.0,))
    runs = case_runs(case, DRAGONFLY, Resolution(steps_per_beat=8))
    store = RecordStore(tmp_path)
    job = SolverJob(runs["tandem 90"], "5.1.0")
    result = {"fore": {"vertical": 1e-3}, "hind": {"vertical": 9e-4}, "wall_time": 1.0}
    store.save(SolverRecord(job, result))
    assert store.load(job) == SolverRecord(job, result)
    assert SolverJob(runs["fore"], "5.1.0").key != job.key != SolverJob(job.run, "5.2.0").key
    finer = case_runs(case, DRAGONFLY, Resolution(steps_per_beat=16))["tandem 90"]
    assert store.load(SolverJob(finer, "5.1.0")) is None  # another resolution: another record
    path = store.path(job.key)
    path.write_text(path.read_text().replace("0.0009", "0.0008"))
    with pytest.warns(RecordWarning, match="checksum"):
        assert store.load(job) is None


def test_the_wake_is_keyed_apart_and_free_wake_records_keep_their_keys() -> None:
    case = Case(tuple(base_stroke()), 1.0, 8.8e-3, 9e-3, (90.0,))
    free = case_runs(case, DRAGONFLY, Resolution())
    # The keys the stored free-wake runs were written under before the wake could be chosen
    # (docs/crosscheck/lag_study.csv's runs): reused, not run again.
    stored = {"fore": "923c7faf1c558439f6f1", "hind": "6a24ea635fdbfc4862b4"}
    stored["tandem 90"] = "6734ee24f34014f720e1"
    assert {name: run.key("5.1.0") for name, run in free.items()} == stored
    assert case_runs(case, DRAGONFLY, Resolution(), "free") == free
    prescribed = case_runs(case, DRAGONFLY, Resolution(), "prescribed")
    assert all(run.wake == "prescribed" for run in prescribed.values())
    assert not {run.key("5.1.0") for run in prescribed.values()} & set(stored.values())
    assert "prescribed wake" in prescribed["tandem 90"].label()
    assert "wake" not in free["tandem 90"].label()
    with pytest.raises(ValueError, match="--wake 'fixed'; allowed: free, prescribed"):
        case_runs(case, DRAGONFLY, Resolution(), "fixed")


@pytest.mark.parametrize("wake", WAKES)
def test_the_wake_option_reaches_every_solver_run(
    wake: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture, tmp_path: Path
) -> None:
    started = []

    def solve(run: object) -> None:
        started.append(run)
        raise RuntimeError("no solver here")

    monkeypatch.setattr(uvlm, "solver_version", lambda: "0.0")
    monkeypatch.setattr(uvlm, "solve", solve)
    args = ["crosscheck", "--grid", "tiny", "--wake", wake, "--quiet"]
    assert main([*args, "--out", str(tmp_path / "out")]) == 1
    assert "3 of 3 solver runs failed" in capsys.readouterr().err
    assert sorted(run.kind for run in started) == ["fore", "hind", "tandem"]
    assert {run.wake for run in started} == {wake}


@pytest.fixture
def started(monkeypatch: pytest.MonkeyPatch) -> list:
    """The solver replaced by a stand-in (each pair flown lifts 1 mN, less 10 % in the
    tandem); the list of the runs it was asked for."""
    runs: list = []

    def solve(run: object) -> dict:
        runs.append(run)
        loss = 0.9 if run.kind == "tandem" else 1.0  # type: ignore[attr-defined]
        pairs = [p for p in ("fore", "hind") if getattr(run, p) is not None]
        return {"wall_time": 1.0, **{p: {"vertical": 1e-3 * loss} for p in pairs}}

    monkeypatch.setattr(uvlm, "solver_version", lambda: "0.0")
    monkeypatch.setattr(uvlm, "solve", solve)
    return runs


def test_records_of_the_old_folder_and_the_cache_are_reused(
    started: list, capsys: pytest.CaptureFixture, tmp_path: Path
) -> None:
    first = tmp_path / "first"
    assert main(["crosscheck", "--grid", "tiny", "--out", str(first)]) == 0
    assert len(started) == 3 and "3 solver runs: 3 run" in capsys.readouterr().err
    # Another folder takes them from the record cache; a folder of the earlier layout
    # (OUT/runs/<key>.json, the same files) has them moved into OUT/records once.
    (tmp_path / "old").mkdir()
    (first / "records").rename(tmp_path / "old" / "runs")
    for out in ("second", "old"):
        args = ["crosscheck", "--grid", "tiny", "--out", str(tmp_path / out)]
        assert main(args if out == "old" else [*args, "--quiet"]) == 0
    assert len(started) == 3  # none ran again
    assert "3 reused from" in capsys.readouterr().err
    assert len(list((tmp_path / "old" / "records").glob("*.json"))) == 3
    assert not list((tmp_path / "old" / "runs").glob("*.json"))
    rows = (tmp_path / "second" / "crosscheck.csv").read_text().splitlines()
    column = rows[0].split(",").index("uvlm_hind_change_pct")
    assert float(rows[1].split(",")[column]) == pytest.approx(-10.0)
    args = ["crosscheck", "--grid", "tiny", "--rerun", "--quiet", "--out", str(tmp_path / "old")]
    assert main(args) == 0 and len(started) == 6  # --rerun runs every one again


def test_the_generalisation_grid_varies_the_family_and_is_refused_nothing() -> None:
    cases = [point.case(DRAGONFLY, {}, None) for point in GRIDS["generalisation"].points]
    assert len(cases) >= 12 and all(1 <= len(case.lags) <= 2 for case in cases)
    strokes = {case.stroke for case in cases}
    changed = {
        name
        for stroke in strokes
        for name, value, base in zip(PARAMETER_NAMES, stroke, base_stroke(), strict=True)
        if value != base
    }
    for name in ("sweep_amplitude", "pitch_amplitude", "pitch_phase", "stroke_plane_angle"):
        assert any(name in changed_name for changed_name in changed), name
    assert {"fore_frequency", "hind_elevation_offset"} <= changed
    assert {case.speed for case in cases} >= {0.5, 1.0, 2.0}
    assert len({case.spacing for case in cases}) > 1 and len({case.drop for case in cases}) > 2
    for case in cases:  # what the command refuses before any work, it never plans
        check_family(np.asarray(case.stroke))
        assert min(gaps["pairs"] for gaps in clearances(case, DRAGONFLY).values()) >= MIN_CLEARANCE


def test_the_agreement_is_the_rms_difference_and_the_signs_that_agree() -> None:
    from eval.crosscheck.report import READINGS, agreement

    rows = []
    for solver, model in ((-20.0, -17.0), (4.0, -0.0), (-10.0, -14.0)):
        row = {f"uvlm_{p}_change_pct": solver for p in ("hind", "fore")}
        rows.append(
            row | {f"ours_{r}_{p}_change_pct": model for r in READINGS for p in ("hind", "fore")}
        )
    lines = agreement(rows).splitlines()
    assert len(lines) == 2 + len(READINGS)
    rms = math.sqrt((3.0**2 + 4.0**2 + 4.0**2) / 3)  # 3.56 points; ours 0 has no sign of 4 %
    assert lines[2] == f"| {READINGS[0]} | {rms:.1f} pp | {rms:.1f} pp | 2/3 | 2/3 |"


def test_the_generalisation_table_has_every_reading_and_the_agreement(
    started: list, capsys: pytest.CaptureFixture, tmp_path: Path
) -> None:
    import csv
    from typing import get_args

    from tandem_env.physics.options import Slipstream

    args = ["crosscheck", "--grid", "generalisation", "--wake", "prescribed", "--quiet"]
    assert main([*args, "--out", str(tmp_path)]) == 0
    assert len(started) == 32  # 17 alone and 15 tandem: shared runs run once
    with open(tmp_path / "crosscheck.csv", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 16 and {row["wake"] for row in rows} == {"prescribed"}
    assert (
        rows[0]["stroke_changes"] == "" and rows[6]["stroke_changes"] == "hind_sweep_amplitude=45"
    )
    for reading in get_args(Slipstream):
        assert all(f"ours_{reading}_{pair}_change_pct" in rows[0] for pair in ("hind", "fore"))
    out = capsys.readouterr().out
    assert all(f"| {reading} |" in out for reading in get_args(Slipstream))
    assert (tmp_path / "crosscheck.png").stat().st_size > 10_000


def test_the_stored_tables_model_columns_are_todays_model() -> None:
    """docs/crosscheck's stored tables hold the model as it is: their ``ours_*`` columns
    recomputed on their rows (``python -m eval numbers --only crosscheck-lag-study``, which
    rewrites them after a change of the model) equal the stored ones; rows that are not the
    generalisation grid's are refused."""
    from eval.numbers import framework
    from eval.numbers.crosscheck_lag_study import (
        GENERALISATION_FILES,
        LAG_STUDY_FILES,
        generalisation_columns,
        model_columns,
    )

    for files, refresh in (
        (LAG_STUDY_FILES, model_columns),
        (GENERALISATION_FILES, generalisation_columns),
    ):
        stored = framework.read_rows(files["crosscheck.csv"])
        for old, new in zip(stored, refresh(stored), strict=True):
            for key, value in new.items():
                if key.startswith("ours_"):
                    assert float(value) == pytest.approx(float(old[key]), rel=1e-9, abs=1e-9), key
    rows = framework.read_rows(GENERALISATION_FILES["crosscheck.csv"])
    rows[3]["lag_deg"] = "45.0"
    with pytest.raises(SystemExit, match="not the generalisation grid's"):
        generalisation_columns(rows)
