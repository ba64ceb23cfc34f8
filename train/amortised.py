"""An amortised stroke policy: one network from the flight condition to a stroke.

Instead of an optimiser run per condition (seconds to a minute of CMA-ES and polish per
seed, several seeds and continuation rounds for one certified optimum, docs/reference.md),
one small network maps the condition to a stroke in one forward pass (amortised
optimisation; Amos 2023, "Tutorial on amortized optimization", Found. Trends Mach. Learn.
16(5)). ``python -m train --algo amortised --env ID`` trains one (docs/training.md,
"Amortised policy"); ``policy:RUN_DIR`` and ``python -m train.envelope`` use it like a trained
RL policy; ``python -m train.amortised_eval`` judges it at the held-out conditions.

**The map.** Input: the env's observation, the condition c [the condition's unit: m/s for level
flight, W/kg for accelerating flight] normalised from the env's envelope to [-1, 1] (float32,
as the env observes it). Output: a normalised stroke (28,) in [-1, 1], the env's action:

* the 26 continuous coordinates from an MLP: the observation's :attr:`Settings.features`
  Gaussian radial features (:class:`RadialFeatures`: a gradient step at one condition then
  moves mostly the strokes near it), tanh hidden layers (:attr:`Settings.hidden`) and a tanh
  output u ∈ (-1, 1)^26. A coordinate that is not a phase is u itself. A phase (each
  wing's sweep, elevation and pitch phase, Table 4: -180° to 180° on both wings, so ±1 is one
  angle) is ``wrap(centre + u)`` [normalised: 1 = 180°], ``wrap`` onto [-1, 1), with a fixed
  ``centre`` per phase (the circular mean of the training targets' phase; the canonical value
  for a canonicalised one): the output then moves continuously around the circle, and the
  optima's phases near ±180° do not sit on the output's edge.
* the two discrete coordinates (indices 11 and 25, each wing's elevation harmonic N ∈ {1, 2},
  -0.5 for 1 and +0.5 for 2) are not learned: they are those of the optimum at the training
  condition nearest to c (the lower one on a tie). N is a step of the action (its gradient is
  0), so neither regression nor fine-tuning could move it; between two training conditions
  whose optima differ in N the switch sits at the midpoint.

**Canonical targets** (:func:`canonicalise`). The model has a symmetry the targets need not
carry: every angle of a wing is a function of τ + Φ (its elevation of N·τ + Φ_θ) over one cycle
of its own (docs/model.md §3.2, §3.6), so delaying a wing's motion by Δ (its sweep and pitch
phases by Δ, its elevation phase by N·Δ, wrapped) changes nothing but where the cycle starts.
A common delay of both pairs changes nothing in any model reading; under the mean slipstream
(the default, ``ModelOptions.phase_resolved()`` False) the pairs meet only through cycle means,
so each pair may be delayed on its own (docs/model.md §5.7). The targets are delayed so that
the fore-wing's sweep phase, and where the pairs are independent the hind-wing's too, sits at
:data:`CANONICAL_SWEEP_PHASE` (0°): optima found with arbitrary phase offsets become one smooth
family over the conditions. The delay is a whole number of time-grid steps (360°/n_time: 2.8125°
at the default n_time = 128), so the canonical sweep phase lies within half a step of 0°: the
motion-following time grid (docs/model.md §3.5) is sampled at fixed s_k = 2πk/n_time and
follows the sweep phase, so a delay by whole steps samples the same points of the same motion
and the objective is unchanged to rounding (measured: 1e-14 relative; ``tests/train/
test_amortised.py`` holds it to 1e-9), while an arbitrary delay moves it by the grid's
discretisation error (measured: about 5e-6 relative at n_time = 128).

**Training** (:func:`train_policy`), deterministic for a seed (torch and numpy seeded, one torch
thread, float64):

(a) regression: the MLP's outputs before the output tanh (z, u = tanh z) are fitted (mean
    squared error on z, full batch, Adam, :attr:`Settings.regression_steps` steps) to atanh
    of the canonical optima of the reference table (``tandem_env.envs.reference``) at the
    grid's TRAINING conditions only (``training_conditions(env_id)``: every other grid point,
    the envelope's ends among them); targets at a bound are held :data:`TARGET_LIMIT` inside
    it (tanh reaches ±1 only at infinity), and fitting z keeps their gradient from
    vanishing in the saturated tanh;
(b) fine-tuning by the objective's gradient: :attr:`Settings.finetune_steps` Adam steps, each on
    :attr:`Settings.batch` conditions drawn uniformly over the training conditions' range,
    maximising the mean of ``J / ref(c)`` with ``J = objective − w · Σ_i max(0, δ − margin_i)``
    [objective units], the env's exact (L1) penalty of its reward (``w`` =
    :attr:`Settings.penalty_weight`, the env's default 10) held :attr:`Settings.safety_margin`
    δ inside every constraint's signed margin (``Constraint.margin``, [-], >= 0 where it holds)
    so that the strokes of a held-out condition, between the fitted ones, stay feasible;
    ``ref(c)`` [objective units] is the table's optimum interpolated over the training
    conditions only (so every condition weighs alike). The gradient w.r.t. the stroke is the
    env's problem view's autograd gradient (``FlightProblem.differentiate``, the torch model,
    ONE model evaluation per batch), carried through the network by the chain rule. A
    regression term on the training targets (weight :attr:`Settings.anchor`) keeps the
    network near the certified optima while it climbs. The learning rate decays to 0 over the
    steps (cosine); the conditions of a step are stratified (one draw in each of ``batch``
    equal parts of the range).

The default training (5 000 regression steps, 600 fine-tuning steps of 16 conditions at the
default resolution) takes about 3 minutes on the 2-core machine; the measured held-out results
are in docs/training.md, "Amortised policy".

**A run folder** (zoo-style, :class:`~train.layout.RunLayout`, ``logs/amortised/<env>_<n>/``)::

    <env>.pt                 the network's weights: a torch state_dict (torch.load(weights_only=True))
    policy.json              what the forward pass needs besides: sizes, phase centres, the
                             envelope, the harmonic per training condition, the series' identity
    result.json              training summary: losses, timings, strokes evaluated, provenance
    <env>/args.yml           the command's arguments (made_by: python -m train)
    <env>/config.yml         the training settings (:class:`Settings`)

every file written atomically (``tandem_env.io.files``) and read with safe loaders (JSON,
``yaml.safe_load`` through :func:`train.layout.read_run_yaml`, weights only).

Refused before any computation, with the value and what is allowed: an env without a
reference table, a series the table does not hold (objective, planform), env options that
change the problem the table describes (model options, insect, tolerances; those that do not
are the penalty, backend and device), a condition keyword (the condition is the policy's
input), unknown or out-of-range settings.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from tandem_env.io.files import (
    atomic_path,
    read_json,
    to_jsonable,
    write_json_atomic,
    write_text_atomic,
)
from tandem_env.physics.checks import is_integer, is_real
from tandem_env.physics.stroke import (
    DISCRETE,
    HARMONIC_INDEX,
    N_PARAMETERS,
    N_PER_WING,
    normalised_to_physical,
    physical_to_normalised,
)
from train.layout import MADE_BY, RunLayout, env_name, read_run_yaml, resolve_run_dir

__all__ = [
    "ALGO",
    "CANONICAL_SWEEP_PHASE",
    "TARGET_LIMIT",
    "AmortisedPolicy",
    "Settings",
    "Targets",
    "canonicalise",
    "check_env_kwargs",
    "is_amortised_run",
    "load_policy",
    "reference_targets",
    "save_run",
    "train_policy",
    "train_run",
]

#: The ``--algo`` of an amortised run (its run folders: ``logs/amortised/<env>_<n>/``).
ALGO = "amortised"
#: Where the canonical targets put each canonicalised sweep phase [deg] (within half a time-grid
#: step, :func:`canonicalise`).
CANONICAL_SWEEP_PHASE = 0.0
#: The most a regression target lies from 0 in a normalised coordinate [-]: targets at a bound
#: are held this far inside (0.005 % of the parameter's range), where tanh can reach them.
TARGET_LIMIT = 0.9999
#: Format of ``policy.json``.
POLICY_FORMAT = "tandem_env.amortised-policy/1"
#: The file of the weights in the run folder: ``<env>.pt``.
WEIGHTS_SUFFIX = ".pt"
POLICY_FILE = "policy.json"

#: Per wing, indices of the sweep, elevation and pitch phases and of N within its 14.
_SWEEP, _ELEVATION, _PITCH = 7, 8, 9
#: The 26 continuous coordinates the network outputs, in action order.
CONTINUOUS: tuple[int, ...] = tuple(j for j in range(N_PARAMETERS) if not DISCRETE[j])
#: The six phase coordinates of the action.
PHASES: tuple[int, ...] = tuple(
    w + k for w in (0, N_PER_WING) for k in (_SWEEP, _ELEVATION, _PITCH)
)
HARMONICS: tuple[int, ...] = (HARMONIC_INDEX, N_PER_WING + HARMONIC_INDEX)
CITATION = (
    "amortised optimisation (Amos 2023, 'Tutorial on amortized optimization', Found. Trends "
    "Mach. Learn. 16(5)): an MLP regressed on the reference optima at the training conditions "
    "and fine-tuned by the autograd gradient of the penalised objective"
)


# --- canonical strokes -------------------------------------------------------------------------
def _wrap_degrees(angle: np.ndarray) -> np.ndarray:
    return (np.asarray(angle, dtype=np.float64) + 180.0) % 360.0 - 180.0


def delay(physical: np.ndarray, fore: Any, hind: Any) -> np.ndarray:
    """Physical strokes (B, 28) [Table 4 units] with each pair's motion delayed by ``fore`` and
    ``hind`` [deg of its own cycle, scalars or (B,)]: its sweep and pitch phases less Δ, its
    elevation phase less N·Δ, wrapped onto [-180°, 180°)."""
    out = np.array(physical, dtype=np.float64, copy=True)
    for base, shift in ((0, fore), (N_PER_WING, hind)):
        d = np.broadcast_to(np.asarray(shift, dtype=np.float64), out.shape[:1])
        out[:, base + _SWEEP] = _wrap_degrees(out[:, base + _SWEEP] - d)
        out[:, base + _PITCH] = _wrap_degrees(out[:, base + _PITCH] - d)
        harmonic = out[:, base + HARMONIC_INDEX]
        out[:, base + _ELEVATION] = _wrap_degrees(out[:, base + _ELEVATION] - harmonic * d)
    return out


def canonicalise(physical: np.ndarray, n_time: int, *, pairs_independent: bool) -> np.ndarray:
    """The strokes (B, 28) [Table 4 units] delayed by whole time-grid steps (360°/``n_time``)
    so that the fore-wing's sweep phase lies within half a step of
    :data:`CANONICAL_SWEEP_PHASE`; ``pairs_independent`` (the model is not phase-resolved,
    ``ModelOptions.phase_resolved()`` False: the default mean slipstream) delays the hind pair
    on its own the same way, else by the fore pair's delay. The model's results are unchanged
    to rounding (module docstring)."""
    strokes = np.array(physical, dtype=np.float64, ndmin=2)
    step = 360.0 / int(n_time)

    def steps(phase: np.ndarray) -> np.ndarray:
        return np.round(_wrap_degrees(phase - CANONICAL_SWEEP_PHASE) / step) * step

    fore = steps(strokes[:, _SWEEP])
    hind = steps(strokes[:, N_PER_WING + _SWEEP]) if pairs_independent else fore
    return delay(strokes, fore, hind)


def _wrap_normalised(x: np.ndarray) -> np.ndarray:
    return (np.asarray(x, dtype=np.float64) + 1.0) % 2.0 - 1.0


# --- settings ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Settings:
    """How an amortised policy is trained (``--hyperparams key=value``; ``config.yml``)."""

    hidden: tuple[int, ...] = (64, 64)
    """Widths of the MLP's hidden layers (tanh) [-]."""
    regression_steps: int = 5000
    """Adam steps of the regression on the training optima (full batch) [-]."""
    regression_lr: float = 3e-3
    """Adam's learning rate in the regression [-]."""
    finetune_steps: int = 600
    """Adam steps of the fine-tuning by the objective's gradient (0: none) [-]."""
    finetune_lr: float = 1e-3
    """Adam's learning rate in the fine-tuning [-]."""
    batch: int = 16
    """Conditions per fine-tuning step (one batched model evaluation) [-]."""
    penalty_weight: float = 10.0
    """w of the fine-tuning's penalty [objective units per unit of margin] (the env's default
    ``penalty_weight``)."""
    safety_margin: float = 1e-3
    """δ: the fine-tuning penalises every constraint margin below it [-] (margins are
    fractions: the level flight's tolerance is 0.02)."""
    anchor: float = 0.1
    """Weight of the regression loss on the training targets during the fine-tuning [-]."""
    features: int = 32
    """Gaussian radial features of the observation before the MLP (0: the observation
    itself) [-] (:class:`RadialFeatures`)."""
    finetune_n_time: int | None = None
    """Time samples of the fine-tuning's model (None: the env's, default 128) [-]."""
    finetune_n_blade: int | None = None
    """Blade elements of the fine-tuning's model (None: the env's, default 24) [-]."""

    def __post_init__(self) -> None:
        hidden = self.hidden
        if isinstance(hidden, int | np.integer) and not isinstance(hidden, bool):
            hidden = (hidden,)
        if (
            not isinstance(hidden, list | tuple)
            or not hidden
            or not all(is_integer(h) and 1 <= h <= 4096 for h in hidden)
            or len(hidden) > 8
        ):
            raise ValueError(
                f"hidden = {self.hidden!r}; allowed: 1 to 8 layer widths, each an integer from "
                "1 to 4096, e.g. [64, 64]"
            )
        object.__setattr__(self, "hidden", tuple(int(h) for h in hidden))
        for name, low, high in (
            ("features", 0, 1024),
            ("regression_steps", 0, 10**6),
            ("finetune_steps", 0, 10**6),
            ("batch", 1, 4096),
        ):
            value = getattr(self, name)
            if not is_integer(value) or not low <= value <= high:
                raise ValueError(f"{name} = {value!r}; allowed: an integer from {low} to {high:,}")
            object.__setattr__(self, name, int(value))
        for name, low, high, open_low in (
            ("regression_lr", 0.0, 1.0, True),
            ("finetune_lr", 0.0, 1.0, True),
            ("penalty_weight", 0.0, 1e6, True),
            ("safety_margin", 0.0, 0.1, False),
            ("anchor", 0.0, 1e6, False),
        ):
            value = getattr(self, name)
            ok = is_real(value) and math.isfinite(value) and low <= value <= high
            if not ok or (open_low and value == low):
                bound = f"above {low:g}" if open_low else f"from {low:g}"
                raise ValueError(f"{name} = {value!r}; allowed: a number {bound} to {high:g}")
            object.__setattr__(self, name, float(value))
        for name, low, high in (("finetune_n_time", 8, 4096), ("finetune_n_blade", 2, 512)):
            value = getattr(self, name)
            if value is not None and (not is_integer(value) or not low <= value <= high):
                raise ValueError(
                    f"{name} = {value!r}; allowed: None (the env's) or an integer from {low} to "
                    f"{high}"
                )
            if value is not None:
                object.__setattr__(self, name, int(value))

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> Settings:
        """Settings from ``key=value`` overrides; ValueError naming an unknown key."""
        names = [f.name for f in fields(cls)]
        unknown = sorted(set(values) - set(names))
        if unknown:
            raise ValueError(f"unknown amortised setting(s) {unknown}; allowed: {', '.join(names)}")
        return cls(**dict(values))

    def to_dict(self) -> dict[str, Any]:
        return to_jsonable(asdict(self))


