"""The kernel's arguments as bundles: one per blade element, per wing and for the options.

The compiled kernel (``cycle``, ``induction``, ``blade``) and its torch twin (``torch_model``)
pass each wing's geometry, force coefficients and per-wing inputs, and the options they read,
as these named tuples instead of loose arguments, so that a new kernel option or a new per-wing
input is one field here and one line where the bundle is built (``model.kernel_settings``,
``model.kernel_wings``). Numba compiles a named tuple as a struct (each distinct field type, e.g.
``table`` as ``None`` or an array, is its own compiled signature); torch fills the same
:class:`Section` with tensors. A field that is ``None`` on some paths (``table``) is handed on
as an argument to the function that branches on it: numba prunes ``if x is None`` only for
arguments, which keeps the default path's compiled code as it was.
"""

from __future__ import annotations

from typing import Any, NamedTuple


class Section(NamedTuple):
    """One blade element (an annulus of the span) and its wing's coefficients.

    Node-table values (``model.wing_tables``, ``cycle.N_*`` columns) are per element; the rest
    are the wing's (``cycle.K_*`` constants) and the air's. Floats in the numba kernel; in the
    torch backend the per-element fields are tensors broadcasting over (B, n_blade, n_time).
    The kernel gives every field (``cycle.section_at``); the defaults, 0, make a bare plate.
    """

    r: Any = 0.0
    """Radius r [m]."""
    chord: Any = 0.0
    """Chord c(r) [m]."""
    width: Any = 0.0
    """Quadrature weight dr [m]."""
    m11: Any = 0.0
    """¼πρb_t² [kg/m]."""
    m22: Any = 0.0
    """¼πρc² [kg/m]."""
    inertia_a: Any = 0.0
    """(1/128)πρ(c² + b_t²)² [kg·m]."""
    damping: Any = 0.0
    """(1/16)πρc⁴ [kg·m]."""
    rho: float = 0.0
    """Air density ρ [kg/m³]."""
    ct: float = 0.0
    """Translational coefficient C_t [-]."""
    cd0: float = 0.0
    """C_d(0) [-]."""
    cd90: float = 0.0
    """C_d(π/2) [-]."""
    cr: float = 0.0
    """Rotational coefficient C_r [-]."""
    mu1: float = 0.0
    """Linear rotational damping μ₁ [-]."""
    mu2: float = 0.0
    """Quadratic rotational damping μ₂ [-]."""


class Settings(NamedTuple):
    """The options the kernel reads (``ModelOptions`` as compiled, ``model.kernel_settings``),
    the air and the roots' geometry, and the Fourier tables of the resolution."""

    mode: int
    """``cycle.MODE_NONE``, ``MODE_ISOLATED`` or ``MODE_COUPLED`` (``ModelOptions.induction``)."""
    interference: float
    """C_hf [-]."""
    spin_total: bool
    """Ω = ω·e_s instead of η̇ (``ModelOptions.spin``)."""
    tolerance: float
    """The inflow solve's relative tolerance [-]."""
    max_evaluations: int
    """Most force sweeps of one annulus's inflow solve [-]."""
    convected: bool
    """The convected slipstream (``ModelOptions.slipstream``, docs/model.md §5.7)."""
    means: bool
    """Each wing's cycle means are computed (False: only the per-sample history is written,
    whose means ``cycle.history_means`` takes later: the vortex reading's passes)."""
    pairs: int
    """The pairs a call solves: 1 the fore pair, 2 the hind pair, 3 both (the vortex reading's
    passes solve one pair at a time, docs/model.md §5.8 item 6)."""
    rows: Any
    """(n,) int64: the strokes of the batch a call solves, each writing its outputs at its own
    row and reading ``WingBatch.external`` at its place in ``rows`` (the vortex reading's
    passes, on the strokes not yet converged); (0,): every stroke, in order."""
    rho: float
    """Air density ρ [kg/m³]."""
    root_spacing: float
    """How far the hind-wing's root is behind the fore-wing's [m] (``Dragonfly``)."""
    root_drop: float
    """How far the hind-wing's root is below the fore-wing's [m]."""
    cos_table: Any
    """cos(m·s_k), (n_time, M) (``cycle.fourier_tables``)."""
    sin_table: Any
    """sin(m·s_k), (n_time, M)."""


