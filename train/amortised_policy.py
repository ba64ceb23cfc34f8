"""The amortised stroke policy (trained by :mod:`train.amortised`; docs/training.md, "Amortised
policy"): its map from the condition c [the condition's unit] to a normalised stroke (28,) in
[-1, 1], its training settings (:class:`Settings`, the one home of their limits), canonical
targets (:func:`canonicalise`) and run folder files (``<env>.pt``, the weights, read with
``torch.load(weights_only=True)``, and ``policy.json``).
"""

from __future__ import annotations

import math
import pickle
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import torch

from tandem_env.envs.declaration import refusal
from tandem_env.envs.reference import REFERENCE_GRID, training_conditions
from tandem_env.envs.registration import config_class
from tandem_env.io.files import read_json, to_jsonable
from tandem_env.physics.checks import count, is_integer, is_real, real_array
from tandem_env.physics.stroke import (
    DISCRETE,
    HARMONIC_INDEX,
    N_PARAMETERS,
    N_PER_WING,
    normalised_to_physical,
    physical_to_normalised,
)
from train.config import AMORTISED
from train.run_folder import POLICY_FILE, RunLayout, RunPolicy, read_run_folder

#: Where the canonical targets put each canonicalised sweep phase [deg] (within half a time-grid
#: step, :func:`canonicalise`).
CANONICAL_SWEEP_PHASE = 0.0
#: The most a regression target lies from 0 in a normalised coordinate [-]: targets at a bound
#: are held this far inside (0.005 % of the parameter's range), where tanh can reach them.
TARGET_LIMIT = 0.9999
#: Format of ``policy.json``.
POLICY_FORMAT = "tandem_env.amortised-policy/2"

#: Per wing, indices of the sweep, elevation and pitch phases and of N within its 14.
_SWEEP, _ELEVATION, _PITCH = 7, 8, 9
#: The 26 continuous coordinates the network outputs, in action order.
CONTINUOUS: tuple[int, ...] = tuple(j for j in range(N_PARAMETERS) if not DISCRETE[j])
#: The six phase coordinates of the action.
PHASES: tuple[int, ...] = tuple(
    w + k for w in (0, N_PER_WING) for k in (_SWEEP, _ELEVATION, _PITCH)
)
HARMONICS: tuple[int, ...] = (HARMONIC_INDEX, N_PER_WING + HARMONIC_INDEX)
#: The policy's arrays ``policy.json`` holds, in its order.
_ARRAYS = ("centres", "switches", "domains", "harmonics")
#: (28,) which of the action's coordinates are phases, and (26,) which of the network's outputs.
PHASE_MASK = np.isin(np.arange(N_PARAMETERS), PHASES)
_OUTPUT_PHASES = PHASE_MASK[list(CONTINUOUS)]
CITATION = (
    "amortised optimisation (Amos 2023, 'Tutorial on amortized optimization', Found. Trends "
    "Mach. Learn. 16(5)): one MLP per branch of the reference optima, regressed on them at the "
    "training conditions and fine-tuned by the autograd gradient of the penalised objective"
)


