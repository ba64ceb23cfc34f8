"""The model in PyTorch: the numba kernel's cycle (``cycle``), differentiable and on any device.

:func:`evaluate_torch` evaluates the same model as :func:`model.evaluate_numba` (docs/model.md,
every ``ModelOptions`` value, both planforms, the paper's force coefficients), vectorised over the
batch and the blade elements instead of looping over them, and returns a :class:`TorchResult`
of tensors with the :class:`~tandem_env.physics.model.Result` field names, differentiable by
autograd with respect to the strokes and to speed, flight-path angle and available power where
those are tensors. It follows the numba kernel decision by decision, so that the two agree to
rounding (docs/model.md §12.1):

* the pointwise formulae are the kernel's own, run on tensors (``xp.on_namespace``): the
  frame coefficients of every sample (``blade.frame_columns``), the element's relative
  velocity, force, moment, power, shed force and acute angle of attack, the wing's force in
  earth axes and inertial power (``blade``, Eqs. 6-16), the slope of the normal force, the
  momentum side and the solve's model residual (``induction``), the convected wake's delay
  (``cycle.slipstream_delay``), and the blade elements (``cycle.section_at``, a
  ``bundle.Section`` of tensors from the node tables of :func:`model.wing_tables`);
* mirrored here: the per-annulus safeguarded Newton inflow solve of
  ``induction.solve_annulus_samples``, every annulus with its own iterate, bracket and stopping
  rule: a converged annulus is masked and keeps its value while the others go on (no fixed
  iteration count); the exact positive-part integrals of ``cycle.mean_positive_part`` (zero
  crossings of the trigonometric interpolant by the same safeguarded Newton); the convected
  wake's transforms;
* the kinematics (Eqs. 3-5) and the motion-following grid, the free stream and the performance
  step (Eqs. 17-27) are shared too: ``kinematics.batched_angle_history``,
  ``model.stroke_plane_speeds``, ``model.inflow_switched_off`` and ``model.flight_performance``,
  written once over an array namespace (``xp``), run on tensors here.

Derivatives. Autograd differentiates the solve as the numba kernel computes it: through every
force sweep and slope the outer iteration used. The inner scalar solves (the force model
against the momentum side, converged to 1e-12) run without a graph, and their root v* is
attached by the implicit-function rule dv*/dθ = −(∂q/∂θ)/(∂q/∂v) at that root. The zero
crossings of the positive-part integrals are attached as constants: the integrand vanishes
there, so their motion changes the integral only to second order.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Sequence
from dataclasses import fields, make_dataclass
from functools import cache
from typing import Any

import numpy as np
import torch

from . import blade, clearance, cycle, induction, interaction
from .bundle import Section
from .checks import count, flag
from .coefficients import PaperCoefficients
from .insect import DRAGONFLY, Dragonfly
from .kinematics import batched_angle_history, wing_params_radians
from .model import (
    _METADATA,
    DEFAULT_OPTIONS,
    OPTIONAL_FIELDS,
    Result,
    check_model_inputs,
    flight_performance,
    inflow_switched_off,
    stroke_plane_speeds,
    validate_conditions,
    wing_tables,
)
from .options import ModelOptions
from .stroke import (
    DISCRETE,
    N_PARAMETERS,
    N_PER_WING,
    StrokeBounds,
    map_normalised,
    normalised_to_physical,
    validate_physical,
)
from .xp import ArrayNamespace, on_namespace

#: torch's :class:`~tandem_env.physics.xp.ArrayNamespace`: the shared model code on tensors.
TORCH = ArrayNamespace(
    module=torch,
    maximum=lambda x, low: torch.clamp(x, min=low),
    minimum=lambda x, high: torch.clamp(x, max=high),
    all_along=lambda x, axis: torch.all(x, dim=axis),
    max_along=lambda x, axis: torch.amax(x, dim=axis),
    as_int64=lambda x: x.to(torch.int64),
    zeros_bool=lambda x: torch.zeros_like(x, dtype=torch.bool),
    arange_like=lambda n, x: torch.arange(n, dtype=x.dtype, device=x.device),
    constant_like=lambda a, x: torch.as_tensor(a, dtype=x.dtype, device=x.device),
)

#: Floating dtypes the backend computes in (float64 is the default and the one tested to 1e-8).
DTYPES = (torch.float64, torch.float32)
#: Device types the backend runs on.
DEVICE_TYPES = ("cpu", "cuda")
#: Strokes per chunk (memory is bounded by one chunk's (chunk, n_blade, n_time) sweeps).
CHUNK_SIZE = {"cpu": 1024, "cuda": 16384}

#: The array fields of ``Result``, read from the dataclass itself (a field added there or
#: removed is a test failure here, not silent drift).
RESULT_FIELDS: tuple[str, ...] = tuple(
    f.name for f in fields(Result) if f.name not in (*_METADATA, *OPTIONAL_FIELDS)
)

TorchResult = make_dataclass(
    "TorchResult",
    [(name, torch.Tensor) for name in RESULT_FIELDS]
    + [(name, Any, None) for name in OPTIONAL_FIELDS]
    + [("options", ModelOptions, DEFAULT_OPTIONS), ("planform", str, "tear-drop")],
    frozen=True,
    namespace={
        "__doc__": "``Result``'s fields as (B,) tensors on the strokes' device (same names, units).",
        "__len__": lambda self: int(self.lift_to_weight.shape[0]),
        "to_numpy": lambda self: to_numpy_result(self),
    },
)

_TWO_PI = 2.0 * math.pi


# --- input checks -------------------------------------------------------------------------------
def resolve_device(device: Any) -> torch.device:
    """``device`` (None: the CPU) as a ``torch.device`` this backend can run on, or ValueError."""
    if device is None:
        return torch.device("cpu")
    allowed = "None, 'cpu', 'cuda', 'cuda:<index>' or a torch.device of those"
    try:
        dev = torch.device(device)
    except (RuntimeError, TypeError):
        raise ValueError(f"device = {device!r} is not a torch device; allowed: {allowed}") from None
    if dev.type not in DEVICE_TYPES:
        raise ValueError(f"device = {device!r}; allowed: {allowed}")
    if dev.type == "cpu" and dev.index not in (None, 0):
        # torch takes any index for the CPU and runs on the one CPU device: cpu:1 is no device
        raise ValueError(f"device = {device!r}: there is one CPU device; allowed: {allowed}")
    if dev.type == "cuda":
        if not torch.cuda.is_available():
            raise ValueError(
                f"device = {device!r} but CUDA is not available (torch {torch.__version__}, "
                f"torch.cuda.is_available() is False); allowed here: None or 'cpu'"
            )
        if dev.index is not None and dev.index >= torch.cuda.device_count():
            raise ValueError(
                f"device = {device!r}; allowed: cuda:0 to cuda:{torch.cuda.device_count() - 1}"
            )
    return dev


def _check_strokes(strokes: Any, bounds: StrokeBounds) -> torch.Tensor:
    if not isinstance(strokes, torch.Tensor):
        raise ValueError(
            f"strokes is a {type(strokes).__name__}; allowed: a torch.Tensor of shape "
            f"(B, {N_PARAMETERS}) or ({N_PARAMETERS},), float64 or float32 "
            "(tandem_env.evaluate(..., backend='torch') takes arrays)"
        )
    if strokes.dtype not in DTYPES:
        raise ValueError(
            f"strokes has dtype {strokes.dtype}; allowed: torch.float64 or torch.float32"
        )
    if strokes.device.type not in DEVICE_TYPES:
        raise ValueError(f"strokes is on device {strokes.device}; allowed: a cpu or cuda tensor")
    if strokes.ndim == 1:
        strokes = strokes[None, :]
    if strokes.ndim != 2 or strokes.shape[1] != N_PARAMETERS or strokes.shape[0] == 0:
        raise ValueError(
            f"strokes has shape {tuple(strokes.shape)}; allowed: (B, {N_PARAMETERS}) with B >= 1 "
            f"or ({N_PARAMETERS},)"
        )
    # the insect's bounds, N in {1, 2}, finiteness: the numpy check, on a detached copy
    validate_physical(strokes.detach().to("cpu", torch.float64).numpy(), bounds=bounds)
    return strokes


def _as_checkable(value: Any, name: str, like: torch.Tensor) -> Any:
    """A flight condition for ``model.validate_conditions``: a tensor (on the strokes' device, a
    float dtype) as a detached float64 numpy copy, anything else as it is."""
    if not isinstance(value, torch.Tensor):
        return value
    if value.device != like.device:
        raise ValueError(
            f"{name} is on device {value.device}; allowed: the strokes' device {like.device}"
        )
    if value.dtype not in DTYPES:
        raise ValueError(f"{name} has dtype {value.dtype}; allowed: torch.float64 or torch.float32")
    return value.detach().to("cpu", torch.float64).numpy()


def _condition(value: Any, checked: np.ndarray, like: torch.Tensor) -> torch.Tensor:
    """A flight condition as a (B,) tensor: a given tensor keeps its graph, else ``checked``."""
    if isinstance(value, torch.Tensor):
        value = value.to(like.dtype)
        return value.expand(like.shape[0]) if value.ndim == 0 else value
    return torch.as_tensor(checked, dtype=like.dtype, device=like.device)


# --- frames (blade.fill_frame_coefficients) ------------------------------------------------------
def _frame(angles: list[torch.Tensor], weight: torch.Tensor, beta: torch.Tensor, spin_total: bool):
    """The per-sample frame coefficients of the right wing (``blade.frame_columns`` of every
    sample at once), (N_COEF, B, n_time) in ``blade``'s column order."""
    columns = _on_tensors(blade.frame_columns)(
        torch.stack(angles, -1), ..., weight, torch.cos(beta)[:, None], torch.sin(beta)[:, None],
        spin_total, 1,
    )  # fmt: skip
    return torch.stack(torch.broadcast_tensors(*columns))