# --- the problem and its reference -------------------------------------------------------------
def check_env_kwargs(env_id: str, env_kwargs: Mapping[str, Any]) -> Any:
    """The reference series (``tandem_env.envs.reference.ReferenceSeries``) the env of
    ``env_id`` with ``env_kwargs`` is trained on; ValueError naming the value and what is
    allowed where the table does not describe that problem (module docstring). Nothing is
    evaluated."""
    from tandem_env.envs.reference import (
        REFERENCE_GRID,
        load_reference_table,
        problem_fingerprint,
        reference_path,
    )
    from tandem_env.envs.registration import check_env_id, config_class

    check_env_id(env_id, "env")
    if env_id not in REFERENCE_GRID:
        raise ValueError(
            f"env = {env_id!r} has no reference table to train an amortised policy on; "
            f"allowed: {', '.join(map(repr, REFERENCE_GRID))}"
        )
    config_type = config_class(env_id)
    declared = config_type.CONDITION
    condition_words = (declared.keyword, declared.range_keyword, declared.envelope_keyword)
    given = sorted(set(env_kwargs) & set(condition_words))
    if given:
        raise ValueError(
            f"env_kwargs {given}: the condition is the amortised policy's input, set per "
            f"stroke; allowed: none of {', '.join(condition_words)}"
        )
    config = config_type.from_kwargs(**dict(env_kwargs))
    objective = config_type.OBJECTIVES.choice(config)
    try:
        table = load_reference_table()
    except FileNotFoundError:
        raise ValueError(
            f"the reference table {reference_path()} is missing; an amortised policy is "
            "trained on it. Allowed: make it with python -m eval reference"
        ) from None
    planform = config.planform
    series = table.find(env_id, str(objective), problem_fingerprint(config))
    if series is not None:
        return series
    # which is it: a series the table lacks, or options that change the problem?
    table.get(env_id, str(objective), planform)  # raises naming what the table holds
    default = config_type.from_kwargs(
        planform=planform, **_objective_kwargs(config_type, objective)
    )
    changed = sorted(
        k
        for k, v in to_jsonable(config).items()
        if to_jsonable(default).get(k) != v and k not in ("penalty", "backend", "device")
    )
    raise ValueError(
        f"env_kwargs {dict(env_kwargs)!r} change the problem the reference table describes "
        f"(differing from the default: {', '.join(changed) or 'the model'}); allowed: the default "
        "model options, insect and tolerances, with planform ('tear-drop' or 'real'), the "
        "objective, penalty_weight, penalty_offset, backend and device"
    )


