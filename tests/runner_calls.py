"""The runner's harness calls, counted: which jobs a command ran rather than reused."""

from __future__ import annotations

import pytest

from agents import runner
from agents.jobs import Job
from agents.records import Record
from agents.runner import PreparedJob


def count_harness_calls(monkeypatch: pytest.MonkeyPatch) -> list[Job]:
    """The jobs the runner hands the harness from now on (the harness still runs them)."""
    calls: list[Job] = []
    original = runner._harness_run

    def counting(prepared: PreparedJob) -> Record:
        calls.append(prepared.job)
        return original(prepared)

    monkeypatch.setattr(runner, "_harness_run", counting)
    return calls
