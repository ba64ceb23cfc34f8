"""What ``python -m eval study NAME`` runs: a campaign, behind one protocol (:class:`Campaign`):
a plan (:class:`StudyRun`, run by :func:`agents.runner.run_plan`; its look-ahead gives the whole
command's cost, :class:`agents.progress.CommandProgress`) and a report.

:func:`campaigns` maps every study name the command offers to its campaign: ``all`` and each
study of :data:`eval.studies.STUDIES` (read when called, so a study registered there is
offered) to the suite (:data:`eval.studies.suite.SUITE`), and ``readings`` to the readings
study (:data:`eval.studies.readings.campaign.READINGS`). A new campaign is one object with this
protocol and its entry in :data:`CAMPAIGNS`; :mod:`eval.study` knows none of them by name.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from typing import Any, Protocol

from agents.runner import Plan, PlanRun
from agents.store import RecordStore
from eval.studies.base import StudyPlan
from eval.studies.readings.campaign import READINGS
from eval.studies.suite import SUITE


class StudyRun(Plan, Protocol):
    """A campaign's plan for one command: its phases (:class:`agents.runner.Plan`), the
    :class:`StudyPlan` its jobs come from, the title of its first line, and what it writes once
    run."""

    plan: StudyPlan
    title: str

    def finish(self, run: PlanRun) -> Any:
        """Analyse ``run`` (this plan's, run), write the outputs and return the result."""


class Campaign(Protocol):
    """A study the command line runs (:mod:`eval.study`): a plan and a report, with its lines of
    the command's help."""

    names: tuple[str, ...]
    """The study names that choose it."""
    description: str
    """Its lines of the command's study list."""
    default_out: str
    """The output directory without ``--out``."""
    reading_help: str
    """What ``--reading`` means for it, for the option's help."""
    options: Mapping[str, dict[str, Any]]
    """Its own options (flag -> ``add_argument`` keywords, a ``default`` each): refused for
    another study when given."""

    def plan(self, args: argparse.Namespace, plan: StudyPlan, out: RecordStore) -> StudyRun:
        """Its plan into the store ``out``; ValueError naming a bad option, before any work."""

    def report(self, args: argparse.Namespace, result: Any) -> None:
        """Print what the run did (stderr) and found (stdout)."""


#: The campaigns, in the order of the command's help.
CAMPAIGNS: tuple[Campaign, ...] = (SUITE, READINGS)


def campaigns() -> dict[str, Campaign]:
    """Every study name the command offers -> its campaign (the names read now)."""
    return {name: campaign for campaign in CAMPAIGNS for name in campaign.names}


__all__ = ["CAMPAIGNS", "Campaign", "StudyRun", "campaigns"]
