"""A reading of the paper: one named, documented choice for each decision the paper leaves open.

The paper (Faisal & Filippone 2016) leaves several modelling decisions open (docs/model.md §1.3,
§5, §6, §7): how thrust and drag split the horizontal force, how power is accounted, the
rotational coefficient C_r, which spin rate enters circulation and added mass, the inflow in
hover, the fore-wing's share C_hf on the hind-wing, and what F̄_h of accelerating flight is. A
:class:`Reading` names one combination of those choices; the studies build their jobs under it
(:meth:`eval.studies.base.StudyPlan.jobs`), so a reading changes the env keywords of every job and
nothing else. The default reading changes nothing: its jobs are the ``all`` suite's, key for key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from tandem_env import Dragonfly, ModelOptions
from tandem_env.envs import ACCELERATE
from tandem_env.envs.config import MODEL_OPTION_KWARGS

#: ModelOptions fields that set the numerics (resolution, solver), not a reading of the paper.
NUMERICAL_OPTIONS: frozenset[str] = frozenset({"n_time", "n_blade", "tolerance", "max_evaluations"})
#: The ModelOptions fields a reading may set: every modelling decision.
DECISION_OPTIONS: tuple[str, ...] = tuple(
    f.name for f in fields(ModelOptions) if f.name not in NUMERICAL_OPTIONS
)
#: Accelerating-flight objectives whose optimum can stand for the paper's F̄_h (Fig. 7).
HORIZONTAL_OBJECTIVES: tuple[str, ...] = tuple(
    o
    for o in ACCELERATE.objectives.choices
    if o.startswith("horizontal")  # type: ignore[union-attr]
)
#: C_r of the default insect's wings (Table 3: π) [-].
DEFAULT_ROTATIONAL = Dragonfly().fore.rotational_coefficient
_KWARG_OF = {option: kwarg for kwarg, option in MODEL_OPTION_KWARGS.items()}


def _fail(name: str, field_name: str, value: Any, allowed: str) -> None:
    raise ValueError(f"Reading {name!r}: {field_name} = {value!r}; allowed: {allowed}")


@dataclass(frozen=True)
class Reading:
    """One reading of the paper: the options it changes from the documented defaults."""

    name: str
    """Short identifier, e.g. ``"default"`` or ``"thrust_split=body"``; a column of the matrix."""
    description: str
    """One line: what this reading assumes and where the paper leaves it open."""
    options: tuple[tuple[str, Any], ...] = ()
    """:class:`~tandem_env.ModelOptions` fields (``DECISION_OPTIONS``) and their values, sorted
    by name; a mapping is accepted. Values are validated by ``ModelOptions`` itself."""
    rotational_coefficient: float | None = None
    """C_r of both wings [-] (Table 3); None keeps the insect's (π)."""
    horizontal_objective: str = "horizontal"
    """The accelerating-flight objective whose optimum gives F̄_h (``HORIZONTAL_OBJECTIVES``):
    ``"horizontal"`` (docs/model.md §7) or ``"horizontal_literal"`` (Eq. 24 read literally)."""
    derived_from: tuple[str, ...] = field(default=(), compare=False)
    """The single readings a combination was derived from (empty for a single reading)."""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name or self.name != self.name.strip():
            _fail(str(self.name), "name", self.name, "a non-empty name without outer spaces")
        if any(c in self.name for c in '/\\:*?"<>|'):
            _fail(self.name, "name", self.name, "a name usable as a folder name (no / \\ : * ?)")
        if not isinstance(self.description, str) or not self.description.strip():
            _fail(self.name, "description", self.description, "a one-line description")
        items = self.options.items() if isinstance(self.options, Mapping) else self.options
        try:
            pairs = tuple(sorted((str(k), v) for k, v in items))
        except (TypeError, ValueError):
            _fail(self.name, "options", self.options, "(name, value) pairs or a mapping")
        names = [k for k, _ in pairs]
        for key in names:
            if key not in DECISION_OPTIONS:
                _fail(
                    self.name,
                    "options",
                    key,
                    f"ModelOptions fields that are modelling decisions: {', '.join(DECISION_OPTIONS)}",
                )
        if len(set(names)) != len(names):
            _fail(self.name, "options", self.options, "each option once")
        object.__setattr__(self, "options", pairs)
        try:
            ModelOptions(**dict(pairs))
        except (TypeError, ValueError) as error:
            raise ValueError(f"Reading {self.name!r}: {error}") from None
        c_r = self.rotational_coefficient
        if c_r is not None and (
            isinstance(c_r, bool)
            or not isinstance(c_r, int | float)
            or not math.isfinite(c_r)
            or c_r < 0
        ):
            _fail(self.name, "rotational_coefficient", c_r, "None or a finite number >= 0")
        if self.horizontal_objective not in HORIZONTAL_OBJECTIVES:
            _fail(
                self.name,
                "horizontal_objective",
                self.horizontal_objective,
                ", ".join(map(repr, HORIZONTAL_OBJECTIVES)),
            )

    @property
    def model_options(self) -> ModelOptions:
        """The model options of this reading (defaults elsewhere)."""
        return ModelOptions(**dict(self.options))

    def changes(self) -> dict[str, Any]:
        """What differs from the documented default, e.g. ``{"thrust_split": "body"}``."""
        default = ModelOptions()
        out = {k: v for k, v in self.options if getattr(default, k) != v}
        c_r = self.rotational_coefficient
        if c_r is not None and c_r != DEFAULT_ROTATIONAL:
            out["rotational_coefficient"] = float(c_r)
        if self.horizontal_objective != "horizontal":
            out["horizontal_objective"] = self.horizontal_objective
        return out

    @classmethod
    def from_changes(
        cls,
        name: str,
        description: str,
        changes: Mapping[str, Any],
        derived_from: tuple[str, ...] = (),
    ) -> Reading:
        """The reading whose :meth:`changes` are ``changes`` (the inverse of that method)."""
        options = dict(changes)
        c_r = options.pop("rotational_coefficient", None)
        horizontal = options.pop("horizontal_objective", "horizontal")
        return cls(
            name,
            description,
            options=tuple(options.items()),
            rotational_coefficient=c_r,
            horizontal_objective=horizontal,
            derived_from=derived_from,
        )

    def env_kwargs(self) -> dict[str, Any]:
        """The env keywords of this reading's model (``gym.make`` names): only the options
        that differ from the defaults, so a reading that restates a default has the default's
        job keys."""
        changed = self.changes()
        changed.pop("horizontal_objective", None)
        out = {}
        for key, value in changed.items():
            if key == "rotational_coefficient":
                out[key] = value
            elif key in _KWARG_OF:
                out[_KWARG_OF[key]] = value
            else:
                raise ValueError(
                    f"Reading {self.name!r}: option {key!r} has no env keyword "
                    f"(tandem_env.envs.config.MODEL_OPTION_KWARGS); allowed: "
                    f"{', '.join(sorted(_KWARG_OF))}"
                )
        return out

    def objective(self, objective: str) -> str:
        """The accelerating objective a study's ``objective`` becomes under this reading."""
        return self.horizontal_objective if objective == "horizontal" else objective

    def conflicts(self, other: Reading) -> list[str]:
        """The options both readings set to different values (they cannot be combined)."""
        mine, theirs = self.changes(), other.changes()
        return sorted(k for k in mine.keys() & theirs.keys() if mine[k] != theirs[k])

    def describe_changes(self) -> str:
        """``thrust_split=body, power=elastic`` (``-`` for the default)."""
        return ", ".join(f"{k}={_short(v)}" for k, v in self.changes().items()) or "-"


def _short(value: Any) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


DEFAULT = Reading(
    "default",
    "the documented defaults (docs/model.md): sign thrust split, absolute power, pitch spin, "
    "C_r = π, coupled momentum inflow with C_hf = 1, F̄_h = max F̄_h s.t. F̄_v ≥ 0",
)


def combine(readings: tuple[Reading, ...] | list[Reading], name: str | None = None) -> Reading:
    """One reading with every change of ``readings``; raises ValueError if two conflict."""
    merged: dict[str, Any] = {}
    for reading in readings:
        for key, value in reading.changes().items():
            if key in merged and merged[key] != value:
                raise ValueError(
                    f"readings {', '.join(r.name for r in readings)} conflict on {key}: "
                    f"{merged[key]!r} vs {value!r}"
                )
            merged[key] = value
    names = tuple(r.name for r in readings)
    return Reading.from_changes(
        name or " + ".join(names),
        "combination of " + "; ".join(r.description for r in readings),
        merged,
        derived_from=names,
    )
