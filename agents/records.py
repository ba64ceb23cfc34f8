"""Harness records: what one job found, in one format every method and reader shares: its
:class:`~agents.jobs.Job`, the job's key and one mapping of results (:data:`RESULTS`), with a
checksum of all three (docs/harness.md).
"""

from __future__ import annotations

import hashlib
import json
import math
import platform
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

import tandem_env
from agents.jobs import OLD_SCHEMAS, SCHEMA, Job
from agents.tasks import Condition
from tandem_env.envs.reference import record_score
from tandem_env.io.files import to_jsonable
from tandem_env.physics.checks import short_repr

#: The record's ``selection``: which of the strokes a search evaluated it reports.
SELECTION_BEST_FEASIBLE = "best feasible stroke seen"
SELECTION_BEST_REWARD = "best reward seen (no feasible stroke)"
SELECTION_METHOD = "the method's stroke"
SELECTION_POLISHED = "best feasible stroke seen, polished"
SELECTION_REWARD_POLISHED = "best reward seen (no feasible stroke), polished onto the constraints"
SELECTION_INITIAL = "an initial stroke (not improved by the polish)"
SELECTION_INITIAL_POLISHED = "an initial stroke, polished"

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
    "versions": "package versions (numpy, gymnasium, torch, ..., python, tandem_env) and the "
    "model's revision (model: tandem_env.physics.MODEL_REVISION; none before records held it)",
}
#: The results key of the local polish and the reported stroke's optimality (every harness
#: record has it: :meth:`agents.polish.Certificate.to_dict`).
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

#: The CSV summary's columns read from the record's attribute of the same name, after its
#: identity and condition (:meth:`Record.summary_row`).
_SUMMARY_RESULTS = ("seed", "budget", "evaluations", "objective", "reward", "feasible", "score")

# Distribution names on the package index; the record's key is the name with '_' for '-'.
_PACKAGES = ("numpy", "scipy", "gymnasium", "stable-baselines3", "torch", "numba")


class RecordError(ValueError):
    """Data that is not a valid record: not JSON, not a record, malformed or failing its checksum."""


class RecordChecksumError(RecordError):
    """A record whose checksum does not match its contents (edited by hand or damaged)."""


class RecordMismatchError(RecordError):
    """A record whose key is not its job's hash, or whose file is named by another key: edited
    or moved by hand (its checksum may have been made again over the edit)."""


class UnsafeFileError(RecordError):
    """A file not read (not a regular file, e.g. a named pipe) or not trusted (one of the record
    cache owned by another user or writable by others: :func:`agents.store.unsafe_path`)."""


class OutdatedRecordError(RecordError):
    """A record of an earlier format (:data:`OLD_SCHEMAS`): its job is to be recomputed."""


class RecordWarning(UserWarning):
    """A stored record that is corrupt, or replaced by a record of another configuration."""


def package_versions() -> dict[str, Any]:
    """Versions of the packages that determine results (``"not installed"`` for one that is
    not), of Python and tandem_env, and the model's revision (``model``)."""
    versions: dict[str, Any] = {}
    for distribution in _PACKAGES:
        try:
            version = metadata.version(distribution)
        except metadata.PackageNotFoundError:
            version = "not installed"
        versions[distribution.replace("-", "_")] = version
    versions["python"] = platform.python_version()
    versions["tandem_env"] = tandem_env.__version__
    versions["model"] = tandem_env.physics.MODEL_REVISION
    return versions


