"""An amortised stroke policy (:mod:`train.amortised_policy`) trained: one network per branch from
the flight condition to a stroke (Amos 2023, "Tutorial on amortized optimization", Found. Trends
Mach. Learn. 16(5)); ``python -m train --algo amortised --env ID`` runs :func:`train_run`. The
method ((a) branches, (b) regression, (c) fine-tuning, (d) hand-overs), its settings, refusals
and results: docs/training.md, "Amortised policy".
"""

from __future__ import annotations

import contextlib
import itertools
import math
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from tandem_env.envs.reference import REFERENCE_GRID, problem_fingerprint, training_conditions
from tandem_env.envs.registration import check_env_id, config_class
from tandem_env.io.files import atomic_path, to_jsonable, write_json_atomic
from train.amortised_policy import (
    HARMONICS,
    PHASE_MASK,
    AmortisedPolicy,
    Settings,
    Targets,
    build_networks,
    output_centres,
    reference_targets,
    regression_outputs,
    wrap_normalised,
)
from train.config import AMORTISED, TrainConfig
from train.run import torch_threads
from train.run_folder import RunFolder


# --- the problem and its reference -------------------------------------------------------------
def check_env_kwargs(env_id: str, env_kwargs: Mapping[str, Any]) -> Any:
    """The reference series the env of ``env_id`` with ``env_kwargs`` is trained on
    (:func:`table_series`); ValueError for a condition keyword (the policy's input)."""
    series = table_series(env_id, env_kwargs)
    declared = config_class(env_id).CONDITION
    condition_words = (declared.keyword, declared.range_keyword, declared.envelope_keyword)
    given = sorted(set(env_kwargs) & set(condition_words))
    if given:
        raise ValueError(
            f"env_kwargs {given}: the condition is the amortised policy's input, set per "
            f"stroke; allowed: none of {', '.join(condition_words)}"
        )
    return series


def table_series(env_id: str, env_kwargs: Mapping[str, Any]) -> Any:
    """The reference series that scores the env of ``env_id`` with ``env_kwargs`` (its problem
    fingerprint's); ValueError naming what is allowed where the table has none (no table, no
    such series, env options that change the problem). Nothing is evaluated."""
    from tandem_env.envs.reference import load_reference_table, reference_path  # at each call

    check_env_id(env_id, "env")
    if env_id not in REFERENCE_GRID:
        raise ValueError(
            f"env = {env_id!r} has no reference table; allowed: "
            f"{', '.join(map(repr, REFERENCE_GRID))}"
        )
    config_type = config_class(env_id)
    config = config_type.from_kwargs(**dict(env_kwargs))
    objective = config_type.OBJECTIVES.choice(config)
    try:
        table = load_reference_table()
    except FileNotFoundError:
        raise ValueError(
            f"the reference table {reference_path()} is missing; an amortised policy is "
            "trained on it and the tuner scores against it. Allowed: make it with python -m "
            "eval reference"
        ) from None
    planform = config.planform
    series = table.find(env_id, str(objective), problem_fingerprint(config))
    if series is not None:
        return series
    # which is it: a series the table lacks, or options that change the problem?
    table.get(env_id, str(objective), planform)  # raises naming what the table holds
    keyword = config_type.OBJECTIVES.keyword
    default = config_type.from_kwargs(
        planform=planform, **({} if keyword is None else {keyword: objective})
    )
    declared = config_type.CONDITION
    kept = ("penalty", "backend", "device", declared.keyword, declared.range_keyword)
    base = to_jsonable(default)
    changed = sorted(
        k for k, v in to_jsonable(config).items() if base.get(k) != v and k not in kept
    )
    raise ValueError(
        f"env_kwargs {dict(env_kwargs)!r} change the problem the reference table describes "
        f"(differing from the default: {', '.join(changed) or 'the model'}); allowed: the default "
        "model options, insect and tolerances, with planform ('tear-drop' or 'real'), the "
        "objective, penalty_weight, penalty_offset, backend and device (and the condition's "
        "keywords, where the command takes them)"
    )


def make_problem(env_id: str, env_kwargs: Mapping[str, Any], **options: Any) -> Any:
    """The env's problem view (``FlightProblem``) with ``env_kwargs`` and model ``options``
    (e.g. ``n_time``) over them."""
    env = gym.make(env_id, disable_env_checker=True, **{**dict(env_kwargs), **options})
    try:
        return env.unwrapped.problem()
    finally:
        env.close()