# --- how it is trained (``--hyperparams``, ``config.yml``) and the limits of its network ----
@dataclass(frozen=True)
class Settings:
    """How an amortised policy is trained (``--hyperparams key=value``; ``config.yml``)."""

    hidden: tuple[int, ...] = (64, 64)
    """Widths of the MLP's hidden layers (tanh) [-]."""
    regression_steps: int = field(default=5000, metadata={"range": (0, 10**6)})
    """Adam steps of the regression on the training optima (full batch) [-]."""
    regression_lr: float = field(default=3e-3, metadata={"range": (0.0, 1.0), "above": True})
    """Adam's learning rate in the regression [-]."""
    finetune_steps: int = field(default=600, metadata={"range": (0, 10**6)})
    """Adam steps of the fine-tuning by the objective's gradient (0: none) [-]."""
    finetune_lr: float = field(default=1e-3, metadata={"range": (0.0, 1.0), "above": True})
    """Adam's learning rate in the fine-tuning [-]."""
    batch: int = field(default=16, metadata={"range": (1, 4096)})
    """Conditions per branch and fine-tuning step (all in one batched model evaluation) [-]."""
    penalty_weight: float = field(default=10.0, metadata={"range": (0.0, 1e6), "above": True})
    """w of the fine-tuning's penalty [objective units per unit of margin] (the env's default
    ``penalty_weight``)."""
    safety_margin: float = field(default=1e-3, metadata={"range": (0.0, 0.1)})
    """δ: the fine-tuning penalises every constraint margin below it [-] (margins are
    fractions: the level flight's tolerance is 0.02)."""
    anchor: float = field(default=30.0, metadata={"range": (0.0, 1e6)})
    """Weight of the regression loss on the training targets during the fine-tuning [-]."""
    branch_reach: float = field(default=0.6, metadata={"range": (0.5, 1.0), "above": True})
    """How far each branch's domain reaches into the gap to a neighbouring branch's training
    condition [fraction of the gap] (above 0.5: both cover its middle, where they hand over)."""
    branch_tolerance: float = field(default=0.1, metadata={"range": (0.0, 1.0)})
    """Two neighbouring training optima share a branch when the stroke midway loses at most this
    fraction of their mean objective and violates no margin by more (``branch_segments``) [-]."""
    features: int = field(default=0, metadata={"range": (0, 1024)})
    """Gaussian radial features of the observation before the MLP (0: the observation
    itself) [-] (:func:`radial_features`)."""
    finetune_n_time: int | None = field(default=None, metadata={"range": (8, 4096)})
    """Time samples of the fine-tuning's model (None: the env's, default 128) [-]."""
    finetune_n_blade: int | None = field(default=None, metadata={"range": (2, 512)})
    """Blade elements of the fine-tuning's model (None: the env's, default 24) [-]."""

    def __post_init__(self) -> None:
        hidden = (self.hidden,) if is_integer(self.hidden) else self.hidden
        if (
            not isinstance(hidden, list | tuple)
            or not hidden
            or not all(is_integer(h) and 1 <= h <= 4096 for h in hidden)
            or len(hidden) > 8
        ):
            allowed = "1 to 8 layer widths, each an integer from 1 to 4096, e.g. [64, 64]"
            raise refusal("hidden", self.hidden, allowed)
        object.__setattr__(self, "hidden", tuple(int(h) for h in hidden))
        # the numbers, each in its metadata's range: low (excluded if "above") to high; an
        # int | None setting may also be None
        for spec in fields(self)[1:]:
            name, value, (low, high) = spec.name, getattr(self, spec.name), spec.metadata["range"]
            if value is None and spec.type == "int | None":
                continue
            real, above = spec.type == "float", spec.metadata.get("above", False)
            if (
                not (is_real(value) if real else is_integer(value))
                or not (low < value if above else low <= value)
                or value > high
            ):
                optional = "None (the env's) or " if "None" in spec.type else ""
                kind = f"a number {'above' if above else 'from'} {low:g} to {high:g}"
                kind = kind if real else f"an integer from {low} to {high:,}"
                raise ValueError(f"{name} = {value!r}; allowed: {optional}{kind}")
            object.__setattr__(self, name, float(value) if real else int(value))

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> Settings:
        """Settings from ``key=value`` overrides; ValueError naming an unknown key."""
        names = [f.name for f in fields(cls)]
        unknown = sorted(set(values) - set(names))
        if unknown:
            raise ValueError(f"unknown amortised setting(s) {unknown}; allowed: {', '.join(names)}")
        return cls(**dict(values))


# --- canonical strokes -------------------------------------------------------------------------
def wrap_normalised(x: np.ndarray, half: float = 1.0) -> np.ndarray:
    """``x`` wrapped onto [-half, half): a normalised phase, or with ``half=180`` one in degrees."""
    return (np.asarray(x, dtype=np.float64) + half) % (2.0 * half) - half