def _objective_kwargs(config_type: type, objective: str) -> dict[str, Any]:
    keyword = config_type.OBJECTIVES.keyword
    return {} if keyword is None else {keyword: objective}


def make_problem(env_id: str, env_kwargs: Mapping[str, Any], **options: Any) -> Any:
    """The env's problem view (``FlightProblem``) with ``env_kwargs`` and model ``options``
    (e.g. ``n_time``) over them."""
    import gymnasium as gym

    import tandem_env  # noqa: F401 - registers the ids

    env = gym.make(env_id, disable_env_checker=True, **{**dict(env_kwargs), **options})
    try:
        return env.unwrapped.problem()
    finally:
        env.close()


@dataclass(frozen=True)
class Targets:
    """The regression's targets: optima at the training conditions, canonicalised."""

    conditions: np.ndarray
    """(K,) training conditions, increasing [the condition's unit]."""
    strokes: np.ndarray
    """(K, 28) canonical normalised optima."""
    objectives: np.ndarray
    """(K,) their objectives [the objective's unit] (the reference at each)."""

    def __post_init__(self) -> None:
        conditions = np.asarray(self.conditions, dtype=np.float64)
        strokes = np.asarray(self.strokes, dtype=np.float64)
        objectives = np.asarray(self.objectives, dtype=np.float64)
        k = conditions.shape[0] if conditions.ndim == 1 else -1
        if (
            k < 1
            or strokes.shape != (k, N_PARAMETERS)
            or objectives.shape != (k,)
            or not np.all(np.diff(conditions) > 0)
            or not np.all(np.isfinite(strokes))
            or not np.all(np.abs(strokes) <= 1.0)
        ):
            raise ValueError(
                f"targets: conditions {conditions.shape}, strokes {strokes.shape}, objectives "
                f"{objectives.shape}; allowed: K >= 1 increasing conditions, (K, 28) strokes in "
                "[-1, 1], (K,) objectives"
            )
        object.__setattr__(self, "conditions", conditions)
        object.__setattr__(self, "strokes", strokes)
        object.__setattr__(self, "objectives", objectives)


