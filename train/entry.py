"""What the entry points (``python -m train``, ``python -m eval``, ... and their console scripts)
share. Their first import of ``tandem_env`` checks numba's environment before numba reads it
(``tandem_env.io.command.check_numba_environment``) and raises a ValueError naming the bad
variable before ``tandem_env.io.command.command_line`` can be imported to catch it:
:func:`exit_on_bad_environment` does (so this module imports nothing of the project, and is not
in ``tandem_env.io``, whose import it guards). Command lines made from frozen dataclasses
(:func:`command`): each field one option, declared once by :func:`option`, its help the field's
docstring; the dataclass's ``__post_init__`` checks the values, and a ValueError it raises is
the usage error (exit status 2).
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import inspect
import itertools
import sys
import textwrap
from collections.abc import Iterator, Sequence
from dataclasses import MISSING, field, fields
from typing import Any, TypeVar

T = TypeVar("T")
#: Metadata of :func:`option` that is not an argparse setting.
_OWN = ("flags", "off", "amortised", "cli_default", "check")


def option(*flags: str, default: Any = MISSING, factory: Any = MISSING, **settings: Any) -> Any:
    """A field and its option: ``flags`` (none: only ``off``, the flag that turns a True default
    off), argparse ``settings`` (``cli_default``: the command line's default of a field without
    one), ``amortised=True`` where ``python -m train --algo amortised`` takes it too, ``check``
    the function ``check(value, name)`` that checks a value given (not None) and returns it as
    the field holds it; its help is the field's docstring."""
    return field(default=default, default_factory=factory, metadata={"flags": flags, **settings})


def field_docs(cls: type) -> dict[str, str]:
    """The docstring under each field of the dataclass ``cls``, read from its source, one line
    each (the help of its options)."""
    body = ast.parse(textwrap.dedent(inspect.getsource(cls))).body[0].body  # type: ignore[attr-defined]
    return {
        node.target.id: " ".join(doc.value.value.split())
        for node, doc in itertools.pairwise(body)
        if isinstance(node, ast.AnnAssign)
        and isinstance(node.target, ast.Name)
        and isinstance(doc, ast.Expr)
        and isinstance(doc.value, ast.Constant)
    }


def build_parser(cls: type, exclusive: Sequence[str] = (), **settings: Any) -> Any:
    """An ``argparse.ArgumentParser(**settings)`` with one option per field of ``cls`` (those
    in ``exclusive`` exclude each other), typed by the field's type: a ``bool`` is a switch, a
    ``Mapping`` takes ``KEY=VALUE`` pairs, an ``int`` / ``tuple[float, ...]`` its numbers."""
    from tandem_env.io.keyvalue import KeyValuePairs  # here: importing this module imports none

    parser = argparse.ArgumentParser(**settings)
    group = parser.add_mutually_exclusive_group() if exclusive else parser
    docs = field_docs(cls)
    for spec in fields(cls):
        target = group if spec.name in exclusive else parser
        meta = spec.metadata
        kind = str(spec.type)
        kwargs = {k: v for k, v in meta.items() if k not in _OWN}
        empty = {} if kind.startswith("Mapping") else None
        default = kwargs["default"] = meta.get(
            "cli_default", empty if spec.default is MISSING else spec.default
        )
        help_text = docs[spec.name].replace("%", "%%")
        if not any(default is v for v in (None, True, False)) and default != {}:
            help_text = help_text.removesuffix(".") + " (default %(default)s)"
        if kind == "bool":
            if "off" in meta:  # a switch that is on by default
                target.add_argument(
                    meta["off"], dest=spec.name, action="store_false", help=f"off: {help_text}"
                )
                help_text = "(the default)"
            kwargs["action"] = "store_true"
        elif kind.startswith("Mapping"):
            kwargs.update(nargs="+", metavar="KEY=VALUE", action=KeyValuePairs)
        elif kind.startswith("tuple"):
            kwargs.update(nargs="+", type=float if "float" in kind else str)
        elif kind.startswith("int"):
            kwargs["type"] = int
        if meta["flags"]:
            required = "cli_default" not in meta and MISSING is spec.default is spec.default_factory
            target.add_argument(
                *meta["flags"], dest=spec.name, required=required, help=help_text, **kwargs
            )
    return parser


@contextlib.contextmanager
def command(cls: type[T], argv: Sequence[str] | None, **settings: Any) -> Iterator[T]:
    """``cls`` of the command line ``argv`` for the ``with`` block, parsed by the parser of
    ``cls`` (:func:`build_parser`; ``prog`` ``python -m <its module>`` and its docstring's first
    line the description, unless given); a ValueError making it or in the block is the parser's
    usage error (one line, exit status 2)."""
    module = getattr(sys.modules[cls.__module__].__spec__, "name", cls.__module__)  # not __main__
    settings.setdefault("prog", f"python -m {module}")
    settings.setdefault("description", (cls.__doc__ or "").split("\n\n")[0])
    parser = build_parser(cls, **settings)
    args = parser.parse_args(argv)
    try:
        yield cls(**{f.name: getattr(args, f.name) for f in fields(cls)})
    except ValueError as error:
        parser.error(str(error))


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
