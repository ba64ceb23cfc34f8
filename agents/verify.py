"""Stored records checked against the physics before they are reused: a checksum tells damage,
not a forged record, so the runner serves no stored record before :func:`refuted` steps its
stroke once more (one vector-env step per task and env configuration) and compares what the
record says (:data:`CHECKED`) with what the stroke gives.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from agents.evaluator import NATIVE_VECTOR_ENV, reevaluate, stepped_results
from agents.harness import PreparedJob
from agents.jobs import Job
from agents.records import Record
from agents.tasks import TaskSpec, get_task

#: The results a record's stroke decides, compared with their re-evaluation.
CHECKED = ("reward", "objective", "feasible", "stroke", "metrics")
#: Metrics the stroke does not decide alone, left out of the comparison: ``score`` reads the
#: objective (which is checked) against the packaged reference table (docs/reference.md), which
#: every regeneration moves; a record keeps the one of its run.
TABLE_RELATIVE = frozenset({"score"})
#: How closely each number must agree: |stored - recomputed| <= ATOL + RTOL |recomputed| (the
#: same backend reproduces a record bit for bit; numba and torch, which share records, agree
#: within 1e-8, docs/harness.md).
RTOL, ATOL = 1e-7, 1e-8
#: The most records re-evaluated in one step (the model takes up to 10 000 strokes a batch).
_BATCH = 1024


def refuted(found: Mapping[str, Record], jobs: Mapping[str, Job | PreparedJob]) -> dict[str, str]:
    """Key -> why, for each record of ``found`` whose results its stroke does not give in the
    env of its job in ``jobs``, or that cannot be re-evaluated."""
    plain = {key: job.job if isinstance(job, PreparedJob) else job for key, job in jobs.items()}
    groups: dict[Any, list[str]] = {}  # task and env keywords -> keys
    for key in found:
        groups.setdefault((plain[key].task, plain[key].env_kwargs), []).append(key)
    why: dict[str, str] = {}
    for keys in (g[i : i + _BATCH] for g in groups.values() for i in range(0, len(g), _BATCH)):
        records = [found[key] for key in keys]
        try:  # a prepared job's task is its spec
            spec = get_task(jobs[keys[0]].task)
            steps = _step(spec, dict(plain[keys[0]].env_kwargs), records)
        except (ValueError, TypeError, IndexError, RuntimeError, gym.error.Error) as error:
            if len(keys) == 1:
                why[keys[0]] = f"it cannot be re-evaluated ({error})"
            else:  # one record's stroke (out of the box, of another length) fails them all
                for key in keys:
                    why.update(refuted({key: found[key]}, {key: jobs[key]}))
            continue
        for key, record, step in zip(keys, records, steps, strict=True):
            if (difference := _difference(_decided(record.results), _decided(step))) is not None:
                why[key] = f"its results are not what its stroke gives: {difference}"
    return why


def _decided(results: Mapping[str, Any]) -> dict[str, Any]:
    """The results of :data:`CHECKED`, their metrics without :data:`TABLE_RELATIVE`."""
    metrics = {k: v for k, v in results["metrics"].items() if k not in TABLE_RELATIVE}
    return {name: results[name] for name in CHECKED} | {"metrics": metrics}


def _step(spec: TaskSpec, kwargs: dict[str, Any], records: Sequence[Record]) -> list[dict]:
    """The stepped results of each record's stroke at its job's condition and seed: one step
    of one vector env where it takes a condition per sub-env, else one single env per record."""
    keyword = spec.declared_condition.keyword
    actions = np.asarray([r.normalised_stroke for r in records], dtype=np.float64)
    env = gym.make_vec(spec.env_id, num_envs=len(records), **NATIVE_VECTOR_ENV, **kwargs)
    with contextlib.closing(env):
        if callable(reset_envs := getattr(env.unwrapped, "reset_envs", None)):
            options = [{keyword: spec.condition(r.job.condition).value} for r in records]
            reset_envs(np.arange(len(records)), [r.job.seed for r in records], options)
            _, rewards, _, _, infos = env.step(actions)
            steps = range(len(records))
            return [stepped_results(rewards[i], _row(infos, i), actions[i]) for i in steps]
    stepped = []  # each stroke re-evaluated as :func:`agents.harness.run_job` evaluated it
    for record, action in zip(records, actions, strict=True):
        condition = spec.condition(record.job.condition)
        made = {**kwargs, condition.name: condition.value}
        with gym.make(spec.env_id, disable_env_checker=True, **made) as env:
            stepped.append(reevaluate(env, spec, condition, record.job.seed, action)[0])
    return stepped


def _row(infos: Mapping[str, Any], i: int) -> dict[str, Any]:
    """Sub-env ``i``'s info from a vector env's info columns (their ``_name`` masks left out)."""
    return {
        name: _row(value, i) if isinstance(value, Mapping) else value[i]
        for name, value in infos.items()
        if not name.startswith("_")
    }


def _difference(stored: Any, recomputed: Any, where: str = "") -> str | None:
    """The first value of ``stored`` that ``recomputed`` does not match (:data:`RTOL`,
    :data:`ATOL`), in words; None if all do."""
    pairs = None  # the entries of two mappings, or of two lists of one length, in turn
    if isinstance(stored, Mapping) and isinstance(recomputed, Mapping):
        if set(stored) != set(recomputed):
            extra = sorted(set(stored) ^ set(recomputed))
            return f"{where or 'results'} differ in their entries {extra}"
        pairs = [(stored[k], recomputed[k], f"{where}.{k}".lstrip(".")) for k in stored]
    if isinstance(stored, list) and isinstance(recomputed, list) and len(stored) == len(recomputed):
        pairs = [(a, recomputed[j], f"{where}[{j}]") for j, a in enumerate(stored)]
    if pairs is not None:
        return next((d for d in (_difference(*pair) for pair in pairs) if d is not None), None)
    if all(isinstance(x, int | float) and not isinstance(x, bool) for x in (stored, recomputed)):
        close = np.isclose(stored, recomputed, rtol=RTOL, atol=ATOL, equal_nan=True)
    else:
        close = type(stored) is type(recomputed) and stored == recomputed
    return None if close else f"{where} = {stored!r}, re-evaluated {recomputed!r}"
