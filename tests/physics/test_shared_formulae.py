"""The kernel's pointwise formulae are written once (docs/model.md §12.1): each runs compiled on
numba's scalars and, through ``xp.on_namespace``, on whole arrays (the torch backend's way).
Both must give the same numbers bit for bit, still elements (u = v = 0) and the other guarded
cases included: a formula that branches with ``if`` on a value instead of ``xp.select`` fails
here on arrays."""

from __future__ import annotations

import numpy as np
import pytest

from tandem_env.physics import blade, cycle, induction, model
from tandem_env.physics.bundle import Section
from tandem_env.physics.insect import DRAGONFLY
from tandem_env.physics.options import ModelOptions
from tandem_env.physics.xp import NUMPY, on_namespace

N = 64
RNG = np.random.default_rng(7)
SECTION = Section(0.03, 0.008, 0.001, 1e-6, 6e-5, 1e-9, 2e-9, 1.225, 1.8, 0.2, 3.4, 3.1, 0.2, 0.3)


def values(zero_every: int = 4) -> np.ndarray:
    """N random values with exact zeros among them (the guarded cases)."""
    out = RNG.normal(0.0, 2.0, N)
    out[::zero_every] = 0.0
    return out


COEF = RNG.normal(0.0, 1.0, (N, blade.N_COEF))
ANGLES = RNG.normal(0.0, 1.0, (N, 9))
WEIGHT = RNG.uniform(0.5, 1.5, N)

ROOTS = model.kernel_settings(DRAGONFLY, ModelOptions(), 8)  # root_spacing, root_drop
#: Arrays the formulae index by the sample k themselves (the array call takes k = ...).
SAMPLED = (COEF, ANGLES, WEIGHT)

#: (formula, its arguments): "k" is the sample index, an (N,) array one value per element
#: (unless :data:`SAMPLED`), anything else is shared.
CASES = {
    "relative_velocity": (blade.relative_velocity, (COEF, "k", 0.03, values(), values())),
    "element_force": (blade.element_force, (*(values() for _ in range(5)), SECTION)),
    "element_moment": (blade.element_moment, (*(values() for _ in range(4)), SECTION, 40.0)),
    "element_power": (blade.element_power, (COEF, "k", values(), values(), values(), SECTION)),
    "shed_force": (blade.shed_force, (COEF, "k", *(values() for _ in range(6)), SECTION)),
    "acute_angle": (blade.acute_angle, (values(3), values(2))),
    "earth_forces": (blade.earth_forces, (COEF, "k", values(), values())),
    "inertial_power": (blade.inertial_power, (COEF, "k", 2e-9, 3e-10)),
    "frame_columns": (blade.frame_columns, (ANGLES, "k", WEIGHT, 0.8, 0.6, False, 1)),
    "frame_columns_total_left": (blade.frame_columns, (ANGLES, "k", WEIGHT, 0.8, 0.6, True, -1)),
    "normal_force_rate": (induction.normal_force_rate, (*(values() for _ in range(7)), SECTION)),
    "momentum": (induction._momentum, (values(), 3.0, values(2), values(3))),
    "model_residual": (
        induction._model_residual,
        (values(), (0.1, 0.2, -0.3, 0.4, -0.5), 3.0, values(2), values(3)),
    ),
    "slipstream_delay": (cycle.slipstream_delay, (values(), values(), values(), values(), ROOTS)),
}  # fmt: skip


def _at(arg, i: int):
    if isinstance(arg, str):
        return i  # the sample index k
    if isinstance(arg, np.ndarray) and not any(arg is a for a in SAMPLED):
        return float(arg[i])
    return arg


@pytest.mark.parametrize("name", sorted(CASES))
def test_formula_gives_the_same_on_scalars_and_on_arrays(name: str) -> None:
    formula, args = CASES[name]
    on_arrays = on_namespace(formula, NUMPY)(*(... if isinstance(a, str) else a for a in args))
    scalar = [formula(*(_at(a, i) for a in args)) for i in range(N)]
    if isinstance(on_arrays, tuple):
        for part, got in enumerate(on_arrays):
            want = np.array([row[part] for row in scalar])
            np.testing.assert_array_equal(np.broadcast_to(got, want.shape), want, err_msg=name)
    else:
        np.testing.assert_array_equal(on_arrays, np.array(scalar), err_msg=name)
