"""Progress of long work on stderr (tqdm): one bar class for a search and for a set of jobs.

A search reports ``(iteration, evaluations, best)`` after every iteration (:data:`Reporter`);
the job runner (``eval.studies.runner``) moves one bar over the evaluations of all its jobs
as they run (serially) or finish (on a Dask cluster), with the jobs done in its status. The
bar's rate and time left are in evaluations either way.
"""

from __future__ import annotations

import contextlib
import sys
import warnings
from collections.abc import Callable, Iterator

from tqdm.auto import tqdm

__all__ = ["ProgressBar", "Reporter", "warnings_as_lines"]

#: A search's progress callback: (iteration, evaluations so far, best reward so far).
Reporter = Callable[[int, int, float], None]


class ProgressBar:
    """A tqdm bar over model evaluations (so its rate and ETA are in evaluations).

    Parameters
    ----------
    total : int
        The budget [evaluations].
    description : str
        Label, e.g. ``"pso level speed=1.5 seed 0"``.
    enabled : bool
        False makes every call a no-op (``--quiet``).
    """

    def __init__(self, total: int, description: str, enabled: bool = True) -> None:
        self._bar = (
            tqdm(
                total=total,
                desc=description,
                unit="eval",
                unit_scale=True,
                file=sys.stderr,
                dynamic_ncols=True,
                mininterval=0.5,
                leave=True,
            )
            if enabled
            else None
        )

    def move_to(self, evaluations: int, status: str | None = None) -> None:
        """Move the bar to ``evaluations`` (absolute, so irregular reports still work)."""
        if self._bar is None:
            return
        self._bar.update(evaluations - self._bar.n)
        if status is not None:
            self._bar.set_postfix_str(status, refresh=False)

    def update(self, iteration: int, evaluations: int, best: float) -> None:
        """A search's report (:data:`Reporter`): evaluations, iteration and best reward so far."""
        self.move_to(evaluations, f"iter {iteration}, best {best:.5g}")

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@contextlib.contextmanager
def warnings_as_lines() -> Iterator[None]:
    """Within the block every warning is shown as one line on stderr, ``Category: message``,
    written through ``tqdm.write`` so that an open bar is redrawn below it instead of being cut
    (the command lines run in it; ``warnings.showwarning`` is the documented hook)."""
    previous = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        text = " ".join(str(message).split())
        tqdm.write(f"{category.__name__}: {text}", file=sys.stderr)

    warnings.showwarning = show
    try:
        yield
    finally:
        warnings.showwarning = previous
