"""Today's kernel against the values commit 8e3cf19's kernel gave (tests/data/kernel_8e3cf19.npz,
written by tests/physics/kernel_cases.py): the reference optima, random strokes at the speed
benchmark's call and under every option set of the torch-backend test.

Every float field within 1e-10 relative (denominator floored at 1e-6), flags and counts equal.
The excess forces are differences of O(1) terms, F̄_v = L/W − 1 and F̄_h = (T − D)/W, which
vanish at the constrained optima of the reference table: their denominator is floored at those
terms' magnitude (L/W, resp. (T + D)/W, and both for F̄_a) instead, since a change of one
rounding in T (the positive part's new Fourier transform) is 1e-16 of T/W, and 1e-10 of a
difference below 1e-6.
The summation order of the sweeps and Fourier sums changed (docs/model.md §12), so an inflow
solve whose stopping test sits within rounding of its tolerance could stop one sweep earlier or
later; such a stroke is listed by name, not hidden.

The positive-part means (thrust, drag and the powers) moved on purpose: 8e3cf19 missed the
interpolant's crossings between two samples of one sign (tests/physics/test_positive_part.py;
docs/model.md §11), on about one stroke in six of these cases. A missed crossing pair only ever
left out positive area (a negative dip counted, or a positive hump dropped), so today's values
of those fields are never below 8e3cf19's (but for the ~1e-10 to which a crossing pair near a
double root is located); the count of strokes that moved is printed. The
efficiency and the literal horizontal excess are computed from them and are not compared.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import tandem_env as te

sys.path.insert(0, str(Path(__file__).parent))
from kernel_cases import CANARY, FIXTURE, options_of, stacked

RELATIVE = 1e-10
FLOOR = 1e-6
WEIGHT = te.DRAGONFLY.weight  # [N], both planforms


def _terms(r: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The magnitudes of the terms of F̄_v and F̄_h: L/W and (|T| + |D|)/W."""
    return np.abs(r["lift_to_weight"]), (np.abs(r["thrust"]) + np.abs(r["drag"])) / WEIGHT


TERMS = {
    "excess_vertical": lambda r: _terms(r)[0],
    "excess_horizontal": lambda r: _terms(r)[1],
    "excess_total": lambda r: np.minimum(*_terms(r)),
    # D = T − F̄_x, a difference too: one rounding of T is 1e-16 of T, not of D
    "drag": lambda r: np.abs(r["thrust"]),
}


#: Fields that are (sums of) positive-part means: today's >= 8e3cf19's.
POSITIVE_PARTS = (
    "thrust",
    "drag",
    "power",
    "power_per_mass",
    *(f"{wing}_{kind}" for wing in ("fore", "hind") for kind in ("power", "aero_power")),
    *(f"{wing}_inertial_power" for wing in ("fore", "hind")),
)
#: Fields computed from the positive parts: not compared.
FROM_POSITIVE_PARTS = ("efficiency", "excess_horizontal_literal")


def compare(
    expected: dict[str, np.ndarray],
    got: dict[str, np.ndarray],
    one_sided: tuple[str, ...] = POSITIVE_PARTS,
    skipped: tuple[str, ...] = FROM_POSITIVE_PARTS,
) -> tuple[float, str, list[str], int, float]:
    """The largest relative difference of any float field but ``one_sided`` and ``skipped``,
    where it is ('field: case #i'), the strokes ('case #i') whose flags or counts differ, the
    number of strokes whose ``one_sided`` fields moved beyond :data:`RELATIVE`, and the largest
    fall of one of them below ``expected`` (relative)."""
    assert list(got["case_names"]) == list(expected["case_names"]), "regenerate the fixture"
    case = np.repeat(expected["case_names"], expected["case_sizes"])
    index = np.concatenate([np.arange(n) for n in expected["case_sizes"]])
    worst, where, flipped = 0.0, "", set()
    moved = np.zeros(len(case), dtype=bool)
    fall = 0.0
    for name, want in expected.items():
        if name in (
            "case_names",
            "case_sizes",
            "per_set",
            "batch",
            "revision",
            "vortex_revision",
            *skipped,
        ):
            continue
        have = got[name]
        if want.dtype == bool or np.issubdtype(want.dtype, np.integer):
            flipped |= {f"{case[i]} #{index[i]}" for i in np.flatnonzero(have != want)}
        else:
            floor = np.maximum(TERMS[name](expected), FLOOR) if name in TERMS else FLOOR
            scale = np.maximum(np.abs(want), floor)
            if name in one_sided:
                moved |= np.abs(have - want) > RELATIVE * scale
                fall = max(fall, float(np.max((want - have) / scale)))
                continue
            error = np.abs(have - want) / scale
            i = int(np.argmax(error))
            if error[i] > worst:
                worst, where = float(error[i]), f"{name}: {case[i]} #{index[i]}"
    return worst, where, sorted(flipped), int(moved.sum()), fall


