"""Resolution convergence: the defaults against a 4× refined run (docs/model.md §11).

Errors are relative, against an absolute floor for quantities near zero (0.1·W for forces,
0.1 for L/W; docs/model.md §11). ``python benchmarks/convergence.py`` prints the full study that
chose the defaults.
"""

from __future__ import annotations

import numpy as np
import pytest

import tandem_env as te
from tandem_env import ModelOptions, evaluate

#: The study that chose the defaults is of the paper's model, the mean reading (the vortex
#: reading's own reduced wake and fixed point: tests/physics/test_vortex_reading.py).
DEFAULT = ModelOptions(slipstream="mean")
REFINED = ModelOptions(n_time=4 * DEFAULT.n_time, n_blade=4 * DEFAULT.n_blade, slipstream="mean")
QUANTITIES = {
    "lift_to_weight": 0.1,
    "thrust": 0.1,
    "drag": 0.1,
    "power": 0.0,
}  # floor (× W for forces)


def relative_errors(speed: float, n: int = 100, seed: int = 2024) -> dict[str, np.ndarray]:
    strokes = te.normalised_to_physical(np.random.default_rng(seed).uniform(-1, 1, (n, 28)))
    coarse = evaluate(strokes, speed, options=DEFAULT)
    fine = evaluate(strokes, speed, options=REFINED)
    weight = te.DRAGONFLY.weight
    errors = {}
    for name, floor in QUANTITIES.items():
        scale = floor * (1.0 if name == "lift_to_weight" else weight)
        reference = getattr(fine, name)
        errors[name] = np.abs(getattr(coarse, name) - reference) / np.maximum(
            np.abs(reference), scale
        )
        if floor == 0.0:
            errors[name] = np.abs(getattr(coarse, name) - reference) / np.abs(reference)
    assert coarse.induction_converged.all() and fine.induction_converged.all()
    return errors


@pytest.mark.parametrize("speed", [1.0, 2.0])
def test_defaults_within_half_a_percent_of_refined_in_forward_flight(speed: float) -> None:
    for name, error in relative_errors(speed).items():
        print(f"V={speed}: {name} median {np.median(error):.2e} max {error.max():.2e}")
        assert error.max() < 5e-3, name


def test_defaults_in_hover() -> None:
    """At V = 0 the induced velocity has a square-root singularity where an annulus's mean
    normal force changes sign along the span (v_i = 0 beyond it, docs/model.md §5), so span
    convergence is algebraic there: a few strokes in a hundred keep errors of 0.5-2 % in L/W.
    Time quadrature is spectral and all other quantities meet 0.5 % on every stroke."""
    errors = relative_errors(0.0)
    for name, error in errors.items():
        print(
            f"V=0: {name} median {np.median(error):.2e} p95 {np.percentile(error, 95):.2e} max {error.max():.2e}"
        )
        assert np.median(error) < 5e-4, name
        assert np.percentile(error, 95) < 5e-3, name
    for name in ("thrust", "drag", "power"):
        assert errors[name].max() < 5e-3, name
    assert errors["lift_to_weight"].max() < 3e-2


def test_time_quadrature_is_spectral() -> None:
    """Doubling the time samples at fixed span resolution shrinks errors far faster than 4×."""
    strokes = te.normalised_to_physical(np.random.default_rng(5).uniform(-1, 1, (40, 28)))

    def run(n_time: int) -> te.Result:
        options = ModelOptions(n_time=n_time, n_blade=8, slipstream="mean")
        return evaluate(strokes, 1.0, options=options)

    reference, half, full = run(512), run(64), run(128)
    for name in ("thrust", "power", "lift_to_weight"):
        e_half = np.abs(getattr(half, name) - getattr(reference, name)).max()
        e_full = np.abs(getattr(full, name) - getattr(reference, name)).max()
        assert e_full < e_half / 16, name


def test_thousands_of_random_strokes_are_finite_and_physical() -> None:
    rng = np.random.default_rng(77)
    strokes = te.normalised_to_physical(rng.uniform(-1, 1, (4000, 28)))
    for speed in (0.0, 1.0, 2.0):
        result = evaluate(strokes, speed, options=DEFAULT)
        for name, value in result.as_dict().items():
            assert np.all(np.isfinite(value)), (speed, name)
        assert np.all(result.power > 0.0)
        assert np.all(result.efficiency >= 0.0)
        assert result.induction_converged.all()
        print(
            f"V={speed}: efficiency > 1 on {result.efficiency_above_one.mean():.2%} of 4000 random strokes"
        )
