"""What an entry point (``python -m train``, ``python -m train.envelope``, ``python -m eval`` and
their console scripts) does around its first import of ``tandem_env``, which imports numba, which
reads its environment as it is imported: the package checks those variables first and raises a
ValueError naming the bad one before ``tandem_env.io.command.command_line`` (the shared wrapper
that would catch it) can be imported. It lives here, not in ``tandem_env.io``, because importing
anything of ``tandem_env`` is the import it guards; this module imports nothing of the project.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator


@contextlib.contextmanager
def exit_on_bad_environment(program: str) -> Iterator[None]:
    """Run the ``with`` block (an entry point's first import of ``tandem_env``); a ValueError
    it raises (a numba setting numba cannot use) ends the process with one line,
    ``PROGRAM: error: ...``, on standard error and exit status 2, without a traceback.
    ``program``: the command as the error line names it (``python -m eval``)."""
    try:
        yield
    except ValueError as error:
        print(f"{program}: error: {error}", file=sys.stderr)
        raise SystemExit(2) from None