# --- the force sweep (induction.normal_force_sweep, _slope) and the span integrals --------------
#: :class:`Section`'s per-element fields (the node table's; the others are the wing's).
_ELEMENT_FIELDS = ("r", "chord", "width", "m11", "m22", "inertia_a", "damping")


def _on_tensors(kernel: Callable) -> Callable:
    """A compiled elementwise formula of the numba kernel on tensors (``xp.on_namespace``)."""
    return on_namespace(kernel, TORCH)


class _Wing:
    """One wing's frame, ``frame`` (N_COEF, B, 1, n_time) in ``blade``'s column order, and its
    blade elements: ``section``, the numba kernel's
    :class:`~tandem_env.physics.bundle.Section` with the node-table fields as (n_blade, 1)
    tensors (``cycle.section_at`` of every annulus at once)."""

    def __init__(
        self, frame: torch.Tensor, nodes: np.ndarray, consts: np.ndarray, rho: float, like, compiled
    ):
        self.compiled = compiled
        self.frame = frame[:, :, None, :]
        node = torch.tensor(nodes, dtype=like.dtype, device=like.device)[:, :, None]
        c = [float(v) for v in consts]
        self.section = cycle.section_at.py_func(node, slice(None), c, rho)
        self.i_span, self.i_pitch = c[cycle.K_I_SPAN], c[cycle.K_I_PITCH]
        self.n_time = frame.shape[-1]
        #: the other pair's (u, v) offsets (B, n_blade, 2, n_time) [m/s] under the vortex
        #: reading (``WingBatch.external``), or None
        self.external = None

    def sweep_and_slope(self, vt: torch.Tensor, vn: torch.Tensor):
        """F̄_n [N/m] and dF̄_n/dv_n [N·s/m²] at normal inflow ``vn`` with ``vt``, both shaped
        like the nodes ((B, n_blade, 1) or (n, 1)); results have the nodes' shape without the
        last axis (``induction.normal_force_sweep`` and ``normal_force_slope``)."""
        core = _compiled(_sweep_and_slope) if self.compiled else _sweep_and_slope
        return core(self.frame, self.section, vt, vn, self.external)

    def sweep_and_slope_at(self, rows: torch.Tensor, cols: torch.Tensor, vt, vn):
        """:meth:`sweep_and_slope` of the listed (stroke, annulus) pairs only (the inflow
        solve's active annuli), ``vt`` and ``vn`` (n, 1): results (n,)."""
        core = _compiled(_sweep_and_slope_at) if self.compiled else _sweep_and_slope_at
        return core(self.frame, self.section, vt, vn, rows, cols, self.external)


def _element_state(frame, section: Section, vt, vn, external=None):
    """The frame as the kernel's formulas index it (``coef[k, C_*]`` with k = ``...``), the
    relative velocity (u, v, u̇, v̇) [m/s, m/s²] of every element and sample
    (``blade.relative_velocity``, with the ``external`` (u, v) offsets (..., 2, n_time) of the
    vortex reading, ``induction.normal_force_sweep``) and the element force (F_c, F_n) [N/m]
    (``blade.element_force``, the paper's coefficients)."""
    coef = frame.movedim(0, -1)
    u, v, du, dv = _on_tensors(blade.relative_velocity)(coef, ..., section.r, vt, vn)
    if external is not None:
        u, v = u + external[..., 0, :], v + external[..., 1, :]
    fc, fn = _on_tensors(blade.element_force)(u, v, du, dv, frame[blade.C_SPIN], section)
    return coef, (u, v, du, dv), (fc, fn)


def _sweep_and_slope(frame, section: Section, vt, vn, external=None):
    """Cycle-mean normal force and its exact slope (``induction.normal_force_rate``) of a sweep."""
    _, (u, v, _, _), (fc, fn) = _element_state(frame, section, vt, vn, external)
    a, b = frame[blade.C_ECZ], frame[blade.C_ENZ]
    weight = frame[blade.C_WEIGHT]
    n_time = weight.shape[-1]
    mean = ((fc * a + fn * b) * weight).sum(-1) / n_time
    rate = _on_tensors(induction.normal_force_rate)(
        u, v, a, b, frame[blade.C_DECZ], frame[blade.C_DENZ], frame[blade.C_SPIN], section
    )
    return mean, (rate * weight).sum(-1) / n_time


