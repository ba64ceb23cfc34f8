"""The physics: a pure, batched quasi-steady model of tandem flapping wings (no Gymnasium here)."""

import os as _os

from ..io.command import check_numba_environment as _check_numba_environment

# numba reads its environment as it is imported and fails deep inside for a bad value: say
# which variable and what is allowed instead (EnvironmentSettingError, a ValueError).
_check_numba_environment()

import numba as _numba

# numba's default OpenMP layer spins its threads: on a shared or oversubscribed CPU (CI, several
# training processes) one small evaluation then costs tens of milliseconds instead of one. The
# work-queue layer does not spin. A user's NUMBA_THREADING_LAYER still wins.
if "NUMBA_THREADING_LAYER" not in _os.environ:
    _numba.config.THREADING_LAYER = "workqueue"

from .backends import BACKENDS, evaluate

#: The model's revision: part of every harness record's key, so a record (and the reference
#: table, its provenance) made by another model is never served as this one's. Bump it in
#: every change that moves any result beyond 1e-10 relative: the model's, and a record's by a
#: change of the harness's search or polish (3 and 4: the polish's finish by autograd, on every
#: part, then on the reported stroke);
#: tests/physics/test_kernel_equal.py's canary fails until it is bumped for the model's
#: (docs/harness.md, "The record cache").
MODEL_REVISION = 4
#: The vortex reading's own revision, in the key of a record made under it beside
#: MODEL_REVISION: bump it in a change that moves the vortex reading's results only (its
#: constants, its reduced wake; docs/model.md §5.8), so that the other readings' records (the
#: reference table's among them) stay served; the canary checks both. 2: the factor on the
#: shed circulation refitted to 1.7 and the hind pair's wake 2 beats long; 3: the fixed point's
#: Anderson step of depth two (2026-12-07); 4: the upstream mean summed in one order whatever
#: the batch, so that a stroke's result is bit for bit its result alone (moves ~1e-10); 5: a
#: wing with another force-coefficient model sheds its own C_L's circulation, not Eq. 14's; 6:
#: the fixed point's passes Gauss-Seidel (the hind pair in the fore pair's field of the same
#: pass), stopping after either pair's solve (moves the results within the fixed point's
#: tolerance); 7: M = 4 read stations with a natural cubic spline onto the elements, not 6
#: with linear interpolation (moves the results by about 1 % of the interaction); 8: Γ shed at
#: the wake grid's phases from the frames there, and the field read at the kernel's samples
#: through a periodic cubic spline, where both were interpolated linearly between samples
#: whose phases move with the stroke (kinks in every result, on which the polish came to rest).
VORTEX_REVISION = 8
#: The wings' gap's revision (``clearance.gaps`` and the tasks' constraints on it), in the key
#: of a record made for an insect that sets ``min_wing_gap``: bump it in a change that moves
#: those records only. 1: one margin, at the least distance; 2: a second at the next place
#: the wings come close (an optimum on the gap at two places can be certified).
GAP_REVISION = 2


def key_revisions(slipstream: str, gap: bool) -> dict[str, int]:
    """The revisions a record's key holds besides MODEL_REVISION: the vortex reading's under it
    (``slipstream``), the gap's where the insect sets one (``gap``)."""
    revisions = {"vortex": VORTEX_REVISION} if slipstream == "vortex" else {}
    return revisions | ({"gap": GAP_REVISION} if gap else {})


from .coefficients import (
    COEFFICIENT_MODELS,
    PaperCoefficients,
    SinusoidalFit,
    TabulatedCoefficients,
    coefficient_model,
)
from .insect import (
    DRAGONFLY,
    PLANFORMS,
    Dragonfly,
    Wing,
    describe_insect,
    insect_mapping,
    load_insect,
)
from .measured import MeasuredWing, evaluate_measured
from .model import (
    AVAILABLE_POWER_LIMITS,
    MAX_FLIGHT_PATH_ANGLE,
    METRIC_NAMES,
    SPEED_LIMITS,
    Result,
    validate_conditions,
)
from .options import ModelOptions
from .stroke import (
    BOUND_TOLERANCE,
    LOWER,
    MODEL_LIMITS,
    N_PARAMETERS,
    PARAMETER_NAMES,
    PARAMETER_UNITS,
    TABLE_4,
    TABLE_4_BOUNDS,
    UPPER,
    Stroke,
    StrokeBounds,
    WingStroke,
    bound_sides,
    describe_bounds,
    normalised_to_physical,
    physical_to_normalised,
    strokes_to_dicts,
    validate_physical,
)

__all__ = [
    "AVAILABLE_POWER_LIMITS",
    "BACKENDS",
    "BOUND_TOLERANCE",
    "COEFFICIENT_MODELS",
    "DRAGONFLY",
    "GAP_REVISION",
    "LOWER",
    "MAX_FLIGHT_PATH_ANGLE",
    "METRIC_NAMES",
    "MODEL_LIMITS",
    "MODEL_REVISION",
    "N_PARAMETERS",
    "PARAMETER_NAMES",
    "PARAMETER_UNITS",
    "PLANFORMS",
    "SPEED_LIMITS",
    "TABLE_4",
    "TABLE_4_BOUNDS",
    "UPPER",
    "VORTEX_REVISION",
    "Dragonfly",
    "MeasuredWing",
    "ModelOptions",
    "PaperCoefficients",
    "Result",
    "SinusoidalFit",
    "Stroke",
    "StrokeBounds",
    "TabulatedCoefficients",
    "Wing",
    "WingStroke",
    "bound_sides",
    "coefficient_model",
    "describe_bounds",
    "describe_insect",
    "evaluate",
    "evaluate_measured",
    "insect_mapping",
    "load_insect",
    "normalised_to_physical",
    "physical_to_normalised",
    "strokes_to_dicts",
    "validate_conditions",
    "validate_physical",
]

from .history import StrokeHistory, WingHistory, measured_history, stroke_history

__all__ += ["StrokeHistory", "WingHistory", "measured_history", "stroke_history"]

#: Names of the torch backend (``torch_model``), imported on first use so that importing the
#: package never imports torch.
_TORCH_NAMES = ("evaluate_torch", "TorchResult")


def __getattr__(name: str):
    if name in _TORCH_NAMES:
        from . import torch_model

        return getattr(torch_model, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
