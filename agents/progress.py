"""A plan's phases and the whole command's cost over them (:func:`agents.runner.run_plan`)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from agents.jobs import Job
from agents.record_cache import CacheOption, cacheable, record_cache
from agents.store import RecordStore
from tandem_env.io.progress_bar import QuietStream


@dataclass(frozen=True)
class Phase:
    """One phase of a plan (:func:`agents.runner.run_plan`): its jobs as known now."""

    name: str
    jobs: tuple[Job, ...]
    provisional: frozenset[str] = frozenset()
    """Keys of stand-ins for jobs an earlier phase's results decide (budgets right, keys not
    final: :meth:`agents.jobs.Continuation.job`): counted as to run."""
    later: str = ""
    """What follows this phase that no look-ahead can count before it has run (the readings
    study's combinations), said as ``then ...`` on the cost line."""


def _duration(seconds: float) -> str:
    if seconds < 1:
        return "under 1 s"
    for limit, scale, unit in ((90, 1, "s"), (90 * 60, 60, "min")):
        if seconds < limit:
            return f"{seconds / scale:.0f} {unit}"
    return f"{seconds / 3600:.1f} h"


class CommandProgress:
    """The whole cost of a command of several phases (:func:`~agents.runner.run_plan`), said
    on stderr before any work (:meth:`announce`) and at each phase's start (:meth:`start`):
    jobs stored, cached and to run, their evaluations and the time left at the rate so far."""

    def __init__(
        self,
        title: str,
        out: str | os.PathLike[str] | RecordStore,
        *,
        cache: CacheOption = True,
        enabled: bool = True,
        detail: str = "",
        rerun: bool = False,
    ) -> None:
        self.title = title
        self.name = title.partition(" (")[0]
        """The title less its parenthesis, as the phase lines name the command."""
        self.detail = detail
        self._store = RecordStore.at(out)
        self.out_dir = self._store.directory
        self._cache = None if rerun else record_cache(cache)
        self.rerun = rerun
        self.enabled = enabled
        self._phases: dict[str, Phase] = {}
        self._done: set[str] = set()
        self._evaluations = 0
        self._seconds = 0.0
        self.lines: list[str] = []
        """Every line said, in order (what a test or a log reads)."""

    def _plan(self, phases: Sequence[Phase], started: Sequence[Phase] = ()) -> None:
        """The look-ahead's ``phases``, each of those ``started`` in its place (or after)."""
        self._phases = {p.name: p for p in phases} | {p.name: p for p in started}

    def counts(self) -> dict[str, int]:
        """The command's jobs by state (``done``, ``stored``, ``cached``, ``todo``: stand-ins
        too), with ``evaluations`` and ``todo_evaluations``."""
        jobs: dict[str, tuple[Job, bool]] = {}
        for phase in self._phases.values():
            for job in phase.jobs:
                provisional = job.key in phase.provisional
                if job.key not in jobs or not provisional:
                    jobs[job.key] = (job, provisional)
        counts = dict.fromkeys(("done", "stored", "cached", "todo"), 0)
        counts |= {"evaluations": 0, "todo_evaluations": 0}
        for key, (job, provisional) in jobs.items():
            counts["evaluations"] += job.budget
            if key in self._done:
                state = "done"
            elif provisional or self.rerun:
                state = "todo"
            elif self._store.path(key).exists():
                state = "stored"
            elif self._cache is not None and cacheable(job) and self._cache.path(key).exists():
                state = "cached"
            else:
                state = "todo"
            counts[state] += 1
            if state == "todo":
                counts["todo_evaluations"] += job.budget
        return counts

    def time_left(self, evaluations: int) -> str:
        """``evaluations`` at the rate measured so far, in words."""
        if evaluations == 0:
            return "none"
        if self._evaluations == 0 or self._seconds <= 0:
            return "estimating (from the speed of the first jobs to finish)"
        rate = self._evaluations / self._seconds
        measured = f"at the {rate:,.0f} evaluations/s measured so far"
        return f"about {_duration(evaluations / rate)} ({measured})"

    def _jobs(self) -> dict[str, Job]:
        return {job.key: job for phase in self._phases.values() for job in phase.jobs}

    def _left(self, c: Mapping[str, int]) -> str:
        text = f"{c['todo']} to run ({c['todo_evaluations']:,} evaluations)"
        if later := (list(self._phases.values())[-1].later if self._phases else ""):
            text += f"; then {later}"
        return f"{text}; time left: {self.time_left(c['todo_evaluations'])}"

    def _say(self, line: str) -> None:
        self.lines.append(line)
        if self.enabled:
            QuietStream().write(line + "\n")  # one write: a bar cannot cut the line

    def announce(self, phases: Sequence[Phase]) -> None:
        """The first line: the whole command (the plan's look-ahead ``phases``) before work."""
        self._plan(phases)
        c = self.counts()
        jobs = self._jobs().values()
        seeds = sorted({job.seed for job in jobs})
        budgets = " / ".join(f"{b:,}" for b in sorted({job.budget for job in jobs}))
        count = len(self._phases)
        phases = f"{count} phases ({', '.join(self._phases)}): " if count > 1 else ""
        self._say(
            f"{self.title}: {self.detail + '; ' if self.detail else ''}{phases}"
            f"{len(jobs)} optimisations over seeds {seeds}, budgets {budgets} model evaluations "
            f"each ({c['evaluations']:,} in all); {c['stored']} stored in {self.out_dir}, "
            f"{c['cached']} in the record cache, {self._left(c)}"
        )

    def start(self, phases: Sequence[Phase], started: Sequence[Phase]) -> None:
        """The line at the start of the last phase ``started`` (none for the first)."""
        self._plan(phases, started)
        name = started[-1].name
        if (place := list(self._phases).index(name) + 1) == 1:
            return
        c = self.counts()
        finished = c["done"] + c["stored"] + c["cached"]
        self._say(
            f"phase {place}/{len(self._phases)} ({name}) of the {self.name}: "
            f"{len(self._jobs())} optimisations ({c['evaluations']:,} evaluations), "
            f"{finished} done or stored, {self._left(c)}"
        )

    def ran(self, job: Job, seconds: float) -> None:
        """A job finished, ``seconds`` [s] after the previous one (or the call's start)."""
        self._done.add(job.key)
        self._evaluations += job.budget
        self._seconds += seconds
