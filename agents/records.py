"""Harness records and the one store they are kept in.

A :class:`Job` is the configuration of one harness run (one method, task, condition, budget and
seed, with its env keywords, method settings and study preset); its :attr:`Job.key` hashes all
of that (but the model's backend and device, which do not change results) plus the
``tandem_env`` version and the record format. A :class:`Record` is what the
run found, whichever method ran (PSO, CMA-ES, random search, a trained policy), so that
``python -m eval compare`` and the studies read one format. It holds three things, each once:
its job, the job's key and one mapping of results (:data:`RESULTS`; a later stage of the run
adds its own key to it), and its file carries a checksum of all three, so a record edited by
hand or damaged is detected.

A :class:`RecordStore` keeps records as ``DIR/records/<key>.json``, each written atomically
(:func:`tandem_env.io.files.write_json_atomic`). The runner (:func:`eval.studies.runner.run_jobs`)
is the one writer: ``python -m eval optimize`` and the studies run their jobs through it, so a
record is found by its configuration: another budget, seed or model option is another file, a
killed run resumes from the records already there, and a file that is not a valid record of
its job (corrupt, edited, of an older format, of another job) is recomputed with a
:class:`RecordWarning`. The schema with units is documented in ``docs/harness.md``.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import re
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

import tandem_env
from agents.tasks import Condition, available_tasks, get_task
from tandem_env.envs.config import EXECUTION_KWARGS, insect_keyword
from tandem_env.io.files import (
    output_directory,
    read_json,
    to_jsonable,
    write_csv_atomic,
    write_json_atomic,
)

__all__ = [
    "OLD_SCHEMAS",
    "RECORDS_DIR",
    "RESULTS",
    "SCHEMA",
    "SUMMARY_METRICS",
    "SUMMARY_NAME",
    "Job",
    "OutdatedRecordError",
    "Record",
    "RecordChecksumError",
    "RecordError",
    "RecordMismatchError",
    "RecordStore",
    "RecordWarning",
    "StoreWriteError",
    "load_records",
    "package_versions",
    "summary_rows",
    "write_summary",
]

#: Identifies record files (and their version) among other JSON files.
SCHEMA = "tandem_env.harness-record/5"
"""Record format; /2 added ``selection`` (records report the best feasible stroke seen), /3
``key`` and ``job``, /4 holds the job, key and results once each plus a checksum, /5 the
results' ``certificate`` (the local polish, ``agents.polish``); a run split into parts
(``starts``, ``initial``) adds the results' ``starts`` (optional: a one-part run's record is
unchanged)."""
#: Earlier formats: recognised, never read as results (their jobs are recomputed).
OLD_SCHEMAS = (
    "tandem_env.harness-record/1",
    "tandem_env.harness-record/2",
    "tandem_env.harness-record/3",
    "tandem_env.harness-record/4",
)
#: The record's ``selection``: which of the strokes a search evaluated it reports.
SELECTION_BEST_FEASIBLE = "best feasible stroke seen"
SELECTION_BEST_REWARD = "best reward seen (no feasible stroke)"
SELECTION_METHOD = "the method's stroke"
SELECTION_POLISHED = "best feasible stroke seen, polished"
SELECTION_INITIAL = "an initial stroke (not improved by the polish)"
SELECTION_INITIAL_POLISHED = "an initial stroke, polished"
#: A store's records folder, ``DIR/records``.
RECORDS_DIR = "records"
#: A store's CSV summary over its records, ``DIR/summary.csv``.
SUMMARY_NAME = "summary.csv"

#: The keys every record's results hold, with their meaning and units (docs/harness.md).
#: Further keys (e.g. a stage run after the search) are kept and checksummed as they are.
RESULTS: dict[str, str] = {
    "env_id": "Gymnasium id of the env the search stepped",
    "objective_name": "the info metric the task maximises, e.g. efficiency or excess_vertical",
    "condition_name": "what the job's condition is, e.g. speed or available_power",
    "condition_unit": "the condition's unit, e.g. m/s or W/kg",
    "evaluations": "model evaluations the search and the polish used (<= budget; the "
    "re-evaluation not counted)",
    "objective": "the task's raw objective of the reported stroke, re-evaluated: eta [-] or F [-]",
    "reward": "the penalised objective of the reported stroke, re-evaluated",
    "search_reward": "the reported stroke's reward as seen during the search (= reward)",
    "feasible": "every constraint of the task met at the re-evaluation",
    "selection": "which stroke is reported (best feasible seen, best reward seen, the method's, "
    "best feasible seen and polished, an initial stroke (polished))",
    "stroke": "the stroke, named physical parameters in Table 4 units (Hz, deg, -)",
    "normalised_stroke": "the same stroke as the 28 normalised action values in [-1, 1]",
    "metrics": "every info entry of the re-evaluation except the stroke (docs/envs.md)",
    "history": "[evaluations, best reward so far] after every iteration of the search",
    "wall_time": "wall-clock time of the run, search plus re-evaluation [s]",
    "method_settings": "the method's settings and citation as it reports them",
    "env": "the env's full configuration (insect, model options, penalty)",
    "versions": "package versions (numpy, gymnasium, torch, ..., python, tandem_env)",
}
#: The results key of the stage after the search: the local polish and the optimality of the
#: reported stroke (:meth:`agents.polish.Certificate.to_dict`); every harness record has it.
CERTIFICATE = "certificate"
#: The results key listing the parts of a run split into several (``starts`` searches,
#: ``initial`` strokes; :mod:`agents.harness`): kind, seed, evaluations, reward, feasible,
#: selection, polish status and gain of each. Absent for a run of one search.
STARTS = "starts"

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


class RecordError(ValueError):
    """Data that is not a valid record: not JSON, not a record, malformed or failing its checksum."""


class RecordChecksumError(RecordError):
    """A record whose checksum does not match its contents (edited by hand or damaged)."""


class RecordMismatchError(RecordError):
    """A record whose key is not its job's hash, or whose file is named by another key: edited
    or moved by hand (its checksum may have been made again over the edit)."""


class OutdatedRecordError(RecordError):
    """A record of an earlier format (:data:`OLD_SCHEMAS`): its job is to be recomputed."""


class StoreWriteError(OSError):
    """A store's file could not be written (a full disk, a folder made read-only, a directory
    in a file's place): the file is as it was (writes are atomic), the records already stored
    are kept, and the same command resumes from them once the cause is fixed."""

    def __init__(self, path: Path, error: OSError) -> None:
        reason = error.strerror or str(error)
        super().__init__(
            error.errno,
            f"cannot write {path} ({reason}); it is left as it was and the records already "
            "stored are kept: fix that and run the same command again to resume",
        )
        self.path = path

    def __str__(self) -> str:
        return str(self.strerror)


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


#: The largest budget of one job [model evaluations]: 10⁸, over 6 000 times the paper's
#: budgets; a larger one would run for days and outgrow the memory of the methods' per-iteration
#: tables (PSO's inertia schedule alone: 8 bytes per iteration).
MAX_BUDGET = 10**8


def _check_count(name: str, value: Any, low: int, allowed: str, high: int | None = None) -> None:
    if (
        isinstance(value, bool)
        or not isinstance(value, int | np.integer)
        or value < low
        or (high is not None and value > high)
    ):
        raise ValueError(f"{name} = {value!r}; allowed: {allowed}")


def _pairs(value: Any) -> tuple[tuple[str, Any], ...]:
    # Sorted by name, lists as tuples and mappings read-only (nested too: e.g. the polish's
    # initial strokes, the insect's fields): the same settings give one hashable Job, whatever
    # their order.
    items = value.items() if isinstance(value, Mapping) else value
    return tuple(sorted((str(k), _frozen(v)) for k, v in items))


def _frozen(value: Any) -> Any:
    if isinstance(value, list | tuple):
        return tuple(_frozen(v) for v in value)
    if isinstance(value, Mapping):
        return FrozenMapping({str(k): _frozen(v) for k, v in value.items()})
    return value


class FrozenMapping(Mapping[str, Any]):
    """A read-only, hashable mapping: a job's nested keyword value (the insect's fields, a
    penalty). It is a ``Mapping``, so the env takes it and JSON writes it as an object."""

    def __init__(self, items: Mapping[str, Any]) -> None:
        self._items = dict(items)

    def __getitem__(self, key: str) -> Any:
        return self._items[key]

    def __iter__(self) -> Any:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __hash__(self) -> int:
        return hash(tuple(sorted(self._items.items())))

    def __repr__(self) -> str:
        return repr(self._items)


def _canonical_env_kwargs(value: Any) -> Any:
    """The job's env keywords with ``insect`` in its canonical form (what differs from the
    paper's specimen, :func:`~tandem_env.envs.config.insect_keyword`; left out for the specimen
    itself, so a default run's key is what it always was)."""
    items = dict(value.items() if isinstance(value, Mapping) else value)
    if "insect" in items:
        insect = insect_keyword(items.pop("insect"))
        if insect is not None:
            items["insect"] = insect
    return items


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
    """Env keywords besides the condition (objective, planform, model options, insect), sorted
    by name; a mapping is accepted. ``insect`` (an object, a mapping or a YAML file) is kept as
    the mapping of what differs from the paper's specimen, and left out for the specimen."""
    method_config: tuple[tuple[str, Any], ...] = ()
    """Method settings (e.g. ``swarm_size``), sorted by name; a mapping is accepted."""
    preset: str = ""
    """The study preset the job belongs to (part of the key, so presets never share records);
    empty for a run outside the studies (``python -m eval optimize``)."""

    def __post_init__(self) -> None:
        # The one structural check of a job, where it is made (the CLI, a study, a record file):
        # the harness's prepare_job adds what needs the task and method registries.
        for name in ("method", "task", "preset"):
            value = getattr(self, name)
            if not isinstance(value, str) or (name != "preset" and not value):
                raise ValueError(f"job {name} = {value!r}; allowed: a non-empty name")
        if (
            isinstance(self.condition, bool)
            or not isinstance(self.condition, int | float | np.integer | np.floating)
            or not math.isfinite(self.condition)
        ):
            raise ValueError(f"condition = {self.condition!r}; allowed: a finite number")
        _check_count(
            "budget", self.budget, 1, f"an integer from 1 to {MAX_BUDGET:,} (model evaluations)",
            MAX_BUDGET,
        )  # fmt: skip
        _check_count("seed", self.seed, 0, "integers >= 0")
        object.__setattr__(self, "condition", float(self.condition))
        object.__setattr__(self, "budget", int(self.budget))
        object.__setattr__(self, "seed", int(self.seed))
        object.__setattr__(self, "env_kwargs", _pairs(_canonical_env_kwargs(self.env_kwargs)))
        object.__setattr__(self, "method_config", _pairs(self.method_config))

    @classmethod
    def from_dict(cls, data: Any) -> Job:
        """Inverse of :meth:`to_dict`; raises :class:`RecordError` for anything else."""
        if not isinstance(data, Mapping):
            raise RecordError(f"job = {data!r}; allowed: a JSON object (Job.to_dict)")
        allowed = set(cls.__dataclass_fields__)
        unknown = sorted(set(data) - allowed)
        if unknown:
            raise RecordError(f"job has unknown field(s) {unknown}; allowed: {sorted(allowed)}")
        try:
            return cls(**data)
        except (TypeError, ValueError) as error:
            raise RecordError(f"malformed job: {error}") from None

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

    def configuration(self) -> dict[str, Any]:
        """What decides the job's result: :meth:`to_dict` without the env keywords that choose
        only how the model is computed (``backend``, ``device``: ``EXECUTION_KWARGS``), so a
        torch run reuses a numba run's record and the other way round."""
        data = self.to_dict()
        data["env_kwargs"] = {
            k: v for k, v in data["env_kwargs"].items() if k not in EXECUTION_KWARGS
        }
        return data

    @property
    def key(self) -> str:
        """Configuration hash: the job's :meth:`configuration`, the tandem_env version and the
        record format."""
        return self.key_at(tandem_env.__version__)

    def key_at(self, version: str) -> str:
        """:attr:`key` as tandem_env ``version`` computed it (a record made by that version)."""
        payload = {**self.configuration(), "tandem_env": version, "record": SCHEMA}
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


