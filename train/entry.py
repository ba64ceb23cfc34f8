"""What an entry point (``python -m train``, ``python -m train.envelope``, ``python -m eval`` and
their console scripts) does around its first import of ``tandem_env``.

Importing ``tandem_env`` imports numba, which reads its environment as it is imported; the
package checks those variables first (``tandem_env.io.command.check_numba_environment``) and
raises a ValueError naming the bad one, before the shared wrapper of the command lines
(``tandem_env.io.command.command_line``) can be imported to catch it:
:func:`exit_on_bad_environment` does, around that import. It lives here, not in
``tandem_env.io``, because importing anything of ``tandem_env`` is the import it guards; this
module imports nothing of the project.
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