def _today(stored: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The cases ``stored`` holds, evaluated by today's model with the option sets it names (the
    torch test's covering has grown since 8e3cf19's fixture)."""
    names = [str(n) for n in stored["case_names"] if str(n).startswith("ModelOptions(")]
    return stacked(int(stored["per_set"]), int(stored["batch"]), [options_of(n) for n in names])


def test_kernel_equals_its_previous_version() -> None:
    expected = dict(np.load(FIXTURE))
    worst, where, flipped, moved, fall = compare(expected, _today(expected))
    print(f"largest relative difference {worst:.3g} ({where}); stops flipped: {flipped or 'none'}")
    print(f"positive parts moved on {moved} of {sum(expected['case_sizes'])} strokes")
    assert not flipped, f"inflow solves that stop at another sweep: {flipped}"
    assert worst <= RELATIVE, worst
    # a crossing pair near a double root is located to ~1e-10 of the mean (six Newton steps,
    # tests/physics/test_positive_part.py), in either direction
    assert fall <= 1e-9, f"a positive part fell below 8e3cf19's by {fall:.3g}"


def _cases(data: dict[str, np.ndarray], vortex: bool) -> dict[str, np.ndarray]:
    """The cases of ``data`` under the vortex reading (``vortex``) or under the others."""
    names = [str(n) for n in data["case_names"]]
    mine = np.array(["slipstream='vortex'" in n for n in names]) == vortex
    rows = np.repeat(mine, data["case_sizes"])
    cases = {"case_names": data["case_names"][mine], "case_sizes": data["case_sizes"][mine]}
    return {
        name: value if value.ndim == 0 or name in cases else value[rows]
        for name, value in data.items()
    } | cases


@pytest.mark.parametrize("vortex", [False, True], ids=["other readings", "vortex reading"])
def test_results_move_only_with_the_model_revision(vortex: bool) -> None:
    # The canary: a record is reused while its model revision is today's (docs/harness.md, "The
    # record cache"), so every change of a result beyond RELATIVE must bump MODEL_REVISION, or
    # VORTEX_REVISION where only the vortex reading's results move.
    stored = dict(np.load(CANARY))
    today = {"revision": te.physics.MODEL_REVISION}
    if vortex:
        today["vortex_revision"] = te.physics.VORTEX_REVISION
    held = {name: int(stored[name]) if name in stored else None for name in today}
    assert held == today, (
        f"{CANARY.name} holds revisions {held}, today's are {today}: rewrite it with "
        "PYTHONPATH=. python tests/physics/kernel_cases.py --canary"
    )
    mine = _cases(stored, vortex)
    assert len(mine["case_names"]) > 0
    worst, where, flipped, _, _ = compare(mine, _cases(_today(stored), vortex), (), ())
    print(f"largest relative change {worst:.3g} ({where}); flags changed: {flipped or 'none'}")
    bump, revision = (
        ("VORTEX_REVISION", "vortex_revision") if vortex else ("MODEL_REVISION", "revision")
    )
    assert worst <= RELATIVE and not flipped, (
        f"the model's results moved by {worst:.3g} ({where}; flags: {flipped or 'none'}) while "
        f"{bump} is still {today[revision]}: bump {bump} "
        "(tandem_env/physics/__init__.py), then rewrite the canary (PYTHONPATH=. python "
        "tests/physics/kernel_cases.py --canary)"
    )
