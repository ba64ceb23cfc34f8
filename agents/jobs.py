"""A job: the configuration of one harness run, and the key its record is stored under.

A :class:`Job` is one method, task, condition, budget and seed, with its env keywords, method
settings and study preset; its :attr:`Job.key` hashes them (but the backend and device, which
do not change results), the ``tandem_env`` version, the model's revision and the record format
(:data:`SCHEMA`). Jobs are run by :func:`agents.runner.run_jobs`.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace
from typing import Any, ClassVar, Protocol

import tandem_env
from agents.polish_config import INITIAL_SHARE_RANGE, split_settings
from agents.tasks import available_tasks, get_task
from tandem_env.envs.config import EXECUTION_KWARGS, insect_keyword
from tandem_env.envs.declaration import refusal
from tandem_env.io.files import to_jsonable
from tandem_env.physics import N_PARAMETERS, ModelOptions
from tandem_env.physics.checks import count, is_integer, is_real

#: Identifies record files (and their version) among other JSON files.
SCHEMA = "tandem_env.harness-record/5"
"""Record format; /2 added ``selection``, /3 ``key`` and ``job``, /4 the job, key and results
once each plus a checksum, /5 the results' ``certificate`` (and, optional, ``starts``)."""
#: Earlier formats: recognised, never read as results (their jobs are recomputed).
OLD_SCHEMAS = tuple(f"tandem_env.harness-record/{n}" for n in range(1, 5))

#: The largest budget of one job [model evaluations]: 10⁸, over 6 000 times the paper's; a
#: larger one would run for days and outgrow the methods' per-iteration tables.
MAX_BUDGET = 10**8


def _pairs(value: Any) -> tuple[tuple[str, Any], ...]:
    # Sorted by name, lists as tuples and mappings read-only (nested too): the same settings
    # give one hashable Job, whatever their order.
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


def method_identity(spec: str, config: Mapping[str, Any]) -> str:
    """The identity of the files the method ``spec`` (with settings ``config``) reads: its
    ``identity()``, asked only of a method that takes a path (``name:ARGUMENT``); empty for
    the others and for a method that cannot be made (the harness refuses its job)."""
    if ":" not in spec:
        return ""
    from agents.methods import get_method

    try:
        method = get_method(spec, split_settings(spec, dict(config))[1])
        identity = getattr(method, "identity", None)
        return str(identity()) if callable(identity) else ""
    except (ValueError, TypeError, NotImplementedError, OSError):
        return ""


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
    by name (a mapping is accepted); ``insect`` (an object, a mapping or a YAML file) kept as
    what differs from the paper's specimen, left out for the specimen."""
    method_config: tuple[tuple[str, Any], ...] = ()
    """Method settings (e.g. ``swarm_size``), sorted by name; a mapping is accepted."""
    preset: str = ""
    """The study preset the job belongs to (part of the key, so presets never share records);
    empty outside the studies (``python -m eval optimize``)."""
    method_identity: str | None = None
    """What the files the method reads hold, so a newer trained run is another job under another key
    (:func:`method_identity` when not given); empty ones are left out of the job's dict and key."""

    def __post_init__(self) -> None:
        # the one structural check of a job, where it is made (the CLI, a study, a record
        # file); prepare_job adds what needs the registries
        for name in ("method", "task", "preset"):
            value = getattr(self, name)
            if not isinstance(value, str) or (name != "preset" and not value):
                raise ValueError(f"job {name} = {value!r}; allowed: a non-empty name")
        if not is_real(self.condition) or not math.isfinite(self.condition):
            raise ValueError(f"condition = {self.condition!r}; allowed: a finite number")
        budget = count(self.budget, "budget", high=MAX_BUDGET, what="model evaluations")
        object.__setattr__(self, "condition", float(self.condition))
        object.__setattr__(self, "budget", budget)
        object.__setattr__(self, "seed", count(self.seed, "seed", low=0))
        # ``insect`` in its canonical form (:func:`~tandem_env.envs.config.insect_keyword`),
        # left out for the specimen itself
        kwargs = dict(self.env_kwargs)
        if "insect" in kwargs and (insect := insect_keyword(kwargs.pop("insect"))) is not None:
            kwargs["insect"] = insect
        object.__setattr__(self, "env_kwargs", _pairs(kwargs))
        object.__setattr__(self, "method_config", _pairs(self.method_config))
        if self.method_identity is None:
            identity = method_identity(self.method, dict(self.method_config))
            object.__setattr__(self, "method_identity", identity)

    @classmethod
    def from_dict(cls, data: Any) -> Job:
        """Inverse of :meth:`to_dict`; raises ValueError for anything else (a record file
        reports it as a :class:`~agents.records.RecordError`)."""
        if not isinstance(data, Mapping):
            raise ValueError(f"job = {data!r}; allowed: a JSON object (Job.to_dict)")
        allowed = set(cls.__dataclass_fields__)
        if unknown := sorted(set(data) - allowed):
            raise ValueError(f"job has unknown field(s) {unknown}; allowed: {sorted(allowed)}")
        try:  # a record's job holds the identity its method had (none: none)
            return cls(**{"method_identity": "", **data})
        except (TypeError, ValueError) as error:
            raise ValueError(f"malformed job: {error}") from None

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form (keyword pairs become objects): what a record stores as ``job``."""
        skip = () if self.method_identity else ("method_identity",)
        data = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in skip}
        data |= {"env_kwargs": dict(self.env_kwargs), "method_config": dict(self.method_config)}
        return to_jsonable(data)

    def configuration(self) -> dict[str, Any]:
        """What decides the job's result: :meth:`to_dict` without the env keywords that choose
        only how the model is computed (``backend``, ``device``: ``EXECUTION_KWARGS``), so a
        torch run reuses a numba run's record and the other way round."""
        data = self.to_dict()
        kwargs = data["env_kwargs"].items()
        data["env_kwargs"] = {k: v for k, v in kwargs if k not in EXECUTION_KWARGS}
        return data

    @property
    def key(self) -> str:
        """Configuration hash: the job's :meth:`configuration`, the tandem_env version, the
        model's revision (:data:`~tandem_env.physics.MODEL_REVISION`) and the record format."""
        return self.key_at(tandem_env.__version__, tandem_env.physics.MODEL_REVISION)

    def key_at(self, version: str, model: int | None) -> str:
        """:attr:`key` as tandem_env ``version`` computed it with model revision ``model``
        (None: a record made before the key held the model's revision); a job under the vortex
        reading or whose insect sets a gap holds their revisions too (``key_revisions``)."""
        payload = {**self.configuration(), "tandem_env": version, "record": SCHEMA}
        if model is not None:
            gap = (self.env("insect") or {}).get("min_wing_gap") is not None
            payload |= {"model": model, **tandem_env.physics.key_revisions(self.slipstream(), gap)}
        return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:20]

    def slipstream(self) -> str:
        """The slipstream reading the job's model runs: its ``slipstream`` keyword, else its
        ``options``' (an object or its mapping), else ``ModelOptions``' default."""
        options = self.env("options")
        given = options.get("slipstream") if isinstance(options, Mapping) else None
        default = getattr(options, "slipstream", given) or ModelOptions().slipstream
        return str(self.env("slipstream", default))

    def env(self, name: str, default: Any = None) -> Any:
        """One env keyword (``objective``, ``planform``, ...) or ``default``."""
        return dict(self.env_kwargs).get(name, default)

    def label(self) -> str:
        """Short human label, e.g. ``pso level V=1.5 seed 0``."""
        # The condition's command-line symbol (V, P) from the task's declaration.
        known = self.task in available_tasks()
        symbol = get_task(self.task).declared_condition.metavar if known else "condition"
        extra = [str(v) for k, v in self.env_kwargs if k in ("objective", "planform")]
        return " ".join(
            [self.method, self.task, *extra, f"{symbol}={self.condition:g}", f"seed {self.seed}"]
        )


