"""An entry point's (``python -m train``, ``python -m eval``, ... and their console scripts) first
import of ``tandem_env``, which checks numba's environment before numba reads it
(``tandem_env.io.command.check_numba_environment``) and raises a ValueError naming the bad
variable before ``tandem_env.io.command.command_line`` can be imported to catch it:
:func:`exit_on_bad_environment` does. It imports nothing of the project (not in
``tandem_env.io``: importing that is the import it guards).
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator


@contextlib.contextmanager
def exit_on_bad_environment(program: str) -> Iterator[None]:
    """Run the ``with`` block; a ValueError it raises (a numba setting numba cannot use) ends the
    process with one line, ``PROGRAM: error: ...`` (``program``: ``python -m eval``), on
    standard error and exit status 2, without a traceback."""
    try:
        yield
    except ValueError as error:
        print(f"{program}: error: {error}", file=sys.stderr)
        raise SystemExit(2) from None