def delay(physical: np.ndarray, fore: Any, hind: Any) -> np.ndarray:
    """Physical strokes (B, 28) [Table 4 units] with each pair's motion delayed by ``fore`` and
    ``hind`` [deg of its own cycle, scalars or (B,)]: its sweep and pitch phases less Δ, its
    elevation phase less N·Δ, wrapped onto [-180°, 180°)."""
    out = np.array(physical, dtype=np.float64, copy=True)
    for base, shift in ((0, fore), (N_PER_WING, hind)):
        d = np.broadcast_to(np.asarray(shift, dtype=np.float64), out.shape[:1])
        out[:, base + _SWEEP] = wrap_normalised(out[:, base + _SWEEP] - d, 180.0)
        out[:, base + _PITCH] = wrap_normalised(out[:, base + _PITCH] - d, 180.0)
        harmonic = out[:, base + HARMONIC_INDEX]
        out[:, base + _ELEVATION] = wrap_normalised(out[:, base + _ELEVATION] - harmonic * d, 180.0)
    return out


def canonicalise(physical: np.ndarray, n_time: int, *, pairs_independent: bool) -> np.ndarray:
    """The strokes (B, 28) [Table 4 units] made canonical (docs/training.md, "Amortised
    policy", step 1); ``pairs_independent``: the model is not phase-resolved, so the hind pair is
    delayed on its own, else by the fore pair's delay."""
    strokes = np.array(physical, dtype=np.float64, ndmin=2)
    step = 360.0 / int(n_time)

    def steps(phase: np.ndarray) -> np.ndarray:
        return np.round(wrap_normalised(phase - CANONICAL_SWEEP_PHASE, 180.0) / step) * step

    fore = steps(strokes[:, _SWEEP])
    hind = steps(strokes[:, N_PER_WING + _SWEEP]) if pairs_independent else fore
    return delay(strokes, fore, hind)


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
        for name in ("conditions", "strokes", "objectives"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=np.float64))
        conditions, strokes, objectives = self.conditions, self.strokes, self.objectives
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