# --- the branches (steps (a), (b) and (d); docs/training.md, steps 2, 3 and 5) -----------
#: Strokes interpolated between two neighbouring optima of a branch for its regression [-].
INTERPOLATED = 3
#: Conditions per gap between two branches on which their hand-over is chosen [-].
SWITCH_SAMPLES = 17


def between(first: np.ndarray, second: np.ndarray, fraction: Any = 0.5) -> np.ndarray:
    """The normalised strokes ``fraction`` of the way from ``first`` to ``second`` (B, 28):
    each phase the short way round the circle, the N coordinates the first's."""
    step = np.where(PHASE_MASK, wrap_normalised(second - first), second - first)
    middle = np.where(PHASE_MASK, wrap_normalised(first + fraction * step), first + fraction * step)
    middle[..., list(HARMONICS)] = first[..., list(HARMONICS)]
    return np.clip(middle, -1.0, 1.0)


def branch_segments(problem: Any, targets: Targets, tolerance: float) -> list[tuple[int, int]]:
    """The training conditions split into branches ``[(first, stop), ...]`` (index ranges) by
    the rule of docs/training.md (``tolerance``: ``branch_tolerance``, the midway stroke by
    :func:`between`); no held-out optimum is read."""
    k = targets.conditions.size
    if k == 1:
        return [(0, 1)]
    first, second = targets.strokes[:-1], targets.strokes[1:]
    found = problem.evaluate(
        between(first, second), 0.5 * (targets.conditions[:-1] + targets.conditions[1:])
    )
    expected = 0.5 * (targets.objectives[:-1] + targets.objectives[1:])
    joined = (
        np.all(first[:, list(HARMONICS)] == second[:, list(HARMONICS)], axis=1)
        & (found.objective >= expected - tolerance * np.abs(expected))
        & (np.min(found.margins, axis=1) >= -tolerance)
    )
    cuts = [0, *(int(i) + 1 for i in np.flatnonzero(~joined)), k]
    return list(itertools.pairwise(cuts))


def branch_domains(
    conditions: np.ndarray, segments: list[tuple[int, int]], reach: float
) -> np.ndarray:
    """(n_branches, 2) the conditions each branch learns over [the condition's unit]
    (docs/training.md, step 2; ``reach``: ``branch_reach``)."""
    c = np.asarray(conditions, dtype=np.float64)
    first = np.array([a for a, _ in segments], dtype=np.intp)
    last = np.array([b - 1 for _, b in segments], dtype=np.intp)
    low = c[first] - reach * (c[first] - c[np.maximum(first - 1, 0)])
    high = c[last] + reach * (c[np.minimum(last + 1, c.size - 1)] - c[last])
    return np.stack([low, high], axis=1)


def regression_points(
    targets: Targets, segments: list[tuple[int, int]], domains: np.ndarray, centres: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What each branch's regression fits (conditions (n,), branches (n,), atanh of the tanh
    outputs (n, 26)): its optima, the :data:`INTERPOLATED` strokes between each two neighbours
    (within a basin they fly nearly as well), and its end optima at its domain's ends (a branch
    of one training condition starts flat over its domain)."""
    conditions = targets.conditions
    goal = np.arctanh(regression_outputs(targets.strokes, centres))
    owner = [np.full(b - a, i) for i, (a, b) in enumerate(segments)]
    at, of, goals = [conditions], owner, [goal]
    fractions = np.arange(1, INTERPOLATED + 1) / (INTERPOLATED + 1)
    for i, ((a, b), (low, high)) in enumerate(zip(segments, domains, strict=True)):
        for j in range(a, b - 1):
            pair = targets.strokes[j : j + 2]
            strokes = between(pair[:1], pair[1:], fractions[:, None])  # (fractions, 28)
            at.append(conditions[j] + fractions * (conditions[j + 1] - conditions[j]))
            of.append(np.full(fractions.size, i))
            goals.append(np.arctanh(regression_outputs(strokes, centres)))
        for end, index in ((low, a), (high, b - 1)):
            if end != conditions[index]:
                at.append(np.array([end]))
                of.append(np.array([i]))
                goals.append(goal[index : index + 1])
    return np.concatenate(at), np.concatenate(of), np.concatenate(goals)


def hand_overs(policy: AmortisedPolicy, problem: Any, penalty_weight: float) -> np.ndarray:
    """Where each branch hands over to the next: in the overlap of their domains, the cut that
    maximises the two branches' summed penalised objective (objective − w·Σ max(0, −margin),
    the env's reward) over :data:`SWITCH_SAMPLES` conditions there."""
    switches = []
    for branch in range(policy.n_branches - 1):
        grid = np.linspace(policy.domains[branch + 1, 0], policy.domains[branch, 1], SWITCH_SAMPLES)
        both = np.concatenate([grid, grid])
        found = problem.evaluate(
            policy.strokes(both, np.repeat([branch, branch + 1], grid.size)), both
        )
        value = found.objective - penalty_weight * np.sum(np.maximum(0.0, -found.margins), axis=1)
        own, next_ = value[: grid.size], value[grid.size :]
        cut = 1 + int(np.argmax([own[:k].sum() + next_[k:].sum() for k in range(1, grid.size)]))
        switches.append(0.5 * (grid[cut - 1] + grid[cut]))
    return np.asarray(switches, dtype=np.float64)