def reference_targets(series: Any, n_time: int, *, pairs_independent: bool) -> Targets:
    """The canonical optima of a reference series at its env's training conditions only
    (``training_conditions``; the held-out ones are never read)."""
    from tandem_env.envs.reference import training_conditions

    wanted = training_conditions(series.env_id)
    rows = [
        (c, point)
        for c, point in zip(series.conditions, series.points, strict=True)
        if any(math.isclose(c, w, rel_tol=0, abs_tol=1e-9) for w in wanted)
    ]
    if len(rows) != len(wanted):
        raise ValueError(
            f"the reference series of {series.env_id} holds {len(rows)} of the {len(wanted)} "
            "training conditions; allowed: a complete table (python -m eval reference)"
        )
    strokes = np.array([point["normalised_stroke"] for _, point in rows], dtype=np.float64)
    canonical = canonicalise(
        normalised_to_physical(np.clip(strokes, -1.0, 1.0)),
        n_time,
        pairs_independent=pairs_independent,
    )
    return Targets(
        conditions=np.array([c for c, _ in rows]),
        strokes=np.clip(physical_to_normalised(canonical), -1.0, 1.0),
        objectives=np.array([float(point["objective"]) for _, point in rows]),
    )


# --- the network and the policy ------------------------------------------------------------------
class RadialFeatures:
    """Fixed Gaussian bumps of the observation x ∈ [-1, 1]: ``exp(−((x − μ_k)/σ)²/2)`` at
    ``count`` centres μ_k evenly over [-1, 1], σ their spacing. A gradient step for one
    condition then moves mostly the strokes of the conditions near it (what the per-condition
    optima need: they are not one smooth family), while the map stays smooth."""

    def __new__(cls, count: int) -> Any:
        import torch

        class _Radial(torch.nn.Module):
            def __init__(self) -> None:
                super().__init__()
                self.register_buffer(
                    "centres", torch.linspace(-1.0, 1.0, count, dtype=torch.float64)
                )
                self.width = 2.0 / max(1, count - 1)

            def forward(self, x: Any) -> Any:
                return torch.exp(-0.5 * ((x - self.centres) / self.width) ** 2)

        return _Radial()


