"""The model's first use says once that it compiles (tandem_env/physics/first_use.py)."""

from __future__ import annotations

import logging
import time

import pytest

from tandem_env.physics import first_use


@pytest.fixture()
def fresh(monkeypatch: pytest.MonkeyPatch) -> None:
    # a process whose model has not been called yet
    monkeypatch.setattr(first_use, "_state", {"first_call_done": False, "announced": False})


def test_a_slow_first_call_is_announced_once(fresh, caplog) -> None:
    with caplog.at_level(logging.WARNING, logger="tandem_env"):
        with first_use.compile_notice(after=0.05):
            time.sleep(0.5)  # a first call that compiles
        with first_use.compile_notice(after=0.0):
            time.sleep(0.2)  # later calls: nothing more
    messages = [r.getMessage() for r in caplog.records if r.name == "tandem_env"]
    assert messages == [first_use.COMPILE_MESSAGE]
    assert "30-60 s" in messages[0] and "once per code path" in messages[0]


def test_a_fast_first_call_is_silent(fresh, caplog) -> None:
    # a warm cache loads the kernels in less than the notice's delay
    with caplog.at_level(logging.WARNING, logger="tandem_env"):
        with first_use.compile_notice(after=0.5):
            pass
        time.sleep(0.7)
    assert not [r for r in caplog.records if r.name == "tandem_env"]
