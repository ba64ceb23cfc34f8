"""Harness records and the one store they are kept in.

A :class:`Job` is the configuration of one harness run (one method, task, condition, budget and
seed, with its env keywords, method settings and study preset); its :attr:`Job.key` hashes all
of that plus the ``tandem_env`` version and the record format. A :class:`Record` is what the
run found, whichever method ran (PSO, random search, a trained policy), so that ``python -m eval
compare`` and the studies read one format; it carries its job and key.

A :class:`RecordStore` keeps records as ``DIR/records/<key>.json``, each written atomically
(:func:`tandem_env.io.files.write_json_atomic`). Both ``python -m eval optimize`` and the studies
write through it, so a record is found by its configuration: another budget, seed or model
option is another file, a killed run resumes from the records already there, and nothing of
another configuration is overwritten without a warning. The schema with units is documented
in ``docs/harness.md``.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import MISSING, dataclass, field, fields
from importlib import metadata
from pathlib import Path
from typing import Any

import tandem_env
from agents.tasks import Condition, available_tasks, get_task
from tandem_env.io.files import read_json, to_jsonable, write_csv_atomic, write_json_atomic

__all__ = [
    "RECORDS_DIR",
    "SCHEMA",
    "SUMMARY_METRICS",
    "SUMMARY_NAME",
    "Job",
    "Record",
    "RecordStore",
    "RecordWarning",
    "load_records",
    "package_versions",
    "summary_rows",
    "write_summary",
]

#: Identifies record files (and their version) among other JSON files.
SCHEMA = "tandem_env.harness-record/3"
"""Record format; /2 added ``selection`` (records report the best feasible stroke seen), /3
``key`` and ``job`` (the configuration the record is stored under)."""
#: Older formats :meth:`Record.from_dict` still reads (their ``key`` and ``job`` are empty).
READABLE_SCHEMAS = ("tandem_env.harness-record/2",)
#: The record's ``selection``: which of the strokes a search evaluated it reports.
SELECTION_BEST_FEASIBLE = "best feasible stroke seen"
SELECTION_BEST_REWARD = "best reward seen (no feasible stroke)"
SELECTION_METHOD = "the method's stroke"
#: A store's records folder, ``DIR/records``.
RECORDS_DIR = "records"
#: A store's CSV summary over its records, ``DIR/summary.csv``.
SUMMARY_NAME = "summary.csv"

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

# Record key -> distribution name on the package index.
_PACKAGES = {
    "numpy": "numpy",
    "scipy": "scipy",
    "gymnasium": "gymnasium",
    "stable_baselines3": "stable-baselines3",
    "torch": "torch",
    "numba": "numba",
}


class RecordWarning(UserWarning):
    """A stored record that is corrupt, or replaced by a record of another configuration."""


def package_versions() -> dict[str, str]:
    """Versions of the packages that determine results, plus the Python version.

    Keys: numpy, scipy, gymnasium, stable_baselines3, torch, numba, python. A package that is
    not installed is reported as ``"not installed"``.
    """
    versions: dict[str, str] = {}
    for key, distribution in _PACKAGES.items():
        try:
            versions[key] = metadata.version(distribution)
        except metadata.PackageNotFoundError:
            versions[key] = "not installed"
    versions["python"] = platform.python_version()
    return versions


def _pairs(value: Any) -> tuple[tuple[str, Any], ...]:
    # Sorted by name, lists as tuples: the same settings give one Job, whatever their order.
    items = value.items() if isinstance(value, Mapping) else value
    return tuple(sorted((str(k), tuple(v) if isinstance(v, list) else v) for k, v in items))


@dataclass(frozen=True)
class Job:
    """One harness run (one seed) and everything that decides its result."""

    method: str
    """Harness method spec, e.g. ``"pso"``, ``"random"``, ``"policy:runs/ppo"``."""
    task: str
    """Task name, ``"level"`` or ``"accelerate"`` (or a registered task)."""
    condition: float
    """The task's condition in its declared unit, e.g. flight speed [m/s] (level) or available
    power [W/kg] (accelerate)."""
    budget: int
    """Model evaluations."""
    seed: int
    env_kwargs: tuple[tuple[str, Any], ...] = ()
    """Env keywords besides the condition (objective, planform, model options), sorted by name;
    a mapping is accepted."""
    method_config: tuple[tuple[str, Any], ...] = ()
    """Method settings (e.g. ``swarm_size``), sorted by name; a mapping is accepted."""
    preset: str = ""
    """The study preset the job belongs to (part of the key, so presets never share records);
    empty for a run outside the studies (``python -m eval optimize``)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "condition", float(self.condition))
        object.__setattr__(self, "budget", int(self.budget))
        object.__setattr__(self, "seed", int(self.seed))
        object.__setattr__(self, "env_kwargs", _pairs(self.env_kwargs))
        object.__setattr__(self, "method_config", _pairs(self.method_config))

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form (keyword pairs become objects): what a record stores as ``job``."""
        return to_jsonable(
            {
                "method": self.method,
                "task": self.task,
                "condition": self.condition,
                "budget": self.budget,
                "seed": self.seed,
                "env_kwargs": dict(self.env_kwargs),
                "method_config": dict(self.method_config),
                "preset": self.preset,
            }
        )

    @property
    def key(self) -> str:
        """Configuration hash: the job, the tandem_env version and the record format."""
        payload = {**self.to_dict(), "tandem_env": tandem_env.__version__, "record": SCHEMA}
        text = json.dumps(payload, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:20]

    def env(self, name: str, default: Any = None) -> Any:
        """One env keyword (``objective``, ``planform``, ...) or ``default``."""
        return dict(self.env_kwargs).get(name, default)

    def label(self) -> str:
        """Short human label, e.g. ``pso level V=1.5 seed 0``."""
        # The condition's command-line symbol (V, P) from the task's declaration.
        known = self.task in available_tasks()
        symbol = get_task(self.task).condition_metavar if known else "condition"
        extra = [str(v) for k, v in self.env_kwargs if k in ("objective", "planform")]
        return " ".join(
            [self.method, self.task, *extra, f"{symbol}={self.condition:g}", f"seed {self.seed}"]
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
    key: str = ""
    """The job's configuration hash (:attr:`Job.key`): the record's name in a store."""
    job: dict[str, Any] = field(default_factory=dict)
    """The job that produced the record (:meth:`Job.to_dict`)."""
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
        """Plain-JSON form (the file format); schema and key first, then the field order."""
        out: dict[str, Any] = {"schema": self.schema, "key": self.key}
        for f in fields(self):
            if f.name in out:
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
        """Inverse of :meth:`to_dict`; raises ValueError for a non-record or a missing field.

        Records of an older format in :data:`READABLE_SCHEMAS` are read with an empty key and
        job (they are never taken as a job's stored result).
        """
        schema = data.get("schema")
        if schema != SCHEMA and schema not in READABLE_SCHEMAS:
            raise ValueError(f"not a harness record (schema {schema!r}, want {SCHEMA!r})")
        names = {f.name for f in fields(cls)}
        required = {f.name for f in fields(cls) if f.default is MISSING}
        required -= {f.name for f in fields(cls) if f.default_factory is not MISSING}
        missing = sorted(required - set(data))
        if missing:
            raise ValueError(f"record is missing field(s) {missing}")
        kwargs = {name: data[name] for name in names if name in data}
        kwargs["condition"] = Condition(**kwargs["condition"])
        kwargs["schema"] = SCHEMA
        return cls(**kwargs)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Record:
        """Read a record file."""
        return cls.from_dict(read_json(path))

    def label(self) -> str:
        """Short human label, e.g. ``pso level efficiency speed=1.5 seed 0, budget 12000``."""
        c = self.condition
        return (
            f"{self.method} {self.task} {self.objective_name} {c.name}={c.value:g} "
            f"seed {self.seed}, budget {self.budget}"
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
        row["key"] = self.key
        return row

    def best_so_far(self) -> tuple[list[int], list[float]]:
        """The history as (evaluations, best reward so far) lists, e.g. for plotting."""
        return [e for e, _ in self.history], [b for _, b in self.history]


class RecordStore:
    """Records keyed by configuration: ``DIR/records/<key>.json``, written atomically.

    Raises ValueError when ``directory`` (or its ``records``) exists and is not a directory.
    """

    def __init__(self, directory: str | os.PathLike[str]) -> None:
        self.directory = Path(directory)
        for path in (self.directory, self.directory / RECORDS_DIR):
            if path.exists() and not path.is_dir():
                raise ValueError(
                    f"{path} is a file; allowed: a directory for the records (created if missing)"
                )

    def path(self, key: str) -> Path:
        """Where the record with configuration hash ``key`` is stored."""
        return self.directory / RECORDS_DIR / f"{key}.json"

    def load(self, job: Job) -> Record | None:
        """The stored record of ``job``, or None if it has not run with this configuration.

        A file that cannot be read as a record, or that holds another job (a hand-edited file
        or a truncated-hash collision), is reported with a :class:`RecordWarning` and treated
        as missing, so the job runs again and its record replaces the file.
        """
        path = self.path(job.key)
        if not path.exists():
            return None
        try:
            record = Record.load(path)
        except (OSError, ValueError, TypeError, KeyError) as error:
            _warn(f"{path}: corrupt record ({error}); {job.label()} runs again")
            return None
        if record.key != job.key or record.job != job.to_dict():
            _warn(
                f"{path}: holds {record.label()} (job {record.job}), not {job.label()}; "
                "it runs again and its record replaces the file"
            )
            return None
        return record

    def save(self, record: Record) -> Path:
        """Write ``record`` as ``records/<record.key>.json``; returns the path.

        Replacing a valid record of another configuration is reported with a
        :class:`RecordWarning`; replacing the same configuration's record (a rerun) is silent.
        """
        if not record.key:
            raise ValueError(
                f"{record.label()} has no key; allowed: records made by the harness "
                "(agents.harness.run_seed), which carry their job and key"
            )
        path = self.path(record.key)
        if path.exists():
            try:
                old = Record.load(path)
            except (OSError, ValueError, TypeError, KeyError):
                old = None  # corrupt: already reported by load()
            if old is not None and old.job != record.job:
                _warn(f"{path}: replacing {old.label()} (job {old.job}) by {record.label()}")
        write_json_atomic(path, record.to_dict())
        return path

    def records(self) -> list[Record]:
        """Every readable record in the store, ordered as :func:`summary_rows` orders them."""
        found = []
        for path in sorted((self.directory / RECORDS_DIR).glob("*.json")):
            try:
                found.append(Record.load(path))
            except (OSError, ValueError, TypeError, KeyError) as error:
                _warn(f"{path}: corrupt record ({error}); left out")
        return sorted(found, key=_summary_order)

    def write_summary(self) -> Path:
        """Rewrite ``DIR/summary.csv`` over every record in the store; returns its path."""
        path = self.directory / SUMMARY_NAME
        write_summary(path, self.records())
        return path


def _warn(message: str) -> None:
    warnings.warn(message, RecordWarning, stacklevel=3)


def _summary_order(r: Record) -> tuple[Any, ...]:
    return (r.task, r.objective_name, r.condition.value, r.method, r.budget, r.seed, r.key)


def summary_rows(records: Iterable[Record]) -> list[dict[str, Any]]:
    """CSV rows of ``records``, sorted by task, objective, condition, method, budget and seed."""
    return [r.summary_row() for r in sorted(records, key=_summary_order)]


def write_summary(path: str | os.PathLike[str], records: Sequence[Record]) -> None:
    """Write the CSV summary of ``records`` atomically."""
    write_csv_atomic(path, summary_rows(records))


def load_records(paths: Iterable[str | os.PathLike[str]]) -> list[Record]:
    """Every record in the given files and directories (searched recursively for ``*.json``).

    Finds the records of stores (``DIR/records/*.json``), of study directories and older flat
    files alike. JSON files that are not records (other schema) are skipped; a file claiming
    the record schema but malformed raises ValueError naming it.
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
            schema = data.get("schema") if isinstance(data, dict) else None
            if schema != SCHEMA and schema not in READABLE_SCHEMAS:
                continue
            try:
                records.append(Record.from_dict(data))
            except (TypeError, ValueError) as error:
                raise ValueError(f"{path}: malformed record: {error}") from error
    return records