def build_network(hidden: Sequence[int], features: int = 0) -> Any:
    """The MLP 1 -> (``features`` > 0: :class:`RadialFeatures`) -> hidden (tanh) -> 26
    (linear: z, the output u = tanh z is taken by :class:`AmortisedPolicy`), float64."""
    import torch

    layers: list[Any] = []
    width = 1
    if features:
        layers.append(RadialFeatures(features))
        width = features
    for h in hidden:
        layers += [torch.nn.Linear(width, h), torch.nn.Tanh()]
        width = h
    layers.append(torch.nn.Linear(width, len(CONTINUOUS)))
    return torch.nn.Sequential(*layers).double()


@dataclass(frozen=True, eq=False)
class AmortisedPolicy:
    """A trained amortised policy: the network and what its forward pass needs besides."""

    network: Any
    """The torch MLP (observation (B, 1) -> z (B, 26), u = tanh z)."""
    env_id: str
    env_kwargs: Mapping[str, Any]
    envelope: tuple[float, float]
    """The env's observation envelope [the condition's unit]."""
    centres: np.ndarray
    """(26,) each output's centre [normalised]: 0 but for the phases (module docstring)."""
    harmonic_conditions: np.ndarray
    """(K,) the training conditions [the condition's unit] ..."""
    harmonics: np.ndarray
    """(K, 2) ... and their optima's N coordinates (-0.5 for N = 1, 0.5 for N = 2)."""
    run_dir: Path | None = None
    num_timesteps: int = 0
    """Strokes evaluated in training (the fine-tuning's model evaluations)."""
    algo: str = ALGO
    which: str = "final"

    # --- forward pass ---------------------------------------------------------------------
    def observe(self, conditions: Sequence[float] | np.ndarray) -> np.ndarray:
        """(n, 1) float32 observations of ``conditions``, as the env observes them."""
        values = np.asarray(conditions, dtype=np.float64).reshape(-1)
        low, high = self.envelope
        scaled = 2.0 * (values - low) / (high - low)
        return np.clip(scaled - 1.0, -1.0, 1.0).astype(np.float32)[:, None]

    def harmonics_at(self, conditions: np.ndarray) -> np.ndarray:
        """(n, 2) N coordinates: the nearest training condition's (the lower on a tie)."""
        distance = np.abs(np.asarray(conditions)[:, None] - self.harmonic_conditions[None, :])
        return self.harmonics[np.argmin(distance, axis=1)]

    def forward(self, conditions: np.ndarray) -> Any:
        """(n, 28) normalised strokes as a float64 tensor, differentiable w.r.t. the weights."""
        import torch

        obs = torch.as_tensor(self.observe(conditions), dtype=torch.float64)
        u = torch.tanh(self.network(obs))
        return self.assemble(u, np.asarray(conditions, dtype=np.float64).reshape(-1))

    def assemble(self, u: Any, conditions: np.ndarray) -> Any:
        import torch

        centres = torch.as_tensor(self.centres, dtype=torch.float64)
        phase = torch.as_tensor(_phase_mask(), dtype=torch.bool)
        shifted = torch.remainder(u + centres + 1.0, 2.0) - 1.0
        continuous = torch.where(phase, shifted, u)
        out = torch.zeros((u.shape[0], N_PARAMETERS), dtype=torch.float64)
        out[:, list(CONTINUOUS)] = continuous
        out[:, list(HARMONICS)] = torch.as_tensor(self.harmonics_at(conditions))
        return out

    def strokes(self, conditions: Sequence[float]) -> np.ndarray:
        """The normalised strokes (n, 28) in [-1, 1] at ``conditions`` (one forward pass)."""
        import torch

        values = np.asarray([float(c) for c in conditions], dtype=np.float64)
        if values.size == 0:
            raise ValueError("conditions is empty; allowed: one or more conditions")
        if not np.all(np.isfinite(values)):
            raise ValueError(f"conditions = {list(values)!r}; allowed: finite numbers")
        with torch.no_grad():
            out = self.forward(values).numpy()
        return np.clip(out, -1.0, 1.0)

    # --- what the harness and the envelope read ---------------------------------------------
    @property
    def model_path(self) -> Path:
        base = Path(".") if self.run_dir is None else self.run_dir
        return base / f"{env_name(self.env_id)}{WEIGHTS_SUFFIX}"

    @property
    def training_conditions(self) -> tuple[float, float]:
        """The range of conditions it was trained over [the condition's unit]."""
        return float(self.harmonic_conditions[0]), float(self.harmonic_conditions[-1])

    def trained_at(self, value: float) -> bool:
        low, high = self.training_conditions
        return low - 1e-9 <= value <= high + 1e-9

    def check_env(self, env_id: str) -> None:
        if self.env_id != env_id:
            raise ValueError(
                f"{self.run_dir} was trained on {self.env_id}; this task's env is {env_id}; "
                "allowed: a run of the same env"
            )

    @property
    def citation(self) -> str:
        return CITATION

    def policy_data(self) -> dict[str, Any]:
        """``policy.json``'s content (the weights are beside it)."""
        return {
            "format": POLICY_FORMAT,
            "env_id": self.env_id,
            "env_kwargs": to_jsonable(dict(self.env_kwargs)),
            "hidden": [m.out_features for m in self.network if hasattr(m, "out_features")][:-1],
            "features": int(getattr(self.network[0], "centres", torch_empty()).numel()),
            "envelope": list(self.envelope),
            "centres": self.centres.tolist(),
            "harmonic_conditions": self.harmonic_conditions.tolist(),
            "harmonics": self.harmonics.tolist(),
            "num_timesteps": int(self.num_timesteps),
            "continuous": list(CONTINUOUS),
            "phases": list(PHASES),
            "canonical_sweep_phase": CANONICAL_SWEEP_PHASE,
        }


