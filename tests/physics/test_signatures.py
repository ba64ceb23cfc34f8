"""The physics passes its arguments in bundles (``physics.bundle``), not loose: no function in
tandem_env/physics takes more than :data:`MOST_PARAMETERS` parameters, and no compiled (numba)
function hides them behind ``*args``/``**kwargs``. A new kernel option is a field of a bundle."""

from __future__ import annotations

import ast
from pathlib import Path

import tandem_env.physics

PHYSICS = Path(tandem_env.physics.__file__).parent
#: The most parameters one function may take (``*args`` and ``**kwargs`` count one each).
MOST_PARAMETERS = 12


def parameter_counts(folder: Path) -> dict[str, tuple[int, bool, bool]]:
    """Every function, method and lambda under ``folder`` ("file:line name"): its parameters
    (``self`` included), whether it takes ``*args``/``**kwargs``, whether numba compiles it."""
    out = {}
    for path in sorted(folder.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
                continue
            a = node.args
            named = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs)
            starred = (a.vararg is not None) + (a.kwarg is not None)
            decorators = getattr(node, "decorator_list", [])
            compiled = any("njit" in ast.unparse(d) for d in decorators)
            name = getattr(node, "name", "<lambda>")
            out[f"{path.name}:{node.lineno} {name}"] = (named + starred, starred > 0, compiled)
    return out


def test_no_function_in_the_physics_takes_more_than_twelve_parameters():
    counts = parameter_counts(PHYSICS)
    assert len(counts) > 100  # the walk found the physics
    assert any(compiled for _, _, compiled in counts.values())
    too_many = {name: n for name, (n, _, _) in counts.items() if n > MOST_PARAMETERS}
    assert not too_many, f"more than {MOST_PARAMETERS} parameters (use a bundle): {too_many}"


def test_no_compiled_function_takes_args_or_kwargs():
    counts = parameter_counts(PHYSICS).items()
    starred = [name for name, (_, star, compiled) in counts if star and compiled]
    assert not starred, f"*args/**kwargs are no bundle: {starred}"
