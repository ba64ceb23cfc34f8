"""Fixtures of the whole suite."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from agents.store import CACHE_ENV


@pytest.fixture(scope="session", autouse=True)
def session_record_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """The record cache (agents.store.cache_directory) of the session's module- and
    session-scoped fixtures, set before any of them runs: never the user's."""
    folder = tmp_path_factory.mktemp("session-record-cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv(CACHE_ENV, str(folder))
        yield folder


@pytest.fixture(scope="session", autouse=True)
def sb3_log_folder(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """Where SB3's own logger writes when a test trains a model SB3 built or loaded itself (the
    project's models log through their own logger, train.saved.build_model): SB3's default
    is a new SB3-<time> folder in the system's temp dir at every learn()."""
    folder = tmp_path_factory.mktemp("sb3-logs")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("SB3_LOGDIR", str(folder))
        yield folder


@pytest.fixture(autouse=True)
def record_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Each test's own record cache, empty at its start, shared by its output folders as the
    user's is by theirs (a test that compares two computations of one job turns it off)."""
    folder = tmp_path_factory.mktemp("record-cache")
    monkeypatch.setenv(CACHE_ENV, str(folder))
    return folder