class Work(Protocol):
    """A job of another kind than :class:`Job` (``eval.crosscheck.uvlm.SolverJob``), run,
    stored and cached as a :class:`Job` is: hashable and picklable, its ``key`` hashes what
    decides its result, its ``budget`` is its cost (largest first; the progress bar's unit) and
    ``compute()`` makes its record: ``key``, ``job``, ``to_dict()``, read back by
    ``record_type.from_dict`` (:class:`~agents.records.RecordError` for anything else)."""

    noun: ClassVar[str]  # what the progress bar counts ("solver run")
    record_type: ClassVar[Any]
    key: str
    budget: int

    def label(self) -> str: ...
    def configuration(self) -> dict[str, Any]: ...
    def compute(self) -> Any: ...


@dataclass(frozen=True)
class Continuation:
    """Jobs continued from the optima found so far, in rounds: each on a ``share`` of its
    budget, polishing the optima given as warm starts beside ``starts`` short searches of its
    own (harness settings ``initial``, ``initial_share`` and ``starts``; ``starts`` None: the
    method's own, left out of the key; docs/harness.md). The rounds run until ``rounds`` have,
    or (``until`` not None) until one raised no point by more than ``until`` [%] (:meth:`stops`).
    """

    share: float = 0.2
    initial_share: float = 0.75
    starts: int | None = 1
    rounds: int = 1
    until: float | None = None

    def __post_init__(self) -> None:
        low, high = INITIAL_SHARE_RANGE
        numbers = {
            "share": (lambda x: 0.0 < x <= 1.0, "a number in (0, 1]"),
            "initial_share": (lambda x: low <= x <= high, f"a number in [{low:g}, {high:g}]"),
            "until": (lambda x: x >= 0.0, "a percentage >= 0, or None (every round)"),
        }
        for name, (inside, allowed) in numbers.items():
            if (value := getattr(self, name)) is None and name == "until":
                continue
            if not is_real(value) or not math.isfinite(value) or not inside(value):
                raise ValueError(f"continuation {name} = {value!r}; allowed: {allowed}")
            object.__setattr__(self, name, float(value))
        if self.starts is not None and not (is_integer(self.starts) and 1 <= self.starts <= 8):
            raise refusal("continuation starts", self.starts, "an integer in [1, 8]")
        count(self.rounds, "continuation rounds")

    def job(self, job: Job, strokes: Sequence[Sequence[float]] | None, index: int = 0) -> Job:
        """``job`` continued in round ``index`` (its seed plus ``index``) from the normalised
        ``strokes``; None gives the stand-in of a job whose optima are not known yet (the
        budget right, the key not final: the cost line's)."""
        strokes = [(0.0,) * N_PARAMETERS] if strokes is None else strokes
        initial = [list(map(float, stroke)) for stroke in strokes]
        config = dict(job.method_config) | {"initial": initial, "initial_share": self.initial_share}
        if self.starts is not None:
            config["starts"] = self.starts
        budget = max(1, round(self.share * job.budget))
        return replace(job, budget=budget, seed=job.seed + index, method_config=config)

    def stops(self, largest_gain: float) -> bool:
        """Whether the rounds stop after one whose largest gain over the points was
        ``largest_gain`` [%] (never, without ``until``: every round runs)."""
        return self.until is not None and largest_gain <= self.until
