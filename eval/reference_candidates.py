"""Strokes of other runs competing for the reference table's points (``python -m eval reference
--candidates``, docs/reference.md, "Strokes other methods find")."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

import tandem_env
from agents import verify
from agents.harness import PreparedJob
from agents.records import Record
from tandem_env.envs.reference import config_fingerprint, problem_fingerprint
from tandem_env.envs.registration import config_class

PointKey = tuple[str, str, str, float]
"""(env id, objective, planform, condition) of a grid point (:data:`eval.reference.PointKey`)."""


def candidates(
    records: Iterable[Record], jobs: Mapping[PointKey, Sequence[PreparedJob]]
) -> dict[PointKey, list[Record]]:
    """Strokes found by other runs (any method: a policy's, a study's), per grid point they
    compete for: a feasible record of the table's env at a grid condition, of the problem of
    one of the table's series there (its fingerprint: the same model, insect and planform),
    competes for every objective of that planform. It must be this model's (its revision,
    :attr:`~agents.records.Record.model`), its stroke must replay, through the env,
    to its record (:func:`agents.verify.refuted`, as every reused record does) and fly; any
    other record is refused (ValueError)."""
    fingerprints = {
        key: problem_fingerprint(
            config_class(key[0]).from_kwargs(**dict(prepared[0].job.env_kwargs))
        )
        for key, prepared in jobs.items()
    }
    kept: dict[PointKey, list[Record]] = {}
    revision = tandem_env.physics.MODEL_REVISION
    for record in records:
        env_id, condition = record.env_id, record.job.condition
        mine = config_fingerprint(config_class(env_id), record.results["env"])
        keys = [k for k in jobs if (k[0], k[3]) == (env_id, condition) and fingerprints[k] == mine]
        why = (
            f"it was made by model revision {record.model}, not this model's {revision} "
            "(tandem_env.physics.MODEL_REVISION): rerun it"
            if record.model != revision
            else "it does not fly"
            if not record.feasible
            else f"no series of the table at {env_id} {condition:g} with its model and insect"
            if not keys
            else None
        )
        if why is None and (
            refuted := verify.refuted({record.key: record}, {record.key: record.job})
        ):
            why = f"its stroke does not replay to its record ({refuted[record.key]})"
        if why is not None:
            raise ValueError(
                f"candidate record {record.key} ({record.job.label()}): {why}; allowed: a "
                "feasible record of the table's env and model at a grid condition"
            )
        for key in keys:
            kept.setdefault(key, []).append(record)
    return kept