# --- training ---------------------------------------------------------------------------------
@dataclass
class Training:
    """What :func:`train_policy` hands back besides the policy."""

    regression_loss: float = math.nan
    regression_seconds: float = 0.0
    finetune_seconds: float = 0.0
    branches: list[dict[str, Any]] = field(default_factory=list)
    """Per branch: its training conditions, its domain and where it hands over."""
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
    """Train an amortised policy on ``targets`` (docs/training.md, "Amortised policy");
    ``progress(step, total, row)`` is called after each fine-tuning step."""
    resolution = {"n_time": settings.finetune_n_time, "n_blade": settings.finetune_n_blade}
    problem = make_problem(
        env_id, env_kwargs, **{k: v for k, v in resolution.items() if v is not None}
    )
    independent = not problem.config.options.phase_resolved()
    centres = output_centres(targets, pairs_independent=independent)
    conditions = targets.conditions
    segments = branch_segments(problem, targets, settings.branch_tolerance)
    domains = branch_domains(conditions, segments, settings.branch_reach)
    record = Training()
    # one torch thread, and the seed: both restored afterwards
    with torch_threads(1), torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        network = build_networks(settings.hidden, settings.features, len(segments))
        policy = AmortisedPolicy(
            network=network,
            env_id=env_id,
            env_kwargs=dict(env_kwargs),
            centres=centres,
            switches=np.full(len(segments) - 1, np.nan),
            harmonics=np.where(
                targets.strokes[[a for a, _ in segments]][:, list(HARMONICS)] < 0, -0.5, 0.5
            ),
            domains=domains,
        )
        fit_at, fit_of, fit_goals = regression_points(targets, segments, domains, centres)
        fit_goal = torch.as_tensor(fit_goals)

        def fit_loss(count: int | None = None) -> Any:
            # z's mean squared error on the first count points (the training optima come first)
            z = policy.pre_activations(fit_at[:count], fit_of[:count])
            return torch.mean((z - fit_goal[:count]) ** 2)

        start = time.perf_counter()
        optimiser = torch.optim.Adam(network.parameters(), lr=settings.regression_lr)
        for _ in range(settings.regression_steps):
            optimiser.zero_grad()
            fit_loss().backward()
            optimiser.step()
        with torch.no_grad():
            record.regression_loss = float(fit_loss(conditions.size))
        record.regression_seconds = time.perf_counter() - start

        start = time.perf_counter()
        rng = np.random.default_rng(seed)
        optimiser = torch.optim.Adam(network.parameters(), lr=settings.finetune_lr)
        schedule = torch.optim.lr_scheduler.CosineAnnealingLR(
            optimiser, max(1, settings.finetune_steps)
        )
        evaluated = 0
        strata = np.arange(settings.batch) / settings.batch
        branch_of = np.repeat(np.arange(len(segments)), settings.batch)
        lows = np.repeat([low for low, _ in domains], settings.batch)
        spans = np.repeat([high - low for low, high in domains], settings.batch)
        for step in range(settings.finetune_steps):
            # uniform over each branch's domain, one draw in each of batch equal strata
            draws = np.tile(strata, len(segments)) + rng.uniform(
                0.0, 1.0 / settings.batch, branch_of.size
            )
            sampled = lows + spans * draws
            ref = np.interp(sampled, conditions, targets.objectives)
            optimiser.zero_grad()
            actions = policy.forward(sampled, branch_of)
            found = problem.differentiate(actions.detach().numpy(), sampled)
            evaluated += sampled.size
            margins = found.evaluation.margins
            short = margins < settings.safety_margin
            value = found.evaluation.objective - settings.penalty_weight * np.sum(
                np.where(short, settings.safety_margin - margins, 0.0), axis=1
            )
            d_value = found.objective_gradient + settings.penalty_weight * np.einsum(
                "bm,bmj->bj", short.astype(np.float64), found.margin_jacobian
            )
            actions.backward(torch.as_tensor(-d_value / (ref * settings.batch)[:, None]))
            anchor = 0.0
            if settings.anchor > 0:
                term = settings.anchor * fit_loss(conditions.size)
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
    policy = replace(
        policy,
        num_timesteps=evaluated,
        switches=hand_overs(policy, problem, settings.penalty_weight),
    )
    # each branch serves from one edge to the next: the first condition, the hand-overs, the last
    edges = [float(conditions[0]), *map(float, policy.switches), float(conditions[-1])]
    record.branches = [
        {
            "training_conditions": conditions[a:b].tolist(),
            "domain": [float(low), float(high)],
            "serves_from": edges[i],
            "serves_to": edges[i + 1],
            "N": [1 if n < 0 else 2 for n in policy.harmonics[i]],
        }
        for i, ((a, b), (low, high)) in enumerate(zip(segments, domains, strict=True))
    ]
    return policy, record