def torch_empty() -> Any:
    import torch

    return torch.empty(0)


def _phase_mask() -> np.ndarray:
    return np.array([j in PHASES for j in CONTINUOUS])


def _centres(targets: Targets, canonical: Sequence[int]) -> np.ndarray:
    """(26,) output centres: the circular mean of the targets' phase (the canonical value for
    the ``canonical`` phases), 0 for the other coordinates."""
    centres = np.zeros(len(CONTINUOUS))
    for k, j in enumerate(CONTINUOUS):
        if j not in PHASES:
            continue
        if j in canonical:
            centres[k] = CANONICAL_SWEEP_PHASE / 180.0
        else:
            angle = np.pi * targets.strokes[:, j]
            centres[k] = math.atan2(np.sin(angle).mean(), np.cos(angle).mean()) / np.pi
    return centres


def regression_outputs(targets: Targets, centres: np.ndarray) -> np.ndarray:
    """(K, 26) what the tanh outputs are fitted to: each continuous target, its phases relative
    to their centres (wrapped), all within :data:`TARGET_LIMIT`."""
    u = targets.strokes[:, list(CONTINUOUS)].copy()
    mask = _phase_mask()
    u[:, mask] = _wrap_normalised(u[:, mask] - centres[mask])
    return np.clip(u, -TARGET_LIMIT, TARGET_LIMIT)


# --- training ----------------------------------------------------------------------------------
@contextlib.contextmanager
def _torch_state(seed: int) -> Iterator[None]:
    """One torch thread and the seed, restored afterwards."""
    import torch

    threads = torch.get_num_threads()
    rng = torch.random.get_rng_state()
    torch.set_num_threads(1)
    torch.manual_seed(seed)
    try:
        yield
    finally:
        torch.set_num_threads(threads)
        torch.random.set_rng_state(rng)


@dataclass
class Training:
    """What :func:`train_policy` hands back besides the policy."""

    regression_loss: float = math.nan
    regression_seconds: float = 0.0
    finetune_seconds: float = 0.0
    history: list[dict[str, float]] = field(default_factory=list)
    """Per fine-tuning step: mean score-like J/ref, feasible share, loss."""


