"""What every command line shares around its ``main`` (:func:`run_command`): streams that carry
any character, a closed stream given the null device, standard error a
:class:`~tandem_env.io.progress_bar.QuietStream`; a quiet end (status 1) when the reader of
standard output goes away, one line (status 1) for an ``OSError`` of the machine and one line
(status 2) for a bad numba setting (:func:`check_numba_environment`).
"""

from __future__ import annotations

import argparse
import functools
import io
import os
import sys
from collections.abc import Callable, Mapping
from typing import Any, ParamSpec

from .progress_bar import QuietStream

P = ParamSpec("P")

#: The values of ``NUMBA_THREADING_LAYER`` numba knows (its documentation, "Selecting a
#: threading layer"): the three layers and the three kinds of safety that choose among them.
NUMBA_THREADING_LAYERS = ("default", "safe", "forksafe", "threadsafe", "tbb", "omp", "workqueue")


class EnvironmentSettingError(ValueError):
    """An environment variable the project's dependencies read holds a value they cannot use."""


def check_numba_environment(environ: Mapping[str, str] | None = None) -> None:
    """Check the numba variables of ``environ`` (default ``os.environ``) before numba, which
    fails deep in its import, reads them: :class:`EnvironmentSettingError` naming one."""
    environ = os.environ if environ is None else environ
    threads = environ.get("NUMBA_NUM_THREADS")
    if threads is not None and threads.strip():
        try:
            count = int(threads)
        except ValueError:
            count = 0
        if count < 1:
            raise EnvironmentSettingError(
                f"environment NUMBA_NUM_THREADS={threads!r}; allowed: a whole number >= 1 of "
                "numba threads, or unset (numba's default: one per CPU)"
            )
    layer = environ.get("NUMBA_THREADING_LAYER")
    if layer is not None and layer.strip() and layer.strip().lower() not in NUMBA_THREADING_LAYERS:
        raise EnvironmentSettingError(
            f"environment NUMBA_THREADING_LAYER={layer!r}; allowed: "
            f"{', '.join(NUMBA_THREADING_LAYERS)}, or unset"
        )


def _program() -> str:
    """The command as typed: ``tandem-study``, ``python -m eval``, ``python -m train.envelope``."""
    path = sys.argv[0] if sys.argv and sys.argv[0] else ""
    name, folder = os.path.basename(path), os.path.basename(os.path.dirname(path))
    if name.startswith("tandem-"):
        return name
    if name == "__main__.py":
        return f"python -m {folder}"
    if name.endswith(".py"):
        return f"python -m {folder}.{name[:-3]}"
    return "python"


def run_command(main: Callable[[], int | None], program: str | None = None) -> int:
    """Run a command line's ``main()`` with the shared handling of the module docstring; its
    exit status. ``program`` names the command in an error line (default the script's name)."""
    for name in ("stdout", "stderr"):  # streams that carry any character
        stream = getattr(sys, name)
        if stream is None:  # closed when Python started (2>&-)
            setattr(sys, name, open(os.devnull, "w", encoding="utf-8"))
        elif isinstance(stream, io.TextIOWrapper):
            stream.reconfigure(errors="backslashreplace")
    stderr = sys.stderr
    sys.stderr = QuietStream(stderr)  # type: ignore[assignment]
    try:
        check_numba_environment()
        status = int(main() or 0)
        sys.stdout.flush()  # here, where a reader that went away is handled, not at exit
        return status
    except EnvironmentSettingError as error:
        print(f"{program or _program()}: error: {error}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # the reader of standard output went away
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError):  # no file descriptor behind it
            sys.stdout = open(os.devnull, "w", encoding="utf-8")
        finally:
            os.close(devnull)
        return 1
    except OSError as error:
        # the machine, not the input (a disk that fills, a folder made read-only during the
        # run): every file is written atomically, so what is on disk is whole; say what failed
        where = f"{error.filename}: " if error.filename else ""
        print(
            f"{program or _program()}: error: {where}{error.strerror or error}; files already "
            "written are kept whole: fix that and run the same command again",
            file=sys.stderr,
        )
        return 1
    finally:
        sys.stderr = stderr


def command_line(main: Callable[P, int | None]) -> Callable[P, int]:
    """Decorate an entry point's ``main(argv)`` with :func:`run_command`."""

    @functools.wraps(main)
    def wrapped(*args: P.args, **kwargs: P.kwargs) -> int:
        return run_command(lambda: main(*args, **kwargs))

    return wrapped


def checked_by(convert: Callable[..., Any], *, with_option: bool = False) -> type[argparse.Action]:
    """An argparse action converting the option's value with ``convert`` (``convert(value,
    option)`` where ``with_option``); its ValueError is the usage error (status 2), prefixed
    with the option where it does not name it."""

    class Checked(argparse.Action):
        def __call__(
            self,
            parser: argparse.ArgumentParser,
            namespace: argparse.Namespace,
            values: Any,
            option_string: str | None = None,
        ) -> None:
            option = option_string or self.dest
            try:
                given = (values, option) if with_option else (values,)
                setattr(namespace, self.dest, convert(*given))
            except ValueError as error:
                text = str(error)
                parser.error(text if option in text else f"{option}: {text}")

    Checked.__name__ = f"checked_by_{getattr(convert, '__name__', 'convert')}"
    return Checked