def _sweep_and_slope_at(frame, section: Section, vt, vn, rows, cols, external=None):
    """:func:`_sweep_and_slope` of the (stroke ``rows``, annulus ``cols``) pairs: the gathers
    sit inside the function, so that a compiled version reads the frame in place."""
    section = section._replace(**{name: getattr(section, name)[cols] for name in _ELEMENT_FIELDS})
    external = None if external is None else external[rows, cols]
    return _sweep_and_slope(frame[:, rows, 0], section, vt, vn, external)


def _span_integrals(frame, section: Section, vt, vn, frequency, external=None):
    """Per sample, the span integrals of F_c, F_n [N], of the power delivered to the air P_aero
    [W] and of the chord-weighted acute angle of attack [m²·rad] at the solved inflow
    (``cycle.wing_cycle``'s final pass); ``frequency`` (B, 1, 1) [Hz]."""
    coef, (u, v, _, _), (fc, fn) = _element_state(frame, section, vt, vn, external)
    moment = _on_tensors(blade.element_moment)(
        u, v, frame[blade.C_SPIN], frame[blade.C_DSPIN], section, frequency
    )
    width = section.width
    power = _on_tensors(blade.element_power)(coef, ..., fc, fn, moment, section)
    return (
        (width * fc).sum(1),
        (width * fn).sum(1),
        (width * power).sum(1),
        (section.chord * width * _on_tensors(blade.acute_angle)(u, v)).sum(1),
    )


def _shed_load(frame, section: Section, vt, vn):
    """Per sample, the span integral of the circulatory and viscous element forces along the
    stroke-plane normal [N]: the force the wing sheds into its wake (``blade.shed_force``)."""
    coef, velocity, force = _element_state(frame, section, vt, vn)
    shed = _on_tensors(blade.shed_force)(coef, ..., *velocity, *force, section)
    return (section.width * shed).sum(1)


# --- the convected slipstream (cycle.disc_inflow, cycle.convected_wake) -------------------------
def _disc_inflow(inflow, wing: _Wing):
    """``cycle.disc_inflow``: the mean induced velocity over the swept disc (B,) [m/s]."""
    area = (wing.section.r * wing.section.width)[:, 0]
    return (inflow * area).sum(-1) / area.sum()


def _convected_wake(load, weight, phase_fore, phase_hind, delay, inflow_fore, fore: _Wing,
                    sweep_fore, vt, vn, interference):  # fmt: skip
    """``cycle.convected_wake``: C_hf·Δv at the hind-wing's samples (B, n_time) [m/s]."""
    n = load.shape[-1]
    k_disc = 4.0 * fore.section.rho * sweep_fore * (fore.section.r * fore.section.width).sum()
    mean = (load * weight).sum(-1, keepdim=True) / n
    rms = torch.sqrt(((load - mean) ** 2 * weight).sum(-1) / n)
    v_disc = _disc_inflow(inflow_fore, fore)
    w = vn + v_disc
    speed_squared = vt * vt + w * w
    flowing = speed_squared > 0.0
    # sqrt's slope is infinite at 0 (in hover, vt = 0 where w changes sign): the still samples
    # take no root, or their zero slope times it would make the whole gradient NaN
    speed = torch.sqrt(torch.where(flowing, speed_squared, 1.0))
    mass_flow = torch.where(flowing, speed + v_disc * w / speed, 0.0)
    mass_flow = torch.maximum(mass_flow, torch.sqrt(rms / k_disc))
    live = (k_disc > 0.0) & (mass_flow > 0.0)
    scale = torch.where(live, interference / torch.where(live, k_disc * mass_flow, 1.0), 0.0)
    n_modes = (n - 1) // 2
    m = torch.arange(1, n_modes + 1, dtype=load.dtype, device=load.device)
    cutoff = n_modes / weight.max(-1, keepdim=True).values
    sigma = torch.exp(-cycle.WAKE_FILTER * (m / cutoff) ** 16)
    f = (load - mean) * weight
    angle = phase_fore[:, :, None] * m
    a = (f[:, :, None] * torch.cos(angle)).sum(1) * (2.0 / n) * sigma * scale[:, None]
    b = (f[:, :, None] * torch.sin(angle)).sum(1) * (2.0 / n) * sigma * scale[:, None]
    angle = (phase_hind - delay[:, None])[:, :, None] * m
    return (a[:, None, :] * torch.cos(angle) + b[:, None, :] * torch.sin(angle)).sum(-1)


@cache
def _compiled(function: Callable) -> Callable:
    """``function`` compiled by ``torch.compile`` (shapes dynamic: the solve's active set
    changes size every step), once per process."""
    return torch.compile(function, dynamic=True)


# --- the inflow solve (induction.solve_annulus_samples), every annulus at once -----------------
#: The momentum side m(v), dm/dv and the force model minus it (``induction``), on tensors.
_momentum = _on_tensors(induction._momentum)
_model_residual = _on_tensors(induction._model_residual)


def _newton_in_bracket(coefs, k_area, vt, vn0, lo, hi):
    """``induction._solve_model`` on 1-D tensors (one entry per annulus): the root of the force
    model minus m(v) in [lo, hi] by safeguarded Newton, each entry stopping on its own."""
    v = 0.5 * (lo + hi)
    a, b = lo.clone(), hi.clone()
    result = v.clone()
    done = torch.zeros_like(v, dtype=torch.bool)
    for _ in range(60):
        q, dq = _model_residual(v, coefs, k_area, vt, vn0)
        positive = q > 0.0
        a = torch.where(positive, v, a)
        b = torch.where(positive, b, v)
        v_new = v - q / torch.where(dq != 0.0, dq, torch.ones_like(dq))
        ok = (dq != 0.0) & (a < v_new) & (v_new < b)
        v_new = torch.where(ok, v_new, 0.5 * (a + b))
        close = (v_new - v).abs() <= 1e-12 * (1.0 + v.abs())
        result = torch.where(~done & close, v_new, result)
        done = done | close
        v = torch.where(done, v, v_new)
        if bool(done.all()):
            break
    return torch.where(done, result, v)


def _gather(mask: torch.Tensor, tensors):
    """The entries of (B, n_blade)-broadcastable tensors where ``mask``, as 1-D tensors."""
    index = torch.nonzero(mask, as_tuple=True)
    return index, [t.expand(mask.shape)[index] for t in tensors]


def _solve_model(coefs, k_area, vt, vn0, lo, hi, mask):
    """:func:`_newton_in_bracket` on the annuli where ``mask`` (the others get the midpoint);
    no graph (see :func:`_attach_root`)."""
    out = 0.5 * (lo + hi)
    if not bool(mask.any()):
        return out
    index, (x0, c0, c1, c2, c3, k, t, n, a, b) = _gather(mask, [*coefs, k_area, vt, vn0, lo, hi])
    out = out.clone()
    out[index] = _newton_in_bracket((x0, c0, c1, c2, c3), k, t, n, a, b)
    return out


