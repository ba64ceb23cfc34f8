"""Reading a user's data files: UTF-8 text and YAML through the safe loader (plain data only).

:func:`read_text` refuses what is not UTF-8 text (UTF-16, binary), naming the file and what is
allowed; :func:`read_yaml` parses with :class:`DataLoader`, YAML's safe loader (it never builds
Python objects) with two fixes for hand-written files. Errors are :class:`DataFileError`, a
``ValueError`` whose message names the file and the fault.
"""

from __future__ import annotations

import collections.abc
import os
import re
from pathlib import Path
from typing import Any

import yaml

__all__ = ["DataFileError", "DataLoader", "read_text", "read_yaml"]


class DataFileError(ValueError):
    """A data file that cannot be read or parsed; the message names the file and the fault."""


class DataLoader(yaml.SafeLoader):
    """YAML's safe loader (plain data only) with two fixes for hand-written data files.

    * YAML 1.2 numbers: PyYAML reads YAML 1.1, where ``1e-4`` and ``34e0`` (no dot, or no sign
      in the exponent) are strings; they are floats here, as in YAML 1.2 and every spreadsheet.
    * Duplicate keys are refused, naming the key and its line (YAML 1.1 loaders keep the
      last one silently, so a pasted second ``speed:`` would win without a word).
    """

    def construct_mapping(self, node: yaml.Node, deep: bool = False) -> dict[Any, Any]:
        if isinstance(node, yaml.MappingNode):
            seen: dict[Any, int] = {}
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=True)
                if not isinstance(key, collections.abc.Hashable):
                    continue  # reported by the base class
                line = key_node.start_mark.line + 1
                if key in seen:
                    raise yaml.constructor.ConstructorError(
                        None,
                        None,
                        f"duplicate key {key!r} on lines {seen[key]} and {line}; allowed: each "
                        "key once per mapping",
                        key_node.start_mark,
                    )
                seen[key] = line
        return super().construct_mapping(node, deep=deep)


DataLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$"),
    list("-+.0123456789"),
)


def read_text(path: str | os.PathLike[str], where: str) -> str:
    """A file's text: UTF-8 (a BOM allowed), no NUL bytes; errors say what the file is
    (``where``, e.g. ``"kinematics file"``)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise DataFileError(
            f"{where} {str(path)!r} cannot be read ({exc.strerror or exc})"
        ) from None
    if data.startswith((b"\xff\xfe", b"\xfe\xff")) or b"\x00" in data[:4096]:
        kind = "UTF-16 text" if data.startswith((b"\xff\xfe", b"\xfe\xff")) else "binary data"
        raise DataFileError(f"{where} {str(path)!r} holds {kind}; allowed: UTF-8 text")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataFileError(
            f"{where} {str(path)!r} is not UTF-8 text (byte {exc.start}: "
            f"{data[exc.start : exc.start + 1]!r}); allowed: UTF-8 text (save it as UTF-8)"
        ) from None


def read_yaml(path: str | os.PathLike[str], where: str, allowed: str) -> Any:
    """The plain data of a YAML file (:class:`DataLoader`); ``allowed`` says what the file
    should hold, for the messages about an empty or too deeply nested file."""
    path = Path(path)
    if not path.is_file():
        raise DataFileError(f"{where} {str(path)!r}: no such file")
    try:
        data = yaml.load(read_text(path, where), Loader=DataLoader)  # safe: plain data
    except yaml.YAMLError as exc:
        raise DataFileError(f"{str(path)!r} is not valid YAML: {exc}") from None
    except RecursionError:
        raise DataFileError(f"{str(path)!r} nests too deeply; allowed: {allowed}") from None
    if data is None:
        raise DataFileError(f"{str(path)!r} is empty; allowed: {allowed}")
    return data
