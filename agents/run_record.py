"""The record of one harness run (one method, task, condition and seed) and its JSON/CSV forms.

A :class:`Record` is what every method produces, whether PSO, random search or a trained
policy, so that ``python -m eval compare`` and the studies read one format. Records are
written atomically (:func:`agents.records.write_json_atomic`), one JSON file per seed, named
by :meth:`Record.filename`; :func:`summary_rows` flattens them for a CSV table. The schema with
units is documented in ``docs/harness.md``.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import MISSING, dataclass, fields
from pathlib import Path
from typing import Any

from agents.records import read_json, write_csv_atomic, write_json_atomic
from agents.tasks import Condition

__all__ = [
    "SCHEMA",
    "SUMMARY_METRICS",
    "Record",
    "load_records",
    "method_slug",
    "summary_rows",
    "write_summary",
]

#: Identifies record files (and their version) among other JSON files.
SCHEMA = "tandem_env.harness-record/2"
"""Record format; /2 added ``selection`` (records report the best feasible stroke seen)."""
#: The record's ``selection``: which of the strokes a search evaluated it reports.
SELECTION_BEST_FEASIBLE = "best feasible stroke seen"
SELECTION_BEST_REWARD = "best reward seen (no feasible stroke)"
SELECTION_METHOD = "the method's stroke"

#: Metrics copied into the CSV summary when a record has them.
SUMMARY_METRICS: tuple[str, ...] = (
    "efficiency",
    "lift_to_weight",
    "thrust",
    "drag",
    "power",
    "power_per_mass",
    "excess_vertical",
    "excess_horizontal",
    "excess_total",
    "mean_angle_of_attack",
    "constraint_violation",
    "induction_converged",
)


@dataclass(frozen=True)
class Record:
    """One run of one method on one task, condition and seed.

    Every number describing the stroke comes from the final re-evaluation of the best stroke
    (a fresh single-env step), not from the search.
    """

    method: str
    """Method spec, e.g. ``"pso"``, ``"random"``, ``"policy:runs/ppo"``."""
    task: str
    """Task name, ``"level"`` or ``"accelerate"``."""
    env_id: str
    """Gymnasium id of the env the search stepped."""
    objective_name: str
    """The ``info`` metric the task maximises, e.g. ``"efficiency"`` or ``"excess_vertical"``."""
    condition: Condition
    """The flight condition (name, value, unit), e.g. speed 1.5 m/s."""
    seed: int
    """Seed of the method (and of the envs' first reset)."""
    budget: int
    """Allowed model evaluations (= env steps = strokes evaluated)."""
    evaluations: int
    """Model evaluations the search used (<= budget; the re-evaluation is not counted)."""
    objective: float
    """The task's raw objective of the best stroke, re-evaluated: η [-] or F̄ [-]."""
    reward: float
    """The penalised objective of the best stroke, re-evaluated (= objective when feasible)."""
    search_reward: float
    """The reported stroke's reward as seen during the search (equals ``reward``: the model is
    deterministic and bit-identical at any batch size)."""
    feasible: bool
    """Every constraint of the task met at the re-evaluation."""
    stroke: dict[str, float | int]
    """The best stroke, named physical parameters in Table 4 units (Hz, deg, -)."""
    normalised_stroke: tuple[float, ...]
    """The same stroke as the 28 normalised action values in [-1, 1]."""
    metrics: dict[str, Any]
    """Every ``info`` entry of the re-evaluation except the stroke (units: docs/envs.md)."""
    history: tuple[tuple[int, float], ...]
    """(evaluations, best reward so far) after every iteration of the search."""
    wall_time: float
    """Wall-clock time of the run, search plus re-evaluation [s]."""
    config: dict[str, Any]
    """``method`` (its settings and citation), ``env_kwargs`` and ``env`` (the env's full
    configuration: insect, model options incl. ``thrust_split``, penalty)."""
    versions: dict[str, str]
    """Package versions (numpy, gymnasium, torch, ..., python, tandem_env)."""
    selection: str = SELECTION_BEST_FEASIBLE
    """Which stroke is reported: ``"best feasible stroke seen"`` (the highest objective among
    the feasible strokes the search evaluated), ``"best reward seen (no feasible stroke)"``, or
    ``"the method's stroke"`` (methods that evaluate through their own envs, e.g. SB3)."""
    schema: str = SCHEMA
    """Record format identifier."""

    def __post_init__(self) -> None:
        if self.schema != SCHEMA:
            raise ValueError(f"record schema {self.schema!r}; allowed: {SCHEMA!r}")
        if not isinstance(self.condition, Condition):
            raise ValueError(f"condition = {self.condition!r}; allowed: a Condition")
        object.__setattr__(self, "normalised_stroke", tuple(map(float, self.normalised_stroke)))
        object.__setattr__(self, "history", tuple((int(e), float(b)) for e, b in self.history))
        if self.evaluations > self.budget:
            raise ValueError(
                f"record evaluations = {self.evaluations} exceed its budget {self.budget}"
            )

    # --- JSON ------------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form (the file format); key order is the field order, schema first."""
        out: dict[str, Any] = {"schema": self.schema}
        for f in fields(self):
            if f.name == "schema":
                continue
            value = getattr(self, f.name)
            if isinstance(value, Condition):
                value = value.to_dict()
            elif f.name in ("normalised_stroke", "history"):
                value = [list(v) if isinstance(v, tuple) else v for v in value]
            out[f.name] = value
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Record:
        """Inverse of :meth:`to_dict`; raises ValueError for a non-record or a missing field."""
        if data.get("schema") != SCHEMA:
            raise ValueError(
                f"not a harness record (schema {data.get('schema')!r}, want {SCHEMA!r})"
            )
        names = {f.name for f in fields(cls)}
        required = {f.name for f in fields(cls) if f.default is MISSING}
        missing = sorted(required - set(data))
        if missing:
            raise ValueError(f"record is missing field(s) {missing}")
        kwargs = {name: data[name] for name in names if name in data}
        kwargs["condition"] = Condition(**kwargs["condition"])
        return cls(**kwargs)

    def save(self, directory: str | os.PathLike[str]) -> Path:
        """Write the record atomically as ``directory / self.filename()``; returns the path."""
        path = Path(directory) / self.filename()
        write_json_atomic(path, self.to_dict())
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Record:
        """Read a record file."""
        return cls.from_dict(read_json(path))

    def filename(self) -> str:
        """``{method}_{task}_{objective}_{condition}{value}_seed{seed}.json``.

        E.g. ``pso_level_efficiency_speed1.5_seed0.json``.
        """
        value = format(self.condition.value, ".10g")
        return (
            f"{method_slug(self.method)}_{self.task}_{self.objective_name}_"
            f"{self.condition.name}{value}_seed{self.seed}.json"
        )

    # --- tables ------------------------------------------------------------------------------------
    def summary_row(self) -> dict[str, Any]:
        """One flat CSV row: identity, result, headline metrics."""
        row: dict[str, Any] = {
            "method": self.method,
            "task": self.task,
            "objective_name": self.objective_name,
            "condition": self.condition.name,
            "condition_value": self.condition.value,
            "condition_unit": self.condition.unit,
            "seed": self.seed,
            "budget": self.budget,
            "evaluations": self.evaluations,
            "objective": self.objective,
            "reward": self.reward,
            "feasible": self.feasible,
            "wall_time_s": self.wall_time,
        }
        for name in SUMMARY_METRICS:
            if name in self.metrics:
                row[name] = self.metrics[name]
        row["file"] = self.filename()
        return row

    def best_so_far(self) -> tuple[list[int], list[float]]:
        """The history as (evaluations, best reward so far) lists, e.g. for plotting."""
        return [e for e, _ in self.history], [b for _, b in self.history]


def summary_rows(records: Iterable[Record]) -> list[dict[str, Any]]:
    """CSV rows of ``records``, sorted by task, objective, condition, method and seed."""
    ordered = sorted(
        records,
        key=lambda r: (r.task, r.objective_name, r.condition.value, r.method, r.budget, r.seed),
    )
    return [r.summary_row() for r in ordered]


def write_summary(path: str | os.PathLike[str], records: Sequence[Record]) -> None:
    """Write the CSV summary of ``records`` atomically."""
    write_csv_atomic(path, summary_rows(records))


def load_records(paths: Iterable[str | os.PathLike[str]]) -> list[Record]:
    """Every record in the given files and directories (searched recursively for ``*.json``).

    JSON files that are not records (other schema) are skipped; a file claiming the record
    schema but malformed raises ValueError naming it.
    """
    records: list[Record] = []
    for base in map(Path, paths):
        if not base.exists():
            raise ValueError(f"{base}: no such file or directory")
        files = sorted(base.rglob("*.json")) if base.is_dir() else [base]
        for path in files:
            try:
                data = read_json(path)
            except (OSError, ValueError) as error:
                raise ValueError(f"{path}: cannot read JSON: {error}") from error
            if not isinstance(data, dict) or data.get("schema") != SCHEMA:
                continue
            try:
                records.append(Record.from_dict(data))
            except (TypeError, ValueError) as error:
                raise ValueError(f"{path}: malformed record: {error}") from error
    return records


def method_slug(spec: str) -> str:
    """File-name-safe form of a method spec (``"policy:runs/ppo"`` -> ``"policy-runs-ppo"``)."""
    safe = "".join(c if c.isalnum() or c in "._-" else "-" for c in spec)
    return "-".join(part for part in safe.split("-") if part) or "method"