def _result(name: str, doc: str) -> property:
    # One accessor per results key, documented from RESULTS (one home for the schema).
    return property(lambda self: self.results[name], doc=doc)


def _checksum(payload: Mapping[str, Any]) -> str:
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class Record:
    """What one :class:`Job` found: the job, its key and one mapping of results.

    Every number describing the stroke comes from the final re-evaluation of the reported
    stroke (a fresh single-env step), not from the search. The results' keys and units are
    :data:`RESULTS`; each has an attribute of that name (``record.objective``), and the job's
    fields read through (``record.method``, ``record.seed``, ...).
    """

    job: Job
    """The configuration that produced the record."""
    key: str
    """The job's configuration hash when it ran (:attr:`Job.key`): the record's file name."""
    results: dict[str, Any]
    """What the run found, plain JSON (:data:`RESULTS`, plus any key a later stage adds)."""
    schema: str = field(default=SCHEMA)
    """Record format identifier."""

    def __post_init__(self) -> None:
        if self.schema != SCHEMA:
            raise RecordError(f"record schema {self.schema!r}; allowed: {SCHEMA!r}")
        if not isinstance(self.job, Job):
            raise RecordError(f"job = {self.job!r}; allowed: a Job")
        if not isinstance(self.key, str) or not self.key:
            raise RecordError(f"key = {self.key!r}; allowed: the job's key (Job.key)")
        if not isinstance(self.results, Mapping):
            raise RecordError(f"results = {self.results!r}; allowed: a mapping")
        missing = [name for name in RESULTS if name not in self.results]
        if missing:
            raise RecordError(f"record results are missing {missing}")
        try:
            results = to_jsonable(self.results)
        except TypeError as error:
            raise RecordError(f"record results are not plain JSON: {error}") from None
        object.__setattr__(self, "results", results)
        evaluations = results["evaluations"]
        if not isinstance(evaluations, int) or not 0 <= evaluations <= self.job.budget:
            raise RecordError(
                f"record evaluations = {evaluations!r}; allowed: an integer from 0 to its "
                f"budget {self.job.budget}"
            )
        for name in ("objective", "reward", "search_reward"):
            # A NaN is no result: it would pass every comparison silently (max, median, rank).
            value = results[name]
            if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
                raise RecordError(
                    f"record {name} = {value!r}; allowed: a number (not NaN; -inf marks an "
                    "infeasible reward)"
                )

    # --- the job's fields -----------------------------------------------------------------------
    @property
    def method(self) -> str:
        """Method spec, e.g. ``"pso"``, ``"cmaes"``, ``"policy:runs/ppo"``."""
        return self.job.method

    @property
    def task(self) -> str:
        """Task name, e.g. ``"level"`` or ``"accelerate"``."""
        return self.job.task

    @property
    def seed(self) -> int:
        """Seed of the method (and of the envs' first reset)."""
        return self.job.seed

    @property
    def budget(self) -> int:
        """Allowed model evaluations (= env steps = strokes evaluated)."""
        return self.job.budget

    @property
    def condition(self) -> Condition:
        """The flight condition (name, the job's value, unit), e.g. speed = 1.5 m/s."""
        r = self.results
        return Condition(r["condition_name"], self.job.condition, r["condition_unit"])

    # --- the results --------------------------------------------------------------------------
    env_id = _result("env_id", RESULTS["env_id"])
    objective_name = _result("objective_name", RESULTS["objective_name"])
    evaluations = _result("evaluations", RESULTS["evaluations"])
    objective = _result("objective", RESULTS["objective"])
    reward = _result("reward", RESULTS["reward"])
    search_reward = _result("search_reward", RESULTS["search_reward"])
    feasible = _result("feasible", RESULTS["feasible"])
    selection = _result("selection", RESULTS["selection"])
    stroke = _result("stroke", RESULTS["stroke"])
    metrics = _result("metrics", RESULTS["metrics"])
    wall_time = _result("wall_time", RESULTS["wall_time"])
    versions = _result("versions", RESULTS["versions"])

    @property
    def certificate(self) -> dict[str, Any]:
        """The local polish and the optimality of the reported stroke (method, status, gain
        [-], evaluations, iterations, converged, KKT residual [-], active constraints;
        :class:`agents.polish.Certificate`); empty for a record made without one."""
        return dict(self.results.get(CERTIFICATE, {}))

    @property
    def normalised_stroke(self) -> tuple[float, ...]:
        """The stroke as the 28 normalised action values in [-1, 1]."""
        return tuple(self.results["normalised_stroke"])

    @property
    def history(self) -> tuple[tuple[int, float], ...]:
        """(evaluations, best reward so far) after every iteration of the search."""
        return tuple((int(e), float(b)) for e, b in self.results["history"])

    @property
    def config(self) -> dict[str, Any]:
        """``method`` (``method_settings``: the method's settings and citation) and ``env`` (the env's full
        configuration: insect, model options incl. ``thrust_split``, penalty)."""
        return {"method": self.results["method_settings"], "env": self.results["env"]}

    # --- JSON ------------------------------------------------------------------------------------
    def _payload(self) -> dict[str, Any]:
        return {
            "schema": self.schema,
            "key": self.key,
            "job": self.job.to_dict(),
            "results": self.results,
        }

    @property
    def checksum(self) -> str:
        """SHA-256 of the schema, key, job and results as JSON (sorted keys, no spaces)."""
        return _checksum(self._payload())

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form (the file format): schema, key, checksum, job, results."""
        payload = self._payload()
        return {
            "schema": payload["schema"],
            "key": payload["key"],
            "checksum": _checksum(payload),
            "job": payload["job"],
            "results": payload["results"],
        }

    @classmethod
    def from_dict(cls, data: Any) -> Record:
        """Inverse of :meth:`to_dict`.

        Raises :class:`OutdatedRecordError` for a record of an earlier format and
        :class:`RecordError` for anything else that is not a valid record, including one whose
        checksum does not match its contents (edited by hand or damaged).
        """
        if not isinstance(data, Mapping):
            raise RecordError(
                f"record data is {type(data).__name__} {_short(data)}; allowed: a JSON object "
                f"with schema {SCHEMA!r}"
            )
        schema = data.get("schema")
        if schema in OLD_SCHEMAS:
            raise OutdatedRecordError(
                f"a record of the earlier format {schema!r} (now {SCHEMA!r}); it is not read "
                "as a result: rerun the command that wrote it to recompute it"
            )
        if schema != SCHEMA:
            raise RecordError(f"not a harness record (schema {_short(schema)}, want {SCHEMA!r})")
        expected = {"schema", "key", "checksum", "job", "results"}
        if set(data) != expected:
            raise RecordError(f"record fields {sorted(data)}; allowed: exactly {sorted(expected)}")
        record = cls(
            job=Job.from_dict(data["job"]),
            key=data["key"],
            results=data["results"],
            schema=schema,
        )
        if record.checksum != data["checksum"]:
            raise RecordChecksumError(
                f"checksum {_short(data['checksum'])} does not match the record's contents: "
                "edited by hand or damaged; it is not used"
            )
        # The key is the hash of the job it holds (as the version that wrote it computed it):
        # a record whose job was edited, or whose key was, is not its job's record, even with
        # a checksum made again over the edit.
        version = record.results["versions"]
        version = version.get("tandem_env") if isinstance(version, Mapping) else None
        keys = {record.job.key} | (
            {record.job.key_at(version)} if isinstance(version, str) else set()
        )
        if record.key not in keys:
            raise RecordMismatchError(
                f"key {_short(record.key)} is not the hash of the job it holds "
                f"({record.job.label()}: key {record.job.key}); the key or the job was edited, "
                "it is not used"
            )
        return record

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Record:
        """Read a record file; :class:`RecordError` naming the file for anything but a valid
        record (OSError if it cannot be opened)."""
        try:
            data = read_json(path)
        except ValueError as error:  # not UTF-8, not JSON, truncated
            raise RecordError(f"{path}: not a record file, cannot read JSON ({error})") from None
        try:
            return cls.from_dict(data)
        except RecordError as error:
            raise type(error)(f"{path}: {error}") from None

    def label(self) -> str:
        """Short human label, e.g. ``pso level efficiency speed=1.5 seed 0, budget 12000``."""
        c = self.condition
        return (
            f"{self.method} {self.task} {self.objective_name} {c.name}={c.value:g} "
            f"seed {self.seed}, budget {self.budget}"
        )

    # --- tables ------------------------------------------------------------------------------------
    def summary_row(self) -> dict[str, Any]:
        """One flat CSV row: identity, result, headline metrics, the 28 stroke parameters and
        ``at_bounds`` (those at a Table 4 bound, :func:`tandem_env.describe_bounds`)."""
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
        # the stroke itself (Table 4 units), and which of its parameters sit at a Table 4 bound
        stroke = [float(self.stroke[name]) for name in tandem_env.PARAMETER_NAMES]
        row.update(zip(tandem_env.PARAMETER_NAMES, stroke, strict=True))
        row["at_bounds"] = tandem_env.describe_bounds(stroke)
        insect = self.job.env("insect")
        if insect is not None:  # what differs from the paper's specimen (JSON in the CSV)
            row["insect"] = to_jsonable(insect)
        row["key"] = self.key
        return row

    def best_so_far(self) -> tuple[list[int], list[float]]:
        """The history as (evaluations, best reward so far) lists, e.g. for plotting."""
        return [e for e, _ in self.history], [b for _, b in self.history]


#: A store's file name for a record: its key (:attr:`Job.key`, 20 hex digits).
_KEY_NAME = re.compile(r"[0-9a-f]{20}")


def _check_name(path: Path, record: Record) -> Record:
    """``record`` if ``path`` is named by its key, as a store names them (``<key>.json``), or by
    no key at all; RecordError for one moved or copied to another job's name."""
    if _KEY_NAME.fullmatch(path.stem) and path.stem != record.key:
        raise RecordMismatchError(
            f"{path}: holds the record of key {record.key} ({record.label()}), not of the key "
            f"{path.stem} it is named by: moved or copied by hand; it is not used"
        )
    return record


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


