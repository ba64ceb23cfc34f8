"""Progress of long work on stderr (tqdm): one bar class for a search and for a set of jobs,
showing what it waits for (compiling the model) until its first report."""

from __future__ import annotations

import contextlib
import sys
import warnings
from collections.abc import Callable, Iterator
from typing import Any, TextIO

from tqdm.auto import tqdm

#: A search's progress callback: (iteration, evaluations so far, best reward so far).
Reporter = Callable[[int, int, float], None]

#: What a bar waits for before its first report in a process that has not evaluated yet.
COMPILING = "compiling the model (first use)…"
#: ... and in one that has (the model is compiled): the first iteration's evaluations.
STARTING = "first iteration…"
# No rate or time left until the first report (tqdm's default format less those two).
_WAITING_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]"
_reported = False  # whether any bar of this process has had a report (the model is compiled)


class QuietStream:
    """A text stream for diagnostics whose failure never stops the work: a failed write
    silences it for good. ``stream`` None means standard error as it is at each write."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self._stream = stream
        self._failed = False

    def _target(self) -> TextIO | None:
        return None if self._failed else (self._stream or sys.stderr)

    def _call(self, name: str, *args: Any) -> Any:
        stream = self._target()
        try:
            return None if stream is None else getattr(stream, name)(*args)
        except (OSError, ValueError):  # EPIPE, EBADF, ENOSPC; ValueError: closed file
            self._failed = True
            return None

    def write(self, text: str) -> int:
        written = self._call("write", text)
        return len(text) if written is None else written

    def flush(self) -> None:
        self._call("flush")

    def isatty(self) -> bool:
        stream = self._target()
        try:
            return bool(stream is not None and stream.isatty())
        except (OSError, ValueError):
            return False

    def __eq__(self, other: object) -> bool:
        # quiet streams over one stream are one file to tqdm, whose ``write`` redraws the bars
        # of files equal to its own (a warning line then goes above an open bar)
        return isinstance(other, QuietStream) and other._stream is self._stream

    def __hash__(self) -> int:
        return hash((QuietStream, id(self._stream)))

    def __getattr__(self, name: str) -> Any:  # encoding, errors, fileno, ... of the stream
        return getattr(self._stream or sys.stderr, name)


class ProgressBar(contextlib.AbstractContextManager):
    """A tqdm bar over ``total`` model evaluations; ``enabled`` False makes every call a no-op;
    ``waiting`` is shown until its first report (default :data:`COMPILING` or :data:`STARTING`)."""

    def __init__(
        self, total: int, description: str, enabled: bool = True, waiting: str | None = None
    ) -> None:
        self._waiting = True
        self._bar: Any = None
        if enabled:
            settings = {"unit": "eval", "unit_scale": True, "dynamic_ncols": True, "leave": True}
            settings |= {"file": QuietStream(), "mininterval": 0.5, "bar_format": _WAITING_FORMAT}
            postfix = waiting or (STARTING if _reported else COMPILING)
            self._bar = tqdm(total=total, desc=description, postfix=postfix, **settings)

    def move_to(self, evaluations: int, status: str | None = None) -> None:
        """Move the bar to ``evaluations`` (absolute, so irregular reports still work)."""
        global _reported
        if self._bar is None:
            return
        if self._waiting:  # the first report: restart the clock, show rate and time left
            self._waiting = False
            _reported = True
            self._bar.set_postfix_str("", refresh=False)
            self._bar.bar_format = None
            self._bar.reset()
        self._bar.update(evaluations - self._bar.n)
        if status is not None:
            self._bar.set_postfix_str(status, refresh=False)

    def waiting(self, text: str | None = None) -> None:
        """Show ``text`` (default as at creation) until the first report, if none came yet."""
        if self._bar is not None and self._waiting:
            self._bar.set_postfix_str(text or (STARTING if _reported else COMPILING))

    def update(self, iteration: int, evaluations: int, best: float) -> None:
        """A search's report (:data:`Reporter`): evaluations, iteration and best reward so far."""
        self.move_to(evaluations, f"iter {iteration}, best {best:.5g}")

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __exit__(self, *exc: object) -> None:
        self.close()


@contextlib.contextmanager
def warnings_as_lines() -> Iterator[None]:
    """Within the block every warning is one line on stderr through ``tqdm.write``, so that an
    open bar is redrawn below it."""
    previous = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        text = " ".join(str(message).split())
        tqdm.write(f"{category.__name__}: {text}", file=QuietStream())

    warnings.showwarning = show
    try:
        yield
    finally:
        warnings.showwarning = previous
