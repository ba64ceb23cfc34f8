"""``key=value`` command-line options, parsed one way for every command (``eval``, ``train``)."""

from __future__ import annotations

import argparse
import ast
from collections.abc import Iterable
from typing import Any

import yaml

from .command import checked_by
from .datafile import BoundedLoader, parse_yaml


def parse_value(text: str) -> Any:
    """A command-line value: a Python literal if it is one (``0.1``, ``(0.25, 2.0)``,
    ``"dict(a=1)"``, ``True``), else YAML (``yes``), else the text itself (``coupled``).

    The zoo evaluates ``key:value`` with ``eval``; literals cover every value our envs and
    models take without executing code.
    """
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
        pass
    try:
        value = parse_yaml(text, BoundedLoader)  # an alias bomb is refused, not expanded
    except (yaml.YAMLError, RecursionError):  # not YAML it may read: the text itself
        return text
    return text if value is None and text.strip() not in ("", "null", "~", "None") else value


def parse_pairs(items: str | Iterable[str] | None, option: str) -> dict[str, Any]:
    """``["key=value", "other:value"]`` (or one such text) -> dict; both the zoo's ``:`` and
    ``=`` are accepted."""
    out: dict[str, Any] = {}
    for item in [items] if isinstance(items, str) else items or ():
        positions = [i for i in (item.find("="), item.find(":")) if i > 0]
        if not positions:
            raise ValueError(
                f"{option} {item!r}: expected key=value (or the zoo's key:value), e.g. "
                f"{option} speed=1.5 speed_range=(0.25,2.0)"
            )
        cut = min(positions)
        key, text = item[:cut].strip(), item[cut + 1 :]
        if not key.isidentifier():
            raise ValueError(f"{option} {item!r}: {key!r} is not a valid keyword name")
        if key in out:
            raise ValueError(f"{option}: {key!r} is given twice")
        if not text.strip():
            # an empty value would be None, i.e. "the default", said by leaving nothing out
            raise ValueError(
                f"{option} {item!r}: no value after {item[cut]!r}; allowed: {key}{item[cut]}VALUE "
                f"({key}=None for none, or leave {key} out for its default)"
            )
        out[key] = parse_value(text)
    return out


class KeyValuePairs(checked_by(parse_pairs, with_option=True)):  # type: ignore[misc]
    """``--option KEY=VALUE ...`` parsed when the command line is (:func:`parse_pairs`): the
    option's value is the dict, or the usage error (exit status 2) naming the bad pair (each
    message of :func:`parse_pairs` names the option)."""


def add_pairs_argument(parser: argparse.ArgumentParser, option: str, help: str) -> None:
    """``option KEY=VALUE ...`` on ``parser``: a dict once the command line is parsed
    (:class:`KeyValuePairs`), ``{}`` when the option is not given."""
    parser.add_argument(
        option, nargs="+", action=KeyValuePairs, default={}, metavar="KEY=VALUE", help=help
    )