class RecordStore:
    """Records keyed by configuration: ``DIR/records/<key>.json``, written atomically.

    Raises ValueError when ``directory`` (or its ``records``) exists and is not a directory.
    """

    def __init__(self, directory: str | os.PathLike[str]) -> None:
        self._given = os.fspath(directory)  # as given: Path("") would be the current folder
        self.directory = Path(directory)
        for path in (self.directory, self.directory / RECORDS_DIR):
            if path.exists() and not path.is_dir():
                raise ValueError(
                    f"{path} is a file; allowed: a directory for the records (created if missing)"
                )

    def check(self, option: str = "--out", *, write: bool = True, jobs: Iterable[Job] = ()) -> bool:
        """Check every path the store writes before any work (:func:`output_directory`): the
        folder, its ``records``, ``summary.csv`` and the record files of ``jobs``; ValueError
        naming the path and what is allowed, or (without ``write``) False if it cannot be
        written now."""
        records = [f"{RECORDS_DIR}/{job.key}.json" for job in jobs]
        return output_directory(
            self._given, option, write=write, folders=(RECORDS_DIR,),
            files=(SUMMARY_NAME, *records),
        )  # fmt: skip

    def path(self, key: str) -> Path:
        """Where the record with configuration hash ``key`` is stored."""
        return self.directory / RECORDS_DIR / f"{key}.json"

    def load(self, job: Job) -> Record | None:
        """The stored record of ``job``, or None if it has not run with this configuration.

        A file that is not a valid record of ``job`` (corrupt, failing its checksum, of an
        earlier format, or holding another job: a file copied by hand or a truncated-hash
        collision) is reported with a :class:`RecordWarning` and treated as missing, so the job
        runs again and its record replaces the file.
        """
        path = self.path(job.key)
        if not path.exists():
            return None
        try:
            record = Record.load(path)
        except OutdatedRecordError as error:
            _warn(f"{error}; {job.label()} is recomputed")
            return None
        except (OSError, RecordError) as error:
            reason = str(error).removeprefix(f"{path}: ")
            _warn(f"{path}: corrupt record ({reason}); {job.label()} runs again")
            return None
        if record.key != job.key or record.job.configuration() != job.configuration():
            _warn(
                f"{path}: holds {record.label()} (job {record.job.to_dict()}), not "
                f"{job.label()}; it runs again and its record replaces the file"
            )
            return None
        return record

    def save(self, record: Record) -> Path:
        """Write ``record`` as ``records/<record.key>.json`` atomically; returns the path.

        Nothing is read back: the one writer (:func:`eval.studies.runner.run_jobs`) saves a
        job's record only after :meth:`load` found none valid under its key.
        """
        path = self.path(record.key)
        data = record.to_dict()
        try:
            write_json_atomic(path, data)
        except OSError as error:
            raise StoreWriteError(path, error) from None
        return path

    def records(self) -> list[Record]:
        """Every valid record in the store, ordered as :func:`summary_rows` orders them; the
        others are left out with a :class:`RecordWarning`."""
        found = []
        for path in sorted((self.directory / RECORDS_DIR).glob("*.json")):
            try:
                found.append(_check_name(path, Record.load(path)))
            except (OSError, RecordError) as error:
                _warn(f"{error}; left out")
        return sorted(found, key=_summary_order)

    def outdated(self) -> list[Path]:
        """The store's files holding records of an earlier format (:data:`OLD_SCHEMAS`)."""
        found = []
        for path in sorted((self.directory / RECORDS_DIR).glob("*.json")):
            try:
                data = read_json(path)
            except (OSError, ValueError):
                continue  # reported by load() when its job asks for it
            if isinstance(data, dict) and data.get("schema") in OLD_SCHEMAS:
                found.append(path)
        return found

    def write_summary(self) -> Path:
        """Rewrite ``DIR/summary.csv`` over every record in the store (read once); its path."""
        path = self.directory / SUMMARY_NAME
        records = self.records()
        try:
            write_summary(path, records)
        except OSError as error:
            raise StoreWriteError(path, error) from None
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

    Finds the records of stores (``DIR/records/*.json``) and of study directories alike. JSON
    files that are not records (another schema) are skipped; a record of an earlier format or
    one failing its checksum is left out with a :class:`RecordWarning` (never mixed in); a file
    that cannot be read, or claims the record schema but is malformed, raises
    :class:`RecordError` naming it.
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
                raise RecordError(f"{path}: cannot read JSON: {error}") from None
            schema = data.get("schema") if isinstance(data, dict) else None
            if schema in OLD_SCHEMAS:
                _warn(f"{path}: a record of the earlier format {schema!r}; left out (rerun "
                      "the command that wrote it to recompute it)")  # fmt: skip
                continue
            if schema != SCHEMA:
                continue
            try:
                records.append(_check_name(path, Record.from_dict(data)))
            except (RecordChecksumError, RecordMismatchError) as error:
                _warn(f"{path}: {str(error).removeprefix(f'{path}: ')}; left out")
                continue
            except RecordError as error:
                raise RecordError(f"{path}: malformed record: {error}") from None
    return records