def train_policy(
    env_id: str,
    env_kwargs: Mapping[str, Any],
    targets: Targets,
    settings: Settings,
    seed: int = 0,
    *,
    progress: Any = None,
) -> tuple[AmortisedPolicy, Training]:
    """Train an amortised policy on ``targets`` (module docstring: (a) regression, (b)
    fine-tuning through ``env_id``'s problem view with ``env_kwargs``). ``progress``: called
    as ``progress(step, total, row)`` after each fine-tuning step."""
    import torch

    problem = make_problem(
        env_id,
        env_kwargs,
        **{
            k: v
            for k, v in (
                ("n_time", settings.finetune_n_time),
                ("n_blade", settings.finetune_n_blade),
            )
            if v is not None
        },
    )
    config = problem.config
    canonical = [7, 21] if not config.options.phase_resolved() else [7]
    centres = _centres(targets, canonical)
    record = Training()
    with _torch_state(seed):
        network = build_network(settings.hidden, settings.features)
        policy = AmortisedPolicy(
            network=network,
            env_id=env_id,
            env_kwargs=dict(env_kwargs),
            envelope=tuple(float(v) for v in config.envelope),  # type: ignore[arg-type]
            centres=centres,
            harmonic_conditions=targets.conditions.copy(),
            harmonics=np.where(targets.strokes[:, list(HARMONICS)] < 0, -0.5, 0.5),
        )
        obs = torch.as_tensor(policy.observe(targets.conditions), dtype=torch.float64)
        # fitted before the output's tanh (z = atanh u): no saturated gradient at a bound
        goal = torch.as_tensor(np.arctanh(regression_outputs(targets, centres)))

        def regression_loss() -> Any:
            return torch.mean((network(obs) - goal) ** 2)

        start = time.perf_counter()
        optimiser = torch.optim.Adam(network.parameters(), lr=settings.regression_lr)
        for _ in range(settings.regression_steps):
            optimiser.zero_grad()
            loss = regression_loss()
            loss.backward()
            optimiser.step()
        with torch.no_grad():
            record.regression_loss = float(regression_loss())
        record.regression_seconds = time.perf_counter() - start

        start = time.perf_counter()
        rng = np.random.default_rng(seed)
        low, high = float(targets.conditions[0]), float(targets.conditions[-1])
        optimiser = torch.optim.Adam(network.parameters(), lr=settings.finetune_lr)
        schedule = torch.optim.lr_scheduler.CosineAnnealingLR(
            optimiser, max(1, settings.finetune_steps)
        )
        evaluated = 0
        strata = np.arange(settings.batch) / settings.batch
        for step in range(settings.finetune_steps):
            # uniform over [low, high], one draw in each of batch equal strata (less variance)
            draws = strata + rng.uniform(0.0, 1.0 / settings.batch, settings.batch)
            conditions = low + (high - low) * draws
            ref = np.interp(conditions, targets.conditions, targets.objectives)
            optimiser.zero_grad()
            actions = policy.forward(conditions)
            found = problem.differentiate(actions.detach().numpy(), conditions)
            evaluated += settings.batch
            margins = found.evaluation.margins
            short = margins < settings.safety_margin
            value = found.evaluation.objective - settings.penalty_weight * np.sum(
                np.where(short, settings.safety_margin - margins, 0.0), axis=1
            )
            d_value = found.objective_gradient + settings.penalty_weight * np.einsum(
                "bm,bmj->bj", short.astype(np.float64), found.margin_jacobian
            )
            scale = ref * settings.batch
            d_loss = torch.as_tensor(-d_value / scale[:, None])
            actions.backward(d_loss)
            anchor = 0.0
            if settings.anchor > 0:
                term = settings.anchor * regression_loss()
                term.backward()
                anchor = float(term.detach())
            optimiser.step()
            schedule.step()
            row = {
                "step": step + 1,
                "relative_value": float(np.mean(value / ref)),
                "feasible": float(np.mean(found.evaluation.feasible)),
                "anchor": anchor,
            }
            record.history.append(row)
            if progress is not None:
                progress(step + 1, settings.finetune_steps, row)
        record.finetune_seconds = time.perf_counter() - start
    policy = _with(policy, num_timesteps=evaluated)
    return policy, record


def _with(policy: AmortisedPolicy, **changes: Any) -> AmortisedPolicy:
    from dataclasses import replace

    return replace(policy, **changes)


# --- run folders -------------------------------------------------------------------------------
def _write_yaml(path: Path, data: Mapping[str, Any]) -> None:
    write_text_atomic(path, yaml.safe_dump(to_jsonable(dict(data)), sort_keys=True))


def save_run(
    layout: RunLayout,
    policy: AmortisedPolicy,
    settings: Settings,
    args: Mapping[str, Any],
    result: Mapping[str, Any],
) -> None:
    """Write the run folder (module docstring), each file atomically; the weights last but one,
    ``result.json`` last (a folder with it is complete)."""
    import torch

    _write_yaml(layout.config_file, settings.to_dict())
    _write_yaml(layout.args_file, {"made_by": MADE_BY, "algo": ALGO, **dict(args)})
    write_json_atomic(layout.run_dir / POLICY_FILE, policy.policy_data())
    with atomic_path(layout.run_dir / f"{layout.name}{WEIGHTS_SUFFIX}") as tmp:
        torch.save(policy.network.state_dict(), tmp)
    write_json_atomic(layout.result_file, result)


def is_amortised_run(run_dir: str | Path) -> bool:
    """Whether ``run_dir`` (or the latest run it names) holds an amortised run: its one
    ``<env>/args.yml`` says ``algo: amortised``."""
    folder = resolve_run_dir(run_dir)
    found = sorted(folder.glob("*/args.yml")) if folder.is_dir() else []
    if len(found) != 1:
        return False
    try:
        return read_run_yaml(found[0]).get("algo") == ALGO
    except ValueError:
        return False


