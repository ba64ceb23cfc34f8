"""The one message of the model's first use: numba compiles its kernels then.

The first model call of a process on a cold numba cache compiles the kernels (30-60 s on a
2-core machine, README "First use"; numba caches them beside the sources, so later processes load
them in about a second; a call with other argument types compiles its own once more). :func:`compile_notice` wraps a model call: if the first one is still running after
:data:`NOTICE_AFTER` seconds (so a warm cache, which loads in less, stays silent), the
``tandem_env`` logger says once per process, at level WARNING, that the model is compiling and
how long that takes. Silence it with ``logging.getLogger("tandem_env").setLevel(logging.ERROR)``.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Iterator

__all__ = ["COMPILE_MESSAGE", "LOGGER", "NOTICE_AFTER", "compile_notice"]

LOGGER = logging.getLogger("tandem_env")
#: Seconds a first model call may take before the notice (a warm cache loads in less) [s].
NOTICE_AFTER = 3.0
COMPILE_MESSAGE = (
    "tandem_env: compiling the model's kernels on first use (numba; 30-60 s on 2 cores, once "
    "per code path: they are cached for later runs)"
)

_state = {"first_call_done": False, "announced": False}
_lock = threading.Lock()


def _announce() -> None:
    with _lock:
        if _state["announced"]:
            return
        _state["announced"] = True
    LOGGER.warning(COMPILE_MESSAGE)


@contextlib.contextmanager
def compile_notice(after: float = NOTICE_AFTER) -> Iterator[None]:
    """Say :data:`COMPILE_MESSAGE` if the first model call of this process runs longer than
    ``after`` seconds [s]; later calls pass through untouched."""
    if _state["first_call_done"]:
        yield
        return
    timer = threading.Timer(after, _announce)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
        _state["first_call_done"] = True