class WingBatch(NamedTuple):
    """One wing's inputs for a batch of B strokes (``cycle.tandem_cycle``)."""

    angles: Any
    """(B, n_time, 9) φ, φ̇, φ̈, θ, θ̇, θ̈, η, η̇, η̈ [rad, rad/s, rad/s²]."""
    weight: Any
    """(B, n_time) quadrature weights dτ/ds [-]."""
    frequency: Any
    """(B,) [Hz]."""
    beta: Any
    """(B,) stroke-plane angle β [rad]."""
    sweep: Any
    """(B,) sweep amplitude φ_m [rad]."""
    v_tangential: Any
    """(B,) the body's velocity along x_s, V_t [m/s] (``model.freestream_components``)."""
    v_normal: Any
    """(B,) along z_s, V_n [m/s]."""
    inflow_off: Any
    """(B,) bool: no induced velocity whatever the mode (``model.inflow_switched_off``)."""
    phases: Any
    """(B, n_time) the samples' phases ϑ = 2πft [rad], or (0, n_time) where unread."""
    nodes: Any
    """(n_blade, ``cycle.N_COLUMNS``) node table (``model.wing_tables``)."""
    consts: Any
    """(``cycle.N_CONSTANTS``,) the wing's constants."""
    table: Any
    """The force-coefficient model's table (``coefficients``), None for the paper's."""
    external: Any
    """(B, 2, M, n_time) the other pair's induced velocity in the (u, v) of each element at M
    span stations [m/s], which ``to_elements`` (n_blade, M) interpolates onto the elements,
    and ``external_inflow`` (B, n_blade) its cycle mean along −z_s, the upstream inflow of the
    momentum side (the vortex reading's passes, docs/model.md §5.8; ``interaction``), or
    (0, …): none."""
    external_inflow: Any
    to_elements: Any
    """(n_blade, M) the read stations' interpolation weights onto the elements (``external``;
    unread where ``external`` has no rows)."""
    frames: Any
    """(B, n_time, ``blade.N_COEF``) the frame coefficients of each sample
    (``blade.fill_frame_coefficients``, the right wing) where the caller has them, or (0, …):
    the kernel computes them."""


class WingStroke(NamedTuple):
    """One wing of one stroke, as ``cycle.wing_cycle`` integrates it."""

    coef: Any
    """(n_time, ``blade.N_COEF``) frame coefficients (``blade.fill_frame_coefficients``)."""
    nodes: Any
    """(n_blade, ``cycle.N_COLUMNS``) node table."""
    consts: Any
    """(``cycle.N_CONSTANTS``,) the wing's constants."""
    table: Any
    """The force-coefficient model's table, None for the paper's."""
    frequency: float
    """[Hz]."""
    sweep: float
    """Sweep amplitude φ_m [rad]."""
    v_tangential: float
    """V_t [m/s]."""
    v_normal: float
    """V_n [m/s]."""
    weight: Any
    """(n_time,) quadrature weights [-]."""
    phase: Any
    """(n_time,) phases ϑ [rad] (read by the convected slipstream only; may be empty)."""


class Outputs(NamedTuple):
    """Where ``cycle.tandem_cycle`` writes."""

    means: Any
    """(B, 2, ``cycle.N_WING_OUT``) per-wing cycle means."""
    inflow: Any
    """(B, 2, n_blade) induced velocity per annulus [m/s]."""
    history: Any
    """(B, 2, n_time, 5) per-sample F_x, F_z, F_y [N], P_aero, P_iner [W], or (0, …): none."""