def _search_upwards(coefs, k_area, vt, vn0, lo, start, mask):
    """``induction._search_upwards`` where ``mask``: the root above ``lo``, bracketed by doubling
    from ``start``; −1 where the model has no sign change (and outside ``mask``)."""
    root = torch.full_like(lo, -1.0)
    bracketed = torch.zeros_like(mask)
    if not bool(mask.any()):
        return root, bracketed
    index, (x0, c0, c1, c2, c3, k, t, n, low, first) = _gather(
        mask, [*coefs, k_area, vt, vn0, lo, start]
    )
    coefs = (x0, c0, c1, c2, c3)
    pending = _model_residual(low, coefs, k, t, n)[0] > 0.0
    a = low.clone()
    b = torch.maximum(torch.maximum(first, 2.0 * low), torch.full_like(low, 1e-6))
    hit_any = torch.zeros_like(pending)
    for _ in range(64):
        if not bool(pending.any()):
            break
        hit = pending & (_model_residual(b, coefs, k, t, n)[0] <= 0.0)
        hit_any = hit_any | hit
        pending = pending & ~hit
        a = torch.where(pending, b, a)
        b = torch.where(pending, 2.0 * b, b)
    if bool(hit_any.any()):
        inner = torch.nonzero(hit_any, as_tuple=True)
        value = root[index]
        value[inner] = _newton_in_bracket(
            [c[inner] for c in coefs], k[inner], t[inner], n[inner], a[inner], b[inner]
        )
        root[index] = value
        flags = bracketed[index]
        flags[inner] = True
        bracketed[index] = flags
    return root, bracketed


def _attach_root(root, ok, coefs, k_area, vt, vn0):
    """``root`` (solved without a graph) with the implicit-function derivative of
    q(v*; θ) = 0 where ``ok``: v* − (q − q̂)/∂q/∂v, whose value is v* itself."""
    if not torch.is_grad_enabled():
        return root
    safe = torch.where(ok, root, coefs[0].detach())
    q, dq = _model_residual(safe, coefs, k_area, vt, vn0)
    dq = dq.detach()
    use = ok & (dq != 0.0)
    step = (q - q.detach()) / torch.where(use, dq, torch.ones_like(dq))
    return torch.where(use, root - step, root)


def _search(coefs, k_area, vt, vn0, lo, start, mask):
    with torch.no_grad():
        root, ok = _search_upwards(
            [c.detach() for c in coefs], k_area.detach(), vt.detach(), vn0.detach(),
            lo.detach(), start.detach(), mask,
        )  # fmt: skip
    return _attach_root(root, ok, coefs, k_area, vt, vn0)


def _solve_inflow(
    wing: _Wing, vt, vn0, sweep_amplitude, solve, tolerance, max_evaluations, wake=None
):
    """Induced velocity v_i (B, n_blade) [m/s], force sweeps (B, n_blade) and converged
    (B, n_blade) of every annulus (``induction.solve_annulus_samples``; ``solve`` (B,): the
    strokes whose wing solves its inflow at all; ``wake`` (B, n_time) or None: the part of the
    upstream inflow that varies over the cycle [m/s], in the sweeps only)."""
    vt_b = vt[:, None]
    k_area = (4.0 * wing.section.rho * sweep_amplitude[:, None] * wing.section.r[..., 0]).expand_as(
        vn0
    )
    vn_start = vn0[:, :, None] if wake is None else vn0[:, :, None] + wake[:, None, :]
    f0, s0 = wing.sweep_and_slope(vt[:, None, None], vn_start)
    trivial = (f0 <= 0.0) | (k_area <= 0.0) | ~solve[:, None]
    zeros = torch.zeros_like(f0)
    ones = torch.ones_like(f0)
    inf = torch.full_like(f0, math.inf)
    done = trivial.clone()
    converged = trivial.clone()
    evaluations = torch.ones_like(f0, dtype=torch.int64)
    v = zeros
    if bool(done.all()):
        return v, torch.where(solve[:, None], evaluations, 0), converged
    v_hover = _search([zeros, f0, zeros, zeros, zeros], k_area, vt_b, vn0, zeros, ones, ~done)
    f_tol = tolerance * f0.detach()
    x_tol = tolerance * torch.clamp(v_hover.detach(), min=1e-9)
    lo, f_lo, s_lo = zeros, f0, s0
    hi, f_hi, s_hi = inf, zeros, zeros
    curvature = zeros
    step_last, step_before = inf, inf.clone()
    iteration = 1
    while iteration < max_evaluations and not bool(done.all()):
        active = ~done
        open_ = torch.isinf(hi)
        # no bracket yet: the tangent bent by the curvature, searched upwards from lo
        v_a = _search(
            [lo, f_lo, s_lo, 0.5 * curvature, zeros], k_area, vt_b, vn0, lo, v_hover, active & open_
        )
        if iteration == 1:
            capped = torch.where(v_a > lo, torch.minimum(v_a, 4.0 * v_hover), 4.0 * v_hover)
            v_a = torch.where(s_lo > 0.0, capped, v_a)
        v_a = torch.where(v_a > lo, v_a, 2.0 * torch.maximum(lo, v_hover))
        # bracketed: the cubic Hermite model on [lo, hi], or bisection
        hi_s = torch.where(open_, lo + 1.0, hi)
        f_hi_s = torch.where(open_, f_lo, f_hi)
        s_hi_s = torch.where(open_, s_lo, s_hi)
        w = hi_s - lo
        secant = (f_hi_s - f_lo) / w
        c2 = (3.0 * secant - 2.0 * s_lo - s_hi_s) / w
        c3 = (s_lo + s_hi_s - 2.0 * secant) / (w * w)
        closed = active & ~open_
        with torch.no_grad():
            v_model = _solve_model(
                [lo.detach(), f_lo.detach(), s_lo.detach(), c2.detach(), c3.detach()],
                k_area, vt_b, vn0.detach(), lo.detach(), hi_s.detach(), closed,
            )  # fmt: skip
        v_model = _attach_root(v_model, closed, [lo, f_lo, s_lo, c2, c3], k_area, vt_b, vn0)
        accept = (lo < v_model) & (v_model < hi_s) & ((v_model - v).abs() <= 0.5 * step_before)
        v_b = torch.where(accept, v_model, 0.5 * (lo + hi_s))
        step_before = torch.where(closed, step_last, step_before)
        step_last = torch.where(closed, (v_b - v).detach().abs(), step_last)
        v = torch.where(active, torch.where(open_, v_a, v_b), v)
        # sweep only the annuli still solving (the others keep their values)
        rows, cols = torch.nonzero(active, as_tuple=True)
        vn_part = (vn0 + v)[rows, cols, None]
        if wake is not None:
            vn_part = vn_part + wake[rows]
        fv_part, sv_part = wing.sweep_and_slope_at(rows, cols, vt[rows, None], vn_part)
        fv = torch.zeros_like(f0).index_put((rows, cols), fv_part)
        evaluations = evaluations + active.to(torch.int64)
        hv = (fv - _momentum(v, k_area, vt_b, vn0)[0]).detach()
        gap = torch.where(hv > 0.0, hi - v.detach(), v.detach() - lo.detach())
        now = active & ((hv.abs() <= f_tol) | (gap <= x_tol))
        converged = converged | now
        done = done | now
        go_on = active & ~now
        iteration += 1
        if not bool(go_on.any()):
            break
        sv = torch.zeros_like(f0).index_put((rows, cols), sv_part)
        up = go_on & (hv > 0.0)
        down = go_on & ~(hv > 0.0)
        curvature = torch.where(up, (sv - s_lo) / torch.where(up, v - lo, ones), curvature)
        lo, f_lo, s_lo = (
            torch.where(up, new, old) for new, old in ((v, lo), (fv, f_lo), (sv, s_lo))
        )
        hi, f_hi, s_hi = (
            torch.where(down, new, old) for new, old in ((v, hi), (fv, f_hi), (sv, s_hi))
        )
    v = torch.where(trivial, 0.0, v)
    return v, torch.where(solve[:, None], evaluations, 0), converged