def reference_targets(series: Any, n_time: int, *, pairs_independent: bool) -> Targets:
    """The canonical optima of a reference series at its env's training conditions only
    (``training_conditions``; the held-out ones are never read)."""
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
def radial_features(count: int) -> Any:
    """Fixed Gaussian bumps ``exp(−((x − μ_k)/σ)²/2)`` of the observation x ∈ [-1, 1] at
    ``count`` centres μ_k evenly over [-1, 1], σ their spacing (a torch module), so that a step
    for one condition moves mostly the strokes near it."""

    class RadialFeatures(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.register_buffer("centres", torch.linspace(-1.0, 1.0, count, dtype=torch.float64))
            self.width = 2.0 / max(1, count - 1)

        def forward(self, x: Any) -> Any:
            return torch.exp(-0.5 * ((x - self.centres) / self.width) ** 2)

    return RadialFeatures()


def build_networks(hidden: Sequence[int], features: int, branches: int) -> Any:
    """The policy's network (a ``torch.nn.ModuleList``; its ``state_dict`` is the weights file):
    per branch an MLP 1 -> (``features`` > 0: :func:`radial_features`) -> hidden (tanh) -> 26
    (linear: z, the output u = tanh z is taken by :class:`AmortisedPolicy`), float64."""

    def mlp() -> Any:
        layers: list[Any] = [radial_features(features)] if features else []
        width = features or 1
        for h in hidden:
            layers += [torch.nn.Linear(width, h), torch.nn.Tanh()]
            width = h
        return torch.nn.Sequential(*layers, torch.nn.Linear(width, len(CONTINUOUS))).double()

    return torch.nn.ModuleList([mlp() for _ in range(branches)])


@dataclass(frozen=True, eq=False)
class AmortisedPolicy(RunPolicy):
    """A trained amortised policy: the network and what its forward pass needs besides."""

    network: Any
    """The branches' torch MLPs (a ``ModuleList``; input (B, 1) -> z (B, 26), u = tanh z)."""
    env_id: str
    env_kwargs: Mapping[str, Any]
    centres: np.ndarray
    """(26,) each output's centre [normalised]: 0 but for the phases (docs/training.md)."""
    switches: np.ndarray
    """(n_branches - 1,) increasing conditions [the condition's unit] where one branch hands
    over to the next: branch b serves ``switches[b-1] <= c < switches[b]``."""
    harmonics: np.ndarray
    """(n_branches, 2) each branch's N coordinates (-0.5 for N = 1, 0.5 for N = 2)."""
    domains: np.ndarray
    """(n_branches, 2) the conditions each branch was trained over [the condition's unit]:
    its network's input range (:meth:`inputs`)."""
    run_dir: Path | None = None
    num_timesteps: int = 0
    """Strokes evaluated in training (the fine-tuning's model evaluations)."""
    algo: str = AMORTISED

    # --- forward pass ---------------------------------------------------------------------
    def inputs(self, conditions: np.ndarray, branches: np.ndarray) -> np.ndarray:
        """(n, 1) each condition as its branch's network reads it: mapped from the branch's
        domain to [-1, 1] (clipped), so every branch has its whole input range over the
        conditions it learns, however narrow [-]."""
        values = np.asarray(conditions, dtype=np.float64).reshape(-1)
        low, high = self.domains[np.asarray(branches).reshape(-1)].T
        scaled = 2.0 * (values - low) / np.maximum(high - low, 1e-12) - 1.0
        return np.clip(scaled, -1.0, 1.0)[:, None]

    @property
    def n_branches(self) -> int:
        return len(self.network)

    def branch_at(self, conditions: np.ndarray) -> np.ndarray:
        """(n,) the branch whose span (between its ``switches``) holds each condition."""
        return np.searchsorted(self.switches, np.asarray(conditions, dtype=np.float64), "right")

    def pre_activations(self, conditions: np.ndarray, branches: np.ndarray) -> Any:
        """(n, 26) z of each condition's branch (u = tanh z), differentiable."""
        chosen = np.asarray(branches).reshape(-1)
        obs = torch.as_tensor(self.inputs(conditions, chosen), dtype=torch.float64)
        z = torch.zeros((obs.shape[0], len(CONTINUOUS)), dtype=torch.float64)
        for b in np.unique(chosen):
            rows = torch.as_tensor(np.flatnonzero(chosen == b))
            z = z.index_put((rows,), self.network[int(b)](obs[rows]))
        return z

    def forward(self, conditions: np.ndarray, branches: np.ndarray | None = None) -> Any:
        """(n, 28) normalised strokes as a float64 tensor, differentiable w.r.t. the weights:
        each condition's stroke from its branch (``branches``, default :meth:`branch_at`)."""
        values = np.asarray(conditions, dtype=np.float64).reshape(-1)
        chosen = self.branch_at(values) if branches is None else np.asarray(branches).reshape(-1)
        return self.assemble(torch.tanh(self.pre_activations(values, chosen)), chosen)

    def assemble(self, u: Any, branches: np.ndarray) -> Any:
        """(n, 28) strokes from the tanh outputs ``u`` (n, 26) of the ``branches`` (n,)."""
        centres = torch.as_tensor(self.centres, dtype=torch.float64)
        phase = torch.as_tensor(_OUTPUT_PHASES, dtype=torch.bool)
        shifted = torch.remainder(u + centres + 1.0, 2.0) - 1.0
        out = torch.zeros((u.shape[0], N_PARAMETERS), dtype=torch.float64)
        out[:, list(CONTINUOUS)] = torch.where(phase, shifted, u)
        out[:, list(HARMONICS)] = torch.as_tensor(self.harmonics[np.asarray(branches)])
        return out

    def strokes(self, conditions: Sequence[float], branches: Any = None) -> np.ndarray:
        """The normalised strokes (n, 28) in [-1, 1] at ``conditions`` (one forward pass, no
        gradient) of the given ``branches`` (default: each condition's, :meth:`branch_at`)."""
        values = np.asarray([float(c) for c in conditions], dtype=np.float64)
        if values.size == 0:
            raise ValueError("conditions is empty; allowed: one or more conditions")
        if not np.all(np.isfinite(values)):
            raise ValueError(f"conditions = {list(values)!r}; allowed: finite numbers")
        with torch.no_grad():
            return np.clip(self.forward(values, branches).numpy(), -1.0, 1.0)

    # --- what the harness and the envelope read ---------------------------------------------
    @property
    def model_path(self) -> Path:
        return RunLayout(self.run_dir or Path("."), self.env_id).weights

    @property
    def training_conditions(self) -> tuple[float, float]:
        """The range of conditions it was trained over [the condition's unit]: the first
        branch's start to the last one's end (the first and last training conditions)."""
        return float(self.domains[0, 0]), float(self.domains[-1, 1])

    def policy_data(self) -> dict[str, Any]:
        """``policy.json``'s content (the weights are beside it)."""
        return {
            "format": POLICY_FORMAT,
            "env_id": self.env_id,
            "env_kwargs": to_jsonable(dict(self.env_kwargs)),
            "hidden": [m.out_features for m in self.network[0] if hasattr(m, "out_features")][:-1],
            "features": len(getattr(self.network[0][0], "centres", ())),
            **{name: getattr(self, name).tolist() for name in _ARRAYS},
            "num_timesteps": int(self.num_timesteps),
            "continuous": list(CONTINUOUS),
            "phases": list(PHASES),
            "canonical_sweep_phase": CANONICAL_SWEEP_PHASE,
        }


def output_centres(targets: Targets, *, pairs_independent: bool) -> np.ndarray:
    """(26,) output centres: the circular mean of the targets' phase (the canonical value for
    the sweep phases :func:`canonicalise` set, as ``pairs_independent``), 0 for the other
    coordinates."""
    canonical = (_SWEEP, N_PER_WING + _SWEEP) if pairs_independent else (_SWEEP,)
    centres = np.zeros(len(CONTINUOUS))
    for k, j in enumerate(CONTINUOUS):
        if j in canonical:
            centres[k] = CANONICAL_SWEEP_PHASE / 180.0
        elif j in PHASES:
            angle = np.pi * targets.strokes[:, j]
            centres[k] = math.atan2(np.sin(angle).mean(), np.cos(angle).mean()) / np.pi
    return centres


def regression_outputs(strokes: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """(K, 26) what the tanh outputs are fitted to for normalised ``strokes`` (K, 28): each
    continuous coordinate, its phases relative to their centres (wrapped), all within
    :data:`TARGET_LIMIT`."""
    u = np.asarray(strokes, dtype=np.float64)[:, list(CONTINUOUS)].copy()
    u[:, _OUTPUT_PHASES] = wrap_normalised(u[:, _OUTPUT_PHASES] - centres[_OUTPUT_PHASES])
    return np.clip(u, -TARGET_LIMIT, TARGET_LIMIT)


def _refuse(path: Path, what: str) -> ValueError:
    return ValueError(
        f"{path}: {what}; it is not loaded (not as python -m train --algo amortised wrote it: "
        "damaged or edited; train the run again, minutes)"
    )


def _policy_fields(path: Path, data: Any, env_id: str) -> dict[str, Any]:
    """``policy.json``'s ``data`` checked before anything is built (sizes within
    :class:`Settings`' limits, arrays finite and consistent, domains and hand-overs inside the
    reference grid); ValueError naming ``path`` otherwise."""
    if not isinstance(data, dict) or data.get("format") != POLICY_FORMAT:
        raise ValueError(
            f"{path}: format {data.get('format') if isinstance(data, dict) else None!r}; "
            f"allowed: {POLICY_FORMAT!r} (a run of an earlier version: train it again, "
            "python -m train --algo amortised, minutes)"
        )
    needed = ("env_id", "env_kwargs", "hidden", "features", "num_timesteps", *_ARRAYS)
    missing = [key for key in needed if key not in data]
    if missing:
        raise _refuse(path, f"no {', '.join(missing)}")
    if data["env_id"] != env_id:
        raise _refuse(path, f"env_id = {data['env_id']!r}, but its args.yml says {env_id!r}")
    try:
        sizes = Settings(hidden=data["hidden"], features=data["features"])
        steps = count(data["num_timesteps"], "num_timesteps", low=0)
        if not isinstance(data["env_kwargs"], dict):
            raise ValueError(f"env_kwargs = {data['env_kwargs']!r}; allowed: a mapping")
        config_class(env_id).from_kwargs(**data["env_kwargs"])  # its names, types and ranges
        arrays = {name: real_array(data[name], name, "numbers") for name in _ARRAYS}
    except (TypeError, ValueError) as error:
        raise _refuse(path, str(error)) from None
    centres, switches, domains, harmonics = (arrays[name] for name in _ARRAYS)
    n = harmonics.shape[0] if harmonics.ndim else 0
    most = len(training_conditions(env_id))
    shapes = [(len(CONTINUOUS),), (n - 1,), (n, 2), (n, 2)]
    if not 1 <= n <= most or [a.shape for a in arrays.values()] != shapes:
        raise _refuse(
            path,
            f"centres, switches, domains and harmonics of shapes "
            f"{[a.shape for a in arrays.values()]}; allowed: (26,), (n-1,), (n, 2), (n, 2) for "
            f"n from 1 to {most} branches",
        )
    grid = REFERENCE_GRID[env_id][1]
    checks = (
        ("not finite", not all(np.all(np.isfinite(a)) for a in arrays.values())),
        ("centres outside [-1, 1]", np.any(np.abs(centres) > 1.0)),
        ("harmonics other than -0.5 (N = 1) and 0.5 (N = 2)", np.any(np.abs(harmonics) != 0.5)),
        (
            f"domains not increasing ranges inside the grid's {grid[0]:g} to {grid[-1]:g}",
            np.any(domains[:, 0] >= domains[:, 1])
            or np.any(np.diff(domains, axis=0) <= 0)
            or domains.min() < grid[0] - 1e-9
            or domains.max() > grid[-1] + 1e-9,
        ),
        (
            "switches not increasing inside both neighbouring branches' domains",
            np.any(switches < domains[1:, 0]) or np.any(switches > domains[:-1, 1]),
        ),
    )
    for what, wrong in checks:
        if wrong:
            raise _refuse(path, f"its arrays are {what}")
    return {**arrays, "sizes": sizes, "num_timesteps": steps, "env_kwargs": data["env_kwargs"]}


def load_policy(run_dir: str | Path) -> AmortisedPolicy:
    """The policy of an amortised run folder (or of the latest run it names), every file checked
    before the network is built (the weights: a state_dict ``torch.load(weights_only=True)``
    reads, of the network's names and shapes, finite); ValueError naming the file at fault."""
    layout, args = read_run_folder(run_dir, "a folder written by python -m train --algo amortised")
    folder, env_id = layout.run_dir, layout.env_id
    if args.get("algo") != AMORTISED:
        raise ValueError(
            f"{layout.args_file}: algo = {args.get('algo')!r}; allowed: {AMORTISED!r}, the run "
            f"of python -m train --algo amortised (its {POLICY_FILE} and weights) that this loads"
        )
    if env_id not in REFERENCE_GRID:
        allowed = f"an env an amortised policy is trained for, {', '.join(REFERENCE_GRID)}"
        raise refusal(f"{layout.args_file}: env", env_id, allowed)
    path = layout.policy_file
    if not path.is_file():
        raise ValueError(f"{folder}: no {POLICY_FILE} (did the run finish?)")
    try:
        data = read_json(path)
    except (OSError, ValueError) as error:
        raise _refuse(path, f"not readable JSON ({error})") from None
    fields_ = _policy_fields(path, data, env_id)
    weights = layout.weights
    if not weights.is_file():
        raise ValueError(f"{folder}: no weights file {weights.name} (did the run finish?)")
    sizes, n = fields_.pop("sizes"), len(fields_["harmonics"])
    with torch.device("meta"):  # the names and shapes only: nothing is allocated
        skeleton = build_networks(sizes.hidden, sizes.features, n)
    try:
        state = torch.load(weights, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, RuntimeError, EOFError, OSError, ValueError) as error:
        raise _refuse(
            weights,
            f"not a state_dict that torch.load(weights_only=True) reads ({type(error).__name__}; "
            "damaged or tampered), nothing in it was run",
        ) from None
    shapes = {k: tuple(v.shape) for k, v in getattr(state, "items", dict)() if torch.is_tensor(v)}
    expected = {k: tuple(v.shape) for k, v in skeleton.state_dict().items()}
    if not isinstance(state, dict) or len(shapes) != len(state) or shapes != expected:
        raise _refuse(weights, f"its tensors do not match the network {POLICY_FILE} describes")
    if not all(bool(torch.isfinite(v).all()) for v in state.values()):
        raise _refuse(weights, "weights that are not finite")
    network = build_networks(sizes.hidden, sizes.features, n)
    network.load_state_dict(state)
    return AmortisedPolicy(network=network.eval(), env_id=env_id, run_dir=folder, **fields_)
