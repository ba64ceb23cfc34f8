"""What ``python -m eval study NAME`` runs: a campaign, behind one protocol (:class:`Campaign`;
its phases give the whole command's cost, announced on the first line and updated at each
phase's start: :class:`agents.progress.CommandProgress`).

:func:`campaigns` maps every study name the command offers to its campaign: ``all`` and each
study of :data:`eval.studies.STUDIES` (read when called, so a study registered there is
offered) to the suite (:data:`eval.studies.suite.SUITE`), and ``readings`` to the readings
study (:data:`eval.studies.readings.campaign.READINGS`). A new campaign is one object with this
protocol and its entry in :data:`CAMPAIGNS`; :mod:`eval.study` knows none of them by name.
"""

from __future__ import annotations

import argparse
from typing import Any, Protocol

from agents.jobs import Job
from agents.progress import CommandProgress
from eval.studies.base import StudyPlan
from eval.studies.paper_reading import Reading
from eval.studies.readings.campaign import READINGS
from eval.studies.suite import SUITE


class Campaign(Protocol):
    """A study the command line runs (:mod:`eval.study`)."""

    @property
    def names(self) -> tuple[str, ...]:
        """The study names that choose it."""

    description: str
    """Its lines of the command's study list."""
    default_out: str
    """The output directory without ``--out``."""
    reading_help: str
    """What ``--reading`` means for it, for the option's help."""
    refuse_read_only: bool
    """Whether an output folder that cannot be written is refused even when it holds every
    record of the first phase (True: later phases write; False: the run only reports)."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """Its own options (the command adds the shared ones)."""

    def misused(self, args: argparse.Namespace) -> str | None:
        """One line if ``args`` give another study one of its own options, else None."""

    def reading(self, args: argparse.Namespace) -> Reading:
        """The reading of the plan (``--reading``); ValueError naming a bad value."""

    def first_jobs(self, args: argparse.Namespace, plan: StudyPlan) -> tuple[list[Job], str]:
        """Check its options against ``plan`` (ValueError, before any work) and return the jobs
        of its first phase and the title that announces them."""

    def plan_phases(
        self, args: argparse.Namespace, plan: StudyPlan, command: CommandProgress
    ) -> None:
        """Give ``command`` its phases as far as they are known before any work
        (:meth:`~agents.progress.CommandProgress.plan`)."""

    def run(
        self,
        args: argparse.Namespace,
        plan: StudyPlan,
        scheduler: str | None,
        command: CommandProgress,
    ) -> Any:
        """Run it into ``args.out`` (record cache ``args.cache``), telling ``command`` of each
        phase, and return its result."""

    def summarise(self, args: argparse.Namespace, result: Any) -> None:
        """Print what the run did (stderr) and found (stdout)."""


#: The campaigns, in the order of the command's help.
CAMPAIGNS: tuple[Campaign, ...] = (SUITE, READINGS)


def campaigns() -> dict[str, Campaign]:
    """Every study name the command offers -> its campaign (the names read now)."""
    return {name: campaign for campaign in CAMPAIGNS for name in campaign.names}


__all__ = ["CAMPAIGNS", "Campaign", "campaigns"]