# --- cycle means (cycle.cycle_means, cycle.mean_positive_part) ---------------------------------
def _trig(coef_a0, coef_a, coef_b, x, harmonics):
    """The interpolant p(x), p'(x) and its antiderivative P(x) at points x (n,) of series whose
    coefficients are rows of coef_a, coef_b (n, M) (``cycle._trig_eval``)."""
    mx = harmonics * x[:, None]
    c, s = torch.cos(mx), torch.sin(mx)
    value = coef_a0 + (coef_a * c + coef_b * s).sum(-1)
    slope = (harmonics * (coef_b * c - coef_a * s)).sum(-1)
    integral = coef_a0 * x + ((coef_a * s - coef_b * c) / harmonics).sum(-1)
    return value, slope, integral


def _crossings(ca0, ca, cb, lo, width, f_lo, f_hi, harmonics):
    """The zero crossings (x (R,), the positions its Newton iterations evaluated) of series
    rows ca0, ca, cb in [lo, lo + width] from ``f_lo`` to ``f_hi`` (``cycle._crossing``), with
    no gradient: the mean's derivative does not depend on where the roots are (p = 0 there)."""
    hi = lo + width
    x = lo + width * f_lo / (f_lo - f_hi)
    x_eval = x.clone()
    live = torch.arange(x.numel(), device=x.device)  # the crossings still iterating
    for _ in range(6):
        xs = x[live]
        p, dp, _ = _trig(ca0[live], ca[live], cb[live], xs, harmonics)
        x_eval[live] = xs
        same = (p > 0.0) == (f_lo[live] > 0.0)
        lo_l = torch.where(same, xs, lo[live])
        hi_l = torch.where(same, hi[live], xs)
        lo[live], hi[live] = lo_l, hi_l
        mid = 0.5 * (lo_l + hi_l)
        x_new = torch.where(dp != 0.0, xs - p / torch.where(dp != 0.0, dp, 1.0), mid)
        x_new = torch.where((lo_l <= x_new) & (x_new <= hi_l), x_new, mid)
        close = (x_new - xs).abs() < 1e-11
        x[live] = torch.where(close, xs, x_new)
        live = live[~close]
        if live.numel() == 0:
            break
    return x_eval


def _turning_points(ca0, ca, cb, lo, hi, slope_lo, slope_hi, harmonics):
    """The zero of p' in each [lo, hi] where it goes from ``slope_lo`` to ``slope_hi``, by the
    Illinois steps of ``cycle.turning_point`` (each stops as it does there): (x, p(x)), no
    gradient."""
    x = lo.clone()
    kept = torch.zeros_like(lo)  # +1: lo was kept by the last step, −1: hi
    live = torch.ones_like(lo, dtype=torch.bool)
    for _ in range(cycle.TURNING_STEPS):
        x_new = (lo * slope_hi - hi * slope_lo) / (slope_hi - slope_lo)
        x_new = torch.where((lo < x_new) & (x_new < hi), x_new, 0.5 * (lo + hi))
        step = (x_new - x).abs()
        x = torch.where(live, x_new, x)
        slope = _trig(ca0, ca, cb, x, harmonics)[1]
        live = live & (slope != 0.0) & (step >= cycle.TURNING_SHORT)
        if not bool(live.any()):
            break
        new_lo = live & ((slope > 0.0) == (slope_lo > 0.0))
        new_hi = live & ~new_lo
        slope_hi = torch.where(new_lo & (kept == -1.0), 0.5 * slope_hi, slope_hi)
        slope_lo = torch.where(new_hi & (kept == 1.0), 0.5 * slope_lo, slope_lo)
        lo, slope_lo = torch.where(new_lo, x, lo), torch.where(new_lo, slope, slope_lo)
        hi, slope_hi = torch.where(new_hi, x, hi), torch.where(new_hi, slope, slope_hi)
        kept = torch.where(new_lo, -1.0, torch.where(new_hi, 1.0, kept))
    return x, _trig(ca0, ca, cb, x, harmonics)[0]


def mean_positive_part(g: torch.Tensor) -> torch.Tensor:
    """Cycle means of max(g, 0) of (G, n) periodic series on s_k = 2πk/n, to spectral accuracy
    (``cycle.positive_part_of_series``: the trigonometric interpolant integrated exactly between
    its zero crossings, found interval by interval, split at a turning point where p' changes
    sign, each located by safeguarded Newton from the linear guess)."""
    n_series, n = g.shape
    cos_t, sin_t = (
        torch.tensor(t, dtype=g.dtype, device=g.device) for t in cycle.fourier_tables(n)
    )
    harmonics = torch.arange(1, cos_t.shape[1] + 1, dtype=g.dtype, device=g.device)
    a0 = g.sum(-1) / n
    a = 2.0 * (g @ cos_t) / n
    b = 2.0 * (g @ sin_t) / n
    h = _TWO_PI / n
    out = torch.where(g[:, 0] > 0.0, torch.clamp(a0, min=0.0), torch.zeros_like(a0))
    with torch.no_grad():
        gd, a0d, ad, bd = g.detach(), a0.detach(), a.detach(), b.detach()
        slopes = (bd * harmonics) @ cos_t.T - (ad * harmonics) @ sin_t.T  # p'(s_k), (G, n)
        turning = (slopes > 0.0) != (torch.roll(slopes, -1, dims=1) > 0.0)
        g_next = torch.roll(gd, -1, dims=1)
        # pieces (series, lo, width, value at lo, value at hi): whole intervals where p' keeps
        # its sign, the two halves of the others split at their turning point
        series_w, k_w = torch.nonzero(~turning & ((gd > 0.0) != (g_next > 0.0)), as_tuple=True)
        series_t, k_t = torch.nonzero(turning, as_tuple=True)
        lo_t = k_t.to(g.dtype) * h
        x_t, p_t = _turning_points(
            a0d[series_t], ad[series_t], bd[series_t], lo_t, lo_t + h,
            slopes[series_t, k_t], torch.roll(slopes, -1, dims=1)[series_t, k_t], harmonics,
        )  # fmt: skip
        g0_t, g1_t = gd[series_t, k_t], g_next[series_t, k_t]
        first = (g0_t > 0.0) != (p_t > 0.0)
        second = (p_t > 0.0) != (g1_t > 0.0)
        lo_w = k_w.to(g.dtype) * h
        pieces = (
            (series_w, lo_w, torch.full_like(lo_w, h), gd[series_w, k_w], g_next[series_w, k_w]),
            (series_t[first], lo_t[first], (x_t - lo_t)[first], g0_t[first], p_t[first]),
            (series_t[second], x_t[second], (lo_t + h - x_t)[second], p_t[second], g1_t[second]),
        )
        series = torch.cat([piece[0] for piece in pieces])
        if series.numel() == 0:
            return out
        lo, width, f_lo, f_hi = (torch.cat([piece[i] for piece in pieces]) for i in range(1, 5))
        x = _crossings(a0d[series], ad[series], bd[series], lo, width, f_lo, f_hi, harmonics)
        # by series, then position: each positive arc runs to the next crossing of its series
        order = torch.argsort(series.to(g.dtype) * 2.0 * _TWO_PI + x)
        series, x, rising = series[order], x[order], (f_hi > 0.0)[order]
    big_p = _trig(a0[series], a[series], b[series], x, harmonics)[2]
    count = torch.bincount(series, minlength=n_series)
    first_of = torch.cumsum(count, 0) - count
    index = torch.arange(series.numel(), device=g.device)
    last = index == first_of[series] + count[series] - 1
    following = torch.where(last, first_of[series], index + 1)
    wrap = torch.where(last, _TWO_PI * a0[series], torch.zeros_like(big_p))
    arcs = torch.where(rising, big_p[following] + wrap - big_p, torch.zeros_like(big_p))
    total = torch.zeros_like(a0).index_add(0, series, arcs)
    return torch.where(count > 0, torch.clamp(total, min=0.0) / _TWO_PI, out)


