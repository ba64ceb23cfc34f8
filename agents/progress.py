"""Progress of a long search on stderr: iterations, evaluations, best so far, time left (tqdm)."""

from __future__ import annotations

import sys

from tqdm.auto import tqdm

__all__ = ["ProgressBar"]


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
                file=sys.stderr,
                dynamic_ncols=True,
                mininterval=0.5,
                leave=True,
            )
            if enabled
            else None
        )

    def update(self, iteration: int, evaluations: int, best: float) -> None:
        """Move the bar to ``evaluations`` and show the iteration and best reward so far."""
        if self._bar is None:
            return
        # Absolute position, so methods that report irregularly (RL training) still work.
        self._bar.update(evaluations - self._bar.n)
        self._bar.set_postfix_str(f"iter {iteration}, best {best:.5g}", refresh=False)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