# --- the command's trainer ---------------------------------------------------------------------
@dataclass(frozen=True)
class RunResult:
    """What ``python -m train --algo amortised`` prints."""

    run_dir: Path
    summary: Mapping[str, Any]


def train_run(config: TrainConfig) -> RunResult:
    """``python -m train --algo amortised``: train on the reference table's training optima,
    write the run folder (``result.json`` last) and evaluate the final policy at the training
    conditions for the summary."""
    from agents.records import package_versions
    from tandem_env.envs.reference import load_reference_table

    env_id, env_kwargs, seed = config.env_id, config.env_kwargs, config.seed
    settings = Settings.from_mapping(config.hyperparams)
    series = check_env_kwargs(env_id, env_kwargs)

    def report(step: int, total: int, row: Mapping[str, float]) -> None:
        if config.verbose and (step % 25 == 0 or step == total):
            print(
                f"fine-tuning step {step}/{total}: mean J/ref {row['relative_value']:.4f}, "
                f"feasible {row['feasible']:.2f}",
                flush=True,
            )

    with contextlib.ExitStack() as held:
        # Claimed before the minutes of training: a second command on the same folder is
        # refused now, not left to overwrite this one's files when both finish.
        run = RunFolder.open(config, held)
        problem = make_problem(env_id, env_kwargs)
        n_time = settings.finetune_n_time or problem.config.options.n_time
        targets = reference_targets(
            series, n_time, pairs_independent=not problem.config.options.phase_resolved()
        )
        start = time.perf_counter()
        policy, training = train_policy(
            env_id, env_kwargs, targets, settings, seed, progress=report
        )
        wall = time.perf_counter() - start
        policy = replace(policy, run_dir=run.layout.run_dir)
        # the final policy at the training conditions, at the env's resolution
        conditions = np.asarray(training_conditions(env_id))
        found = problem.evaluate(policy.strokes(conditions), conditions)
        columns = (conditions, found.objective, found.feasible, targets.objectives)
        table = load_reference_table()
        summary = {
            "algo": AMORTISED,
            "env_id": env_id,
            "seed": seed,
            "wall_time": wall,
            **asdict(training),  # the losses, seconds, branches and fine-tuning history
            "num_timesteps": policy.num_timesteps,
            "series": {
                key: getattr(series, key) for key in ("objective", "planform", "fingerprint")
            },
            "reference_provenance": to_jsonable(dict(table.provenance)),
            "training_evaluation": [
                dict(zip(("condition", "objective", "feasible", "reference"), row, strict=True))
                for row in zip(*(np.asarray(c).tolist() for c in columns), strict=True)
            ],
            "versions": package_versions(),
        }
        run.start(to_jsonable(asdict(settings)))  # config.yml
        write_json_atomic(run.layout.policy_file, policy.policy_data())
        with atomic_path(run.layout.weights) as tmp:
            torch.save(policy.network.state_dict(), tmp)
        write_json_atomic(run.layout.result_file, summary)
        return RunResult(run.layout.run_dir, summary)
