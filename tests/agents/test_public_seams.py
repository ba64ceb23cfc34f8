"""The polish and the harness read an env through its public problem view (``env.problem()``,
tandem_env/envs/problem.py), never through its core or another object's private attributes."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MODULES = [
    "agents/polish.py",
    "agents/polish_config.py",
    "agents/harness.py",
]
#: The env's internals the polish used to reach for: its batched core.
INTERNALS = {"core"}


def private_reach(source: str) -> list[str]:
    """Each ``x.name`` or ``getattr(x, "name")`` of ``source`` where name is an env internal
    (:data:`INTERNALS`) or private (``_name``, not a dunder) on anything but ``self``/``cls``."""

    def reaches(name: str) -> bool:
        private = name.startswith("_") and not name.startswith("__")
        return name in INTERNALS or private

    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute):
            owner = node.value.id if isinstance(node.value, ast.Name) else None
            if reaches(node.attr) and (owner not in ("self", "cls") or node.attr in INTERNALS):
                found.append(f"line {node.lineno}: .{node.attr}")
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("getattr", "hasattr")
            and len(node.args) >= 2
            and isinstance(node.args[1], ast.Constant)
            and isinstance(node.args[1].value, str)
            and reaches(node.args[1].value)
        ):
            found.append(f"line {node.lineno}: {node.func.id}(..., {node.args[1].value!r})")
    return found


def test_the_checker_finds_each_kind_of_reach():
    bad = (
        "core = env.unwrapped.core\n"
        "declared = getattr(core, 'core', None)\n"
        "batch = vector._step(index, actions)\n"
        "ok = self._spend(1) or env.unwrapped.problem() or np.__version__\n"
    )
    assert private_reach(bad) == [
        "line 1: .core",
        "line 2: getattr(..., 'core')",
        "line 3: ._step",
    ]


@pytest.mark.parametrize("module", MODULES)
def test_no_private_reach_into_the_env(module):
    assert private_reach((ROOT / module).read_text(encoding="utf-8")) == []
