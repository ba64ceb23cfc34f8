"""Reading a user's data files: UTF-8 text (:func:`read_text`) and YAML through the safe loader
(:func:`read_yaml`). Every YAML text goes through :func:`parse_yaml` and a
:class:`BoundedLoader`, which refuses a text or document too large (an alias bomb before
anything is built). Errors are :class:`DataFileError`, naming the file and the fault.
"""

from __future__ import annotations

import collections.abc
import os
import re
from pathlib import Path
from typing import Any

import yaml

#: Most characters a YAML text may hold: 16 MiB, far above any data file (a 4096-sample
#: kinematics table with 20 pitch columns is under 2 MB).
MAX_YAML_CHARS = 16 * 2**20
#: Most values (scalars, sequences, mappings) a YAML document may expand to, each alias counted
#: as the whole value it repeats; 10⁶ is ten times the largest table a data file holds.
MAX_YAML_NODES = 1_000_000
_MERGE = "tag:yaml.org,2002:merge"


class DataFileError(ValueError):
    """A data file that cannot be read or parsed; the message names the file and the fault."""


class YAMLTooLarge(yaml.YAMLError):
    """A YAML text or document beyond :data:`MAX_YAML_CHARS` / :data:`MAX_YAML_NODES`."""


class BoundedLoader(yaml.SafeLoader):
    """YAML's safe loader that refuses a document expanding to more than
    :data:`MAX_YAML_NODES` values (aliases counted as what they repeat) before building it."""

    def compose_document(self) -> yaml.Node:
        """The document's node, once the values it expands to are counted, each alias in full
        (one visit per distinct node): :class:`YAMLTooLarge` beyond :data:`MAX_YAML_NODES`,
        or for a node that holds itself."""
        sizes: dict[int, int] = {}
        open_nodes: set[int] = set()

        def size(node: yaml.Node) -> int:
            key = id(node)
            if key in sizes:
                return sizes[key]
            if key in open_nodes:
                raise YAMLTooLarge(f"an alias refers to a value that holds it (line {_line(node)})")
            open_nodes.add(key)
            children = list(node.value) if isinstance(node, yaml.SequenceNode) else []
            if isinstance(node, yaml.MappingNode):
                children = [item for pair in node.value for item in pair]
            total = 1
            for child in children:
                total += size(child)
                if total > MAX_YAML_NODES:
                    raise YAMLTooLarge(
                        f"it expands to more than {MAX_YAML_NODES:,} values (aliases counted as "
                        f"what they repeat; line {_line(node)}); allowed: at most "
                        f"{MAX_YAML_NODES:,}"
                    )
            open_nodes.discard(key)
            sizes[key] = total
            return total

        node = super().compose_document()
        size(node)
        return node


def _line(node: yaml.Node) -> int:
    return node.start_mark.line + 1 if node.start_mark is not None else 0


def parse_yaml(text: str, loader: type[BoundedLoader]) -> Any:
    """The plain data of a YAML ``text`` read with ``loader`` (a :class:`BoundedLoader`);
    :class:`YAMLTooLarge` for a text or document too large."""
    if not (isinstance(loader, type) and issubclass(loader, BoundedLoader)):
        raise TypeError(f"loader = {loader!r}; allowed: a subclass of BoundedLoader")
    if len(text) > MAX_YAML_CHARS:
        raise YAMLTooLarge(
            f"it holds {len(text):,} characters; allowed: at most {MAX_YAML_CHARS:,}"
        )
    return yaml.load(text, Loader=loader)  # a safe loader: plain data only


class DataLoader(BoundedLoader):
    """YAML's safe loader (plain data only) with two fixes for hand-written data files.

    * YAML 1.2 numbers: PyYAML reads YAML 1.1, where ``1e-4`` and ``34e0`` (no dot, or no sign
      in the exponent) are strings; they are floats here, as in YAML 1.2 and every spreadsheet.
    * Duplicate keys are refused, naming the key and its line (YAML 1.1 loaders keep the
      last one silently, so a pasted second ``speed:`` would win without a word). A key
      merged in (``<<: *anchor``) and given again beside it is an override, not a duplicate.
    """

    def construct_mapping(self, node: yaml.Node, deep: bool = False) -> dict[Any, Any]:
        if isinstance(node, yaml.MappingNode):
            seen: dict[Any, int] = {}
            for key_node, _ in node.value:
                if key_node.tag == _MERGE:
                    continue  # the merge key has no value of its own: the base class merges
                key = self.construct_object(key_node, deep=True)
                if not isinstance(key, collections.abc.Hashable):
                    continue  # reported by the base class
                line = key_node.start_mark.line + 1
                if key in seen:
                    twice = f"duplicate key {key!r} on lines {seen[key]} and {line}"
                    problem = f"{twice}; allowed: each key once per mapping"
                    raise yaml.constructor.ConstructorError(
                        None, None, problem, key_node.start_mark
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
    name = f"{where} {str(path)!r}"
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise DataFileError(f"{name} cannot be read ({exc.strerror or exc})") from None
    utf16 = data.startswith((b"\xff\xfe", b"\xfe\xff"))
    if utf16 or b"\x00" in data[:4096]:
        kind = "UTF-16 text" if utf16 else "binary data"
        raise DataFileError(f"{name} holds {kind}; allowed: UTF-8 text")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataFileError(
            f"{name} is not UTF-8 text (byte {exc.start}: "
            f"{data[exc.start : exc.start + 1]!r}); allowed: UTF-8 text (save it as UTF-8)"
        ) from None


def read_yaml(path: str | os.PathLike[str], where: str, allowed: str) -> Any:
    """The plain data of a YAML file (:class:`DataLoader`); ``allowed`` says what the file
    should hold, for the messages about an empty or too deeply nested file."""
    path = Path(path)
    if not path.is_file():
        raise DataFileError(f"{where} {str(path)!r}: no such file")
    if path.stat().st_size > 4 * MAX_YAML_CHARS:  # a UTF-8 character is at most 4 bytes
        raise DataFileError(
            f"{where} {str(path)!r} holds {path.stat().st_size:,} bytes; allowed: a YAML text "
            f"of at most {MAX_YAML_CHARS:,} characters"
        )
    try:
        data = parse_yaml(read_text(path, where), DataLoader)
    except YAMLTooLarge as exc:
        raise DataFileError(f"{where} {str(path)!r} is refused: {exc}") from None
    except yaml.YAMLError as exc:
        raise DataFileError(f"{str(path)!r} is not valid YAML: {exc}") from None
    except RecursionError:
        raise DataFileError(f"{str(path)!r} nests too deeply; allowed: {allowed}") from None
    if data is None:
        raise DataFileError(f"{str(path)!r} is empty; allowed: {allowed}")
    return data