def _wing_cycle(wing: _Wing, frequency, sweep_amplitude, vt, vn0, solve, options, wake=None):
    """Per-wing cycle means (a dict of (B,) tensors keyed like ``cycle``'s W_ columns, ``FZ``
    for ``W_FZ``, …) and the inflow per annulus (B, n_blade) (``cycle.wing_cycle``; ``wake``
    (B, n_time) or None: the part of the upstream inflow that varies over the cycle [m/s])."""
    if options.induction == "none":
        v_i = torch.zeros_like(vn0)
        evaluations = torch.zeros_like(vn0, dtype=torch.int64)
        converged = torch.ones_like(vn0, dtype=torch.bool)
    else:
        v_i, evaluations, converged = _solve_inflow(
            wing, vt, vn0, sweep_amplitude, solve, options.tolerance, options.max_evaluations,
            wake,
        )  # fmt: skip
    core = _compiled(_span_integrals) if wing.compiled else _span_integrals
    vn_final = (vn0 + v_i)[:, :, None]
    if wake is not None:
        vn_final = vn_final + wake[:, None, :]
    span_fc, span_fn, span_power, span_aoa = core(
        wing.frame, wing.section, vt[:, None, None], vn_final, frequency[:, None, None],
        wing.external,
    )  # fmt: skip
    chord, width = wing.section.chord, wing.section.width
    coef = wing.frame[:, :, 0].movedim(0, -1)
    n_time = wing.n_time
    fx, fz, _ = _on_tensors(blade.earth_forces)(coef, ..., span_fc, span_fn)
    p_iner = _on_tensors(blade.inertial_power)(coef, ..., wing.i_span, wing.i_pitch)
    weight = coef[..., blade.C_WEIGHT]
    out = {"FX": (fx * weight).sum(-1) / n_time, "FZ": (fz * weight).sum(-1) / n_time}
    mean_aero = (span_power * weight).sum(-1) / n_time
    mean_iner = (p_iner * weight).sum(-1) / n_time
    series = torch.stack([fx, span_power, p_iner, span_power + p_iner]) * weight
    thrust, aero_positive, iner_positive, elastic = mean_positive_part(
        series.reshape(-1, n_time)
    ).reshape(4, -1)
    out["THRUST"] = thrust
    out["DRAG"] = torch.clamp(thrust - out["FX"], min=0.0)
    out["P_AERO_POSITIVE"] = aero_positive
    out["P_AERO"] = torch.clamp(2.0 * aero_positive - mean_aero, min=0.0)
    out["P_INER"] = torch.clamp(2.0 * iner_positive - mean_iner, min=0.0)
    out["P_ELASTIC"] = elastic
    area = (chord * width).sum()
    out["AOA"] = (span_aoa * weight).sum(-1) / (area * n_time)
    out["CONVERGED"] = converged.all(-1)
    out["EVALS"] = evaluations.max(-1).values
    out["INFLOW"] = (chord[..., 0] * width[..., 0] * v_i).sum(-1) / area
    return out, v_i


def _vortex_chunk(strokes, speed, gamma, available_power, insect, options, compiled):
    """:func:`_evaluate_chunk` under the vortex reading (docs/model.md §5.8;
    ``interaction.vortex_reading``, as ``model.run_kernel`` runs it on the numba kernel)."""
    pairs, wings = [], []
    for index, geometry in enumerate((insect.fore, insect.hind)):
        params = wing_params_radians(
            strokes[:, index * N_PER_WING : (index + 1) * N_PER_WING], TORCH
        )
        angles, weight, phase = batched_angle_history(params, options.n_time, TORCH)
        frame = _frame(angles, weight, params[:, 13], options.spin == "total")
        nodes, consts = wing_tables(geometry, options.n_blade, insect.air_density)
        wing = _Wing(frame, nodes, consts, insect.air_density, strokes, compiled)
        vt, vn = stroke_plane_speeds(speed, params[:, 13], gamma, TORCH)
        root = np.array([-insect.root_spacing, 0.0, -insect.root_drop]) * index
        root[1] = interaction.ROOT_HALF_WIDTH
        pairs.append(
            interaction.Pair(
                params=params,
                samples=None,
                frequency=params[:, 0],
                beta=params[:, 13],
                coef=wing.frame[:, :, 0].movedim(0, -1)[:, None],
                phase=phase,
                v_tangential=vt,
                v_normal=vn,
                wing=geometry,
                r=np.array(nodes[:, cycle.N_R]),
                width=np.array(nodes[:, cycle.N_WIDTH]),
                root=root,
                grid_coef=interaction.grid_frames(
                    params, options.spin == "total", interaction.WAKE, TORCH
                ),
            )
        )
        wings.append((wing, params, vt, vn, inflow_switched_off(vn, options, TORCH)))
    scale = options.interference * (~(wings[0][4] | wings[1][4])).to(strokes.dtype)

    result: list[Any] = [None, None]  # each wing's outputs of the whole batch

    def run(w, field, rows):
        wing, params, vt, vn, off = wings[w]
        if rows is not None:  # a pass on some of the strokes: their rows of everything
            wing = copy.copy(wing)
            wing.frame = wing.frame[:, rows]
            params, vt, vn, off = params[rows], vt[rows], vn[rows], off[rows]
        vn0 = vn[:, None].expand(-1, wing.section.r.shape[0])
        wing.external = None if field is None else field[0]
        if field is not None:
            vn0 = vn0 + field[1]
        out, inflow = _wing_cycle(wing, params[:, 0], params[:, 1], vt, vn0, ~off, options)
        if rows is None:
            result[w] = out
        else:
            result[w] = {key: result[w][key].index_copy(0, rows, out[key]) for key in result[w]}
        return inflow, result

    outs, converged = interaction.vortex_reading(
        *pairs, run, speed, gamma, scale, TORCH, interaction.WAKE
    )
    for out in outs:
        out["CONVERGED"] = out["CONVERGED"] & converged

    def means(key: str) -> torch.Tensor:
        return torch.stack([outs[0][key], outs[1][key]], dim=1)

    return flight_performance(means, speed, gamma, available_power, insect, options, TORCH)


