"""What an entry point (``python -m train``, ``python -m eval``, their console scripts) does
around its first import of ``tandem_env``, which checks numba's environment variables and
raises a ValueError naming a bad one: before the shared ``command_line`` wrapper can catch it.
This module imports nothing of the project.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator


@contextlib.contextmanager
def exit_on_bad_environment(program: str) -> Iterator[None]:
    """Run the ``with`` block; a ValueError it raises is ``PROGRAM: error: ...`` and status 2."""
    try:
        yield
    except ValueError as error:
        print(f"{program}: error: {error}", file=sys.stderr)
        raise SystemExit(2) from None