@dataclass(frozen=True)
class Record:
    """What one :class:`Job` found: the job, its key and its results (:data:`RESULTS`, each an
    attribute, as the job's fields are), every number from the re-evaluation of the stroke."""

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
        if missing := [name for name in RESULTS if name not in self.results]:
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
        for name in ("objective", "reward", "search_reward"):  # a NaN would pass every comparison
            value = results[name]
            if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
                raise RecordError(
                    f"record {name} = {value!r}; allowed: a number (not NaN; -inf marks an "
                    "infeasible reward)"
                )

    def __getattr__(self, name: str) -> Any:
        """The job's ``method``, ``task``, ``seed`` and ``budget`` (``record.seed`` is
        ``record.job.seed``) and each key of :data:`RESULTS` without a property of its own
        (``record.objective``), read through the record."""
        if name in ("method", "task", "seed", "budget"):
            return getattr(self.job, name)
        if name in RESULTS:
            return self.results[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @property
    def condition(self) -> Condition:
        """The flight condition (name, the job's value, unit), e.g. speed = 1.5 m/s."""
        r = self.results
        return Condition(r["condition_name"], self.job.condition, r["condition_unit"])

    # --- the results (each key of RESULTS is an attribute: below the class) ----------------------
    @property
    def certificate(self) -> dict[str, Any]:
        """The polish and optimality of the stroke (:class:`agents.polish.Certificate`), or {}."""
        return dict(self.results.get(CERTIFICATE, {}))

    @property
    def score(self) -> float:
        """The stroke's normalised score [-] (:func:`~tandem_env.envs.reference.record_score`;
        NaN where the reference table does not apply)."""
        violation = float(self.metrics.get("constraint_violation", math.nan))
        stroke = (self.job.condition, self.objective, self.feasible, violation)
        return record_score(self.env_id, self.results["env"], *stroke)

    @property
    def model(self) -> int | None:
        """The model revision that made the record (:data:`tandem_env.physics.MODEL_REVISION`),
        None before records held it; only a record of today's is reused (its key holds it)."""
        versions = self.results["versions"]
        return versions.get("model") if isinstance(versions, Mapping) else None

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
        """``method`` (``method_settings``: the method's settings and citation) and ``env`` (the
        env's full configuration: insect, model options incl. ``thrust_split``, penalty)."""
        return {"method": self.results["method_settings"], "env": self.results["env"]}

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
        text = json.dumps(self._payload(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form (the file format): schema, key, checksum, job, results."""
        return {**self._payload(), "checksum": self.checksum}

    @classmethod
    def from_dict(cls, data: Any) -> Record:
        """Inverse of :meth:`to_dict`: :class:`OutdatedRecordError` for a record of an earlier
        format, :class:`RecordError` for anything else that is not a valid record."""
        if not isinstance(data, Mapping):
            raise RecordError(
                f"record data is {type(data).__name__} {short_repr(data)}; allowed: a JSON object "
                f"with schema {SCHEMA!r}"
            )
        if (schema := data.get("schema")) in OLD_SCHEMAS:
            raise OutdatedRecordError(
                f"a record of the earlier format {schema!r} (now {SCHEMA!r}); it is not read "
                "as a result: rerun the command that wrote it to recompute it"
            )
        if schema != SCHEMA:
            raise RecordError(
                f"not a harness record (schema {short_repr(schema)}, want {SCHEMA!r})"
            )
        if set(data) != (expected := {"schema", "key", "checksum", "job", "results"}):
            raise RecordError(f"record fields {sorted(data)}; allowed: exactly {sorted(expected)}")
        try:
            job = Job.from_dict(data["job"])
        except ValueError as error:
            raise RecordError(str(error)) from None
        record = cls(job=job, key=data["key"], results=data["results"], schema=schema)
        if record.checksum != data["checksum"]:
            raise RecordChecksumError(
                f"checksum {short_repr(data['checksum'])} does not match the record's contents: "
                "edited by hand or damaged; it is not used"
            )
        # the key is the hash of the job it holds, as the version and model that wrote it
        # computed it (a checksum made again over an edit does not hide the edit)
        versions = record.results["versions"]
        version = versions.get("tandem_env") if isinstance(versions, Mapping) else None
        written = isinstance(version, str) and record.key == job.key_at(version, record.model)
        if record.key != job.key and not written:
            raise RecordMismatchError(
                f"key {short_repr(record.key)} is not the hash of the job it holds "
                f"({record.job.label()}: key {record.job.key}); the key or the job was edited, "
                "it is not used"
            )
        return record

    def label(self) -> str:
        """Short human label, e.g. ``pso level efficiency speed=1.5 seed 0, budget 12000``."""
        c = self.condition
        return (
            f"{self.method} {self.task} {self.objective_name} {c.name}={c.value:g} "
            f"seed {self.seed}, budget {self.budget}"
        )

    def summary_row(self) -> dict[str, Any]:
        """One flat CSV row: identity, result, headline metrics, the 28 stroke parameters and
        ``at_bounds`` (those at a Table 4 bound, :func:`tandem_env.describe_bounds`)."""
        c = self.condition
        row = {name: getattr(self, name) for name in ("method", "task", "objective_name")}
        row |= {"condition": c.name, "condition_value": c.value, "condition_unit": c.unit}
        row |= {name: getattr(self, name) for name in _SUMMARY_RESULTS}
        row["wall_time_s"] = self.wall_time
        row |= {name: self.metrics[name] for name in SUMMARY_METRICS if name in self.metrics}
        # The stroke (Table 4 units) and its parameters at a bound of the insect's (Table 4's
        # unless it sets its own); a task of another action (a plug-in, the analytic test
        # tasks) has no such stroke.
        insect = self.job.env("insect")
        if set(tandem_env.PARAMETER_NAMES) <= set(self.stroke):
            stroke = [float(self.stroke[name]) for name in tandem_env.PARAMETER_NAMES]
            row.update(zip(tandem_env.PARAMETER_NAMES, stroke, strict=True))
            bounds = tandem_env.load_insect(insect or {}).stroke_bounds  # the flyer's own
            row["at_bounds"] = tandem_env.describe_bounds(stroke, bounds)
        if insect is not None:  # what differs from the paper's specimen (JSON in the CSV)
            row["insect"] = to_jsonable(insect)
        row["key"] = self.key
        return row