def _evaluate_chunk(strokes, speed, gamma, available_power, insect, options, compiled):
    if options.slipstream == "vortex" and options.phase_resolved():
        return _vortex_chunk(strokes, speed, gamma, available_power, insect, options, compiled)
    wings = []
    inflow_fore = None
    fore = {}
    for index, geometry in enumerate((insect.fore, insect.hind)):
        params = wing_params_radians(
            strokes[:, index * N_PER_WING : (index + 1) * N_PER_WING], TORCH
        )
        frequency, sweep_amplitude, beta = params[:, 0], params[:, 1], params[:, 13]
        angles, weight, phase = batched_angle_history(params, options.n_time, TORCH)
        frame = _frame(angles, weight, beta, options.spin == "total")
        nodes, consts = wing_tables(geometry, options.n_blade, insect.air_density)
        wing = _Wing(frame, nodes, consts, insect.air_density, strokes, compiled)
        vt, vn = stroke_plane_speeds(speed, beta, gamma, TORCH)
        off = inflow_switched_off(vn, options, TORCH)
        vn0 = vn[:, None].expand(-1, nodes.shape[0])
        coupled = options.induction == "coupled"
        convected = coupled and options.slipstream == "convected"
        wake = None
        if index == 1 and coupled:
            vn0 = vn0 + torch.where(off[:, None], 0.0, options.interference * inflow_fore)
        if index == 1 and convected:
            # the convected slipstream (docs/model.md §5.7; cycle.tandem_stroke)
            delay = _on_tensors(cycle.slipstream_delay)(
                _disc_inflow(inflow_fore, fore["wing"]), vn, fore["beta"], beta, insect
            )
            wake = _convected_wake(
                fore["load"], fore["weight"], fore["phase"], phase,
                2.0 * math.pi * frequency * delay, inflow_fore, fore["wing"],
                fore["sweep"], fore["vt"], fore["vn"], options.interference,
            )  # fmt: skip
            wake = torch.where((off | fore["off"])[:, None], 0.0, wake)
        out, inflow = _wing_cycle(wing, frequency, sweep_amplitude, vt, vn0, ~off, options, wake)
        if index == 0 and convected:
            load = _shed_load(
                wing.frame, wing.section, vt[:, None, None], (vn0 + inflow)[:, :, None]
            )
            fore = {
                "wing": wing, "load": load, "weight": weight, "phase": phase, "beta": beta,
                "sweep": sweep_amplitude, "vt": vt, "vn": vn, "off": off,
            }  # fmt: skip
        inflow_fore = inflow
        wings.append(out)
    fore, hind = wings

    def means(key: str) -> torch.Tensor:
        return torch.stack([fore[key], hind[key]], dim=1)

    return flight_performance(means, speed, gamma, available_power, insect, options, TORCH)


def evaluate_torch(
    strokes: torch.Tensor,
    speed: float | torch.Tensor = 0.0,
    available_power: float | torch.Tensor | None = None,
    *,
    flight_path_angle: float | torch.Tensor = 0.0,
    insect: Dragonfly = DRAGONFLY,
    options: ModelOptions = DEFAULT_OPTIONS,
    chunk_size: int | None = None,
    compiled: bool = False,
) -> Any:
    """Evaluate one wing-beat cycle of each stroke of a batch, in torch (see the module docstring).

    Parameters
    ----------
    strokes : (B, 28) or (28,) tensor, float64 (default precision) or float32
        Physical strokes in Table 4 units (Hz, deg, -), fore-wing first, on the CPU or a CUDA
        device; the computation runs in their dtype on their device.
    speed, available_power, flight_path_angle
        As for :func:`tandem_env.evaluate` [m/s, W/kg, rad]: numbers, arrays, or tensors on the
        strokes' device (0-d or (B,)); tensors keep their graph, so results are differentiable
        with respect to them.
    insect, options
        As for :func:`tandem_env.evaluate`; the insect's wings must use the paper's force
        coefficients (``PaperCoefficients``).
    chunk_size : int, optional
        Strokes evaluated at once (memory ∝ chunk_size·n_blade·n_time); default
        :data:`CHUNK_SIZE` of the device type.
    compiled : bool
        Fuse the force sweeps and span integrals with ``torch.compile`` (the same operations;
        the first call in a process compiles them, which takes minutes; docs/model.md §12.1).

    Returns
    -------
    TorchResult
        ``Result``'s fields as (B,) tensors on the strokes' device (bool and int64 where
        ``Result`` has them); ``.to_numpy()`` gives the ``Result``.
    """
    check_model_inputs(insect, options)
    for name, wing in (("fore", insect.fore), ("hind", insect.hind)):
        if not isinstance(wing.coefficients, PaperCoefficients):
            raise ValueError(
                f"insect.{name}.coefficients = {wing.coefficients.name!r}; allowed with "
                "backend 'torch': the paper's (PaperCoefficients); use the numba backend for "
                "other force-coefficient models"
            )
    strokes = _check_strokes(strokes, insect.stroke_bounds)
    batch = strokes.shape[0]
    given = (speed, available_power, flight_path_angle)
    names = ("speed", "available_power", "flight_path_angle")
    checked = validate_conditions(
        *(_as_checkable(value, name, strokes) for value, name in zip(given, names, strict=True)),
        batch,
        insect,
    )
    v, p_avail, gamma = (
        _condition(value, arr, strokes) for value, arr in zip(given, checked, strict=True)
    )
    compiled = flag(compiled, "compiled")
    if chunk_size is None:
        chunk_size = CHUNK_SIZE[strokes.device.type]
    chunk_size = count(chunk_size, "chunk_size", what="strokes evaluated at once")
    parts = []
    for i in range(0, batch, chunk_size):
        part = slice(i, i + chunk_size)
        parts.append(
            _evaluate_chunk(
                strokes[part], v[part], gamma[part], p_avail[part], insect, options, compiled
            )
        )
    values = {key: torch.cat([part[key] for part in parts]) for key in parts[0]}
    missing = [name for name in RESULT_FIELDS if name not in values]
    if missing:
        raise RuntimeError(f"the torch backend does not compute Result fields {missing}")
    if insect.min_wing_gap is not None:  # the search on numpy, the distance there on torch
        values |= zip(OPTIONAL_FIELDS, clearance.gaps(strokes, insect, TORCH), strict=True)
    return TorchResult(
        **{name: values[name] for name in (*RESULT_FIELDS, *OPTIONAL_FIELDS) if name in values},
        options=options,
        planform=insect.planform,
    )