def load_policy(run_dir: str | Path) -> AmortisedPolicy:
    """The policy of an amortised run folder (or of the latest run it names): its weights
    read with ``torch.load(weights_only=True)``, ``policy.json`` as JSON; ValueError naming
    the file at fault."""
    import torch

    folder = resolve_run_dir(run_dir)
    found = sorted(folder.glob("*/args.yml")) if folder.is_dir() else []
    if len(found) != 1:
        raise ValueError(
            f"{folder} is not a training run folder (expected one <env>/args.yml, found "
            f"{len(found)}); allowed: a folder written by python -m train --algo amortised"
        )
    args = read_run_yaml(found[0])
    env_id = args.get("env")
    if args.get("algo") != ALGO or not isinstance(env_id, str):
        raise ValueError(f"{found[0]}: algo = {args.get('algo')!r}; allowed: {ALGO!r}")
    if env_name(env_id) != found[0].parent.name:
        raise ValueError(
            f"{found[0]}: env = {env_id!r}, but the file sits in the settings folder of "
            f"{found[0].parent.name}; allowed: the env the run was trained on"
        )
    layout = RunLayout(folder, env_id)
    path = folder / POLICY_FILE
    if not path.is_file():
        raise ValueError(f"{folder}: no {POLICY_FILE} (did the run finish?)")
    data = read_json(path)
    if not isinstance(data, dict) or data.get("format") != POLICY_FORMAT:
        raise ValueError(f"{path}: not a policy file of format {POLICY_FORMAT!r}")
    weights = folder / f"{layout.name}{WEIGHTS_SUFFIX}"
    if not weights.is_file():
        raise ValueError(f"{folder}: no weights file {weights.name} (did the run finish?)")
    try:
        hidden = [int(h) for h in data["hidden"]]
        network = build_network(hidden, int(data.get("features", 0)))
        state = torch.load(weights, map_location="cpu", weights_only=True)
        network.load_state_dict(state)
        policy = AmortisedPolicy(
            network=network.eval(),
            env_id=env_id,
            env_kwargs=dict(data["env_kwargs"]),
            envelope=(float(data["envelope"][0]), float(data["envelope"][1])),
            centres=np.asarray(data["centres"], dtype=np.float64),
            harmonic_conditions=np.asarray(data["harmonic_conditions"], dtype=np.float64),
            harmonics=np.asarray(data["harmonics"], dtype=np.float64),
            run_dir=folder,
            num_timesteps=int(data["num_timesteps"]),
        )
    except (KeyError, TypeError, ValueError, RuntimeError) as error:
        raise ValueError(
            f"{folder}: its policy files do not load ({type(error).__name__}: {error})"
        ) from None
    if policy.centres.shape != (len(CONTINUOUS),) or policy.harmonics.shape != (
        policy.harmonic_conditions.shape[0],
        2,
    ):
        raise ValueError(f"{path}: centres or harmonics of the wrong shape")
    return policy


# --- the command's trainer ---------------------------------------------------------------------
@dataclass(frozen=True)
class RunResult:
    """What ``python -m train --algo amortised`` prints."""

    run_dir: Path
    policy: AmortisedPolicy
    training: Training
    summary: Mapping[str, Any]


def train_run(
    env_id: str,
    env_kwargs: Mapping[str, Any],
    overrides: Mapping[str, Any],
    seed: int,
    log_folder: Path,
    *,
    run_dir: Path | None = None,
    verbose: int = 1,
    argv: Mapping[str, Any] | None = None,
) -> RunResult:
    """Check everything, train on the reference table's training optima, write the run folder
    (``log_folder/amortised/<env>_<n>/``, or ``run_dir``: a new or empty folder), and evaluate
    the final policy at the training conditions (default model) for the summary."""
    from tandem_env.envs.reference import load_reference_table, training_conditions

    settings = Settings.from_mapping(overrides)
    series = check_env_kwargs(env_id, env_kwargs)
    if run_dir is not None:
        run_dir = Path(run_dir)
        if run_dir.exists() and (not run_dir.is_dir() or any(run_dir.iterdir())):
            raise ValueError(
                f"run_dir = {run_dir}: not an empty folder; an amortised run is not resumed "
                "(it trains in minutes). Allowed: a new or empty folder"
            )
    problem = make_problem(env_id, env_kwargs)
    n_time = settings.finetune_n_time or problem.config.options.n_time
    targets = reference_targets(
        series, n_time, pairs_independent=not problem.config.options.phase_resolved()
    )

    def report(step: int, total: int, row: Mapping[str, float]) -> None:
        if verbose and (step % 25 == 0 or step == total):
            print(
                f"fine-tuning step {step}/{total}: mean J/ref {row['relative_value']:.4f}, "
                f"feasible {row['feasible']:.2f}",
                flush=True,
            )

    start = time.perf_counter()
    policy, training = train_policy(env_id, env_kwargs, targets, settings, seed, progress=report)
    wall = time.perf_counter() - start
    if run_dir is None:
        layout = RunLayout.new(log_folder, ALGO, env_id)
    else:
        run_dir.mkdir(parents=True, exist_ok=True)
        layout = RunLayout(run_dir, env_id)
    policy = _with(policy, run_dir=layout.run_dir)
    # the final policy at the training conditions, at the env's resolution
    conditions = np.asarray(training_conditions(env_id))
    found = problem.evaluate(policy.strokes(conditions), conditions)
    table = load_reference_table()
    summary = {
        "algo": ALGO,
        "env_id": env_id,
        "seed": seed,
        "wall_time": wall,
        "regression_loss": training.regression_loss,
        "regression_seconds": training.regression_seconds,
        "finetune_seconds": training.finetune_seconds,
        "num_timesteps": policy.num_timesteps,
        "series": {
            "objective": series.objective,
            "planform": series.planform,
            "fingerprint": series.fingerprint,
        },
        "reference_provenance": to_jsonable(dict(table.provenance)),
        "training_evaluation": [
            {
                "condition": float(c),
                "objective": float(o),
                "feasible": bool(f),
                "reference": float(r),
            }
            for c, o, f, r in zip(
                conditions, found.objective, found.feasible, targets.objectives, strict=True
            )
        ],
        "history": training.history,
        "versions": _versions(),
    }
    save_run(
        layout,
        policy,
        settings,
        {
            "env": env_id,
            "seed": seed,
            "env_kwargs": to_jsonable(dict(env_kwargs)),
            "hyperparams": to_jsonable(dict(overrides)),
            "log_folder": str(log_folder),
            "run_dir": None if run_dir is None else str(run_dir),
            **dict(argv or {}),
        },
        summary,
    )
    return RunResult(layout.run_dir, policy, training, summary)


def _versions() -> dict[str, str]:
    from agents.records import package_versions

    return package_versions()