def to_numpy_result(result: Any) -> Result:
    """The numpy :class:`Result` of a :class:`TorchResult` (detached, on the CPU)."""
    arrays = {
        name: getattr(result, name).detach().cpu().numpy()
        for name in (*RESULT_FIELDS, *OPTIONAL_FIELDS)
        if getattr(result, name) is not None
    }
    return Result(**arrays, options=result.options, planform=result.planform)


def evaluate_numpy(
    strokes: np.ndarray,
    speed: Any = 0.0,
    available_power: Any = None,
    *,
    flight_path_angle: Any = 0.0,
    insect: Dragonfly = DRAGONFLY,
    options: ModelOptions = DEFAULT_OPTIONS,
    device: Any = None,
) -> Result:
    """:func:`tandem_env.evaluate`'s ``backend="torch"``: numpy in, numpy ``Result`` out, float64
    on ``device`` (None: the CPU), without a graph."""
    dev = resolve_device(device)
    physical = validate_physical(strokes)
    with torch.no_grad():
        result = evaluate_torch(
            torch.as_tensor(physical, dtype=torch.float64, device=dev),
            speed,
            available_power,
            flight_path_angle=flight_path_angle,
            insect=insect,
            options=options,
        )
    return to_numpy_result(result)


def value_and_grad(
    strokes: torch.Tensor,
    metric: str | Callable[[Any], torch.Tensor],
    speed: float | torch.Tensor = 0.0,
    available_power: float | torch.Tensor | None = None,
    **kwargs: Any,
) -> tuple[torch.Tensor, torch.Tensor]:
    """A metric of every stroke of a batch and its gradient with respect to the strokes.

    ``metric``: a ``Result`` field name (e.g. ``"power_per_mass"``) or a function of the
    :class:`TorchResult` returning (B,) values. Returns ((B,) values, (B, 28) d(metric)/d(stroke)
    in the strokes' units, per Hz, per degree, …), from one backward pass: each stroke's metric
    depends on its own stroke only, so the gradient of the batch sum is every stroke's gradient.
    The column of each discrete N (``elevation_harmonic``, N ∈ {1, 2}) is 0: N takes no
    step of a derivative's size. ``kwargs`` go to :func:`evaluate_torch`.
    """
    if isinstance(metric, str):
        if metric not in RESULT_FIELDS:
            raise ValueError(
                f"metric = {metric!r} is not a Result field; allowed: one of "
                f"{', '.join(RESULT_FIELDS)}, or a function of the TorchResult"
            )
    elif not callable(metric):
        raise ValueError(
            f"metric = {metric!r}; allowed: a Result field name or a function of the TorchResult"
        )
    bounds = kwargs.get("insect", DRAGONFLY).stroke_bounds
    x = _check_strokes(strokes, bounds).detach().clone().reshape(strokes.shape).requires_grad_(True)
    with torch.enable_grad():
        result = evaluate_torch(x, speed, available_power, **kwargs)
        values = getattr(result, metric) if isinstance(metric, str) else metric(result)
        _check_metric_values(values, f"metric {metric!r}", result.efficiency.shape[0])
        (gradient,) = torch.autograd.grad(values.sum(), x)
    # the model's formula in N has a slope, but N is discrete: not a direction to move in
    gradient[..., torch.as_tensor(DISCRETE, device=gradient.device)] = 0.0
    return values.detach(), gradient


def _check_metric_values(values: Any, name: str, batch: int) -> None:
    """ValueError unless ``values`` is a (batch,) floating tensor that depends on the strokes
    (a bool or integer field such as ``induction_converged`` has no derivative)."""
    if not isinstance(values, torch.Tensor) or values.shape != (batch,):
        shape = tuple(values.shape) if isinstance(values, torch.Tensor) else type(values).__name__
        raise ValueError(
            f"{name} gives {shape}; allowed: a ({batch},) tensor, one value per stroke"
        )
    if not values.is_floating_point() or not values.requires_grad:
        raise ValueError(
            f"{name} gives {values.dtype} values that do not depend on the strokes; allowed: a "
            "floating-point metric computed from the result (not a flag or a count)"
        )


def normalised_jacobian(
    actions: np.ndarray,
    metrics: Sequence[Callable[[Any], torch.Tensor]],
    speed: Any = 0.0,
    available_power: Any = None,
    *,
    device: Any = None,
    **kwargs: Any,
) -> tuple[Result, np.ndarray, np.ndarray]:
    """Metrics of normalised strokes and their Jacobian w.r.t. the normalised coordinates, from
    ONE :func:`evaluate_torch` call (float64, on ``device``; None: the CPU).

    ``actions``: (B, 28) normalised strokes in [-1, 1] (:func:`stroke.map_normalised` onto the
    insect's stroke bounds, the map of :func:`stroke.normalised_to_physical`, here on tensors so autograd goes through it: linear
    per coordinate, N a step, so its column is 0). ``metrics``: functions of the
    :class:`TorchResult` returning (B,) tensors (array-agnostic arithmetic on its fields).
    Returns the numpy :class:`Result`, the (B, m) metric values and their (B, m, 28) Jacobian,
    one backward pass per metric through the one forward graph (each stroke's metrics depend on
    its own stroke only, so the gradient of a batch sum is every stroke's gradient).
    ``kwargs`` go to :func:`evaluate_torch`.
    """
    if (
        isinstance(metrics, str)
        or not isinstance(metrics, Sequence)
        or not metrics
        or not all(callable(metric) for metric in metrics)
    ):
        raise ValueError(
            f"metrics = {metrics!r}; allowed: a non-empty sequence of functions of the "
            "TorchResult, each returning (B,) values"
        )
    bounds = kwargs.get("insect", DRAGONFLY).stroke_bounds
    normalised_to_physical(actions, bounds)  # the numpy checks (shape, finite, inside [-1, 1])
    dev = resolve_device(device)
    a = torch.as_tensor(np.atleast_2d(np.asarray(actions, dtype=np.float64)), device=dev)
    a = a.clamp(-1.0, 1.0).requires_grad_(True)
    with torch.enable_grad():
        result = evaluate_torch(map_normalised(a, TORCH, bounds), speed, available_power, **kwargs)
        values = [metric(result) for metric in metrics]
        for k, value in enumerate(values):
            _check_metric_values(value, f"metrics[{k}]", a.shape[0])
        rows = [
            torch.autograd.grad(value.sum(), a, retain_graph=i + 1 < len(values))[0]
            for i, value in enumerate(values)
        ]
    jacobian = torch.stack(rows, dim=1).detach().cpu().numpy()
    jacobian[:, :, DISCRETE] = 0.0  # N is a step of a: 0 already, stated here
    stacked = torch.stack([value.detach() for value in values], dim=1).cpu().numpy()
    return to_numpy_result(result), stacked, jacobian
