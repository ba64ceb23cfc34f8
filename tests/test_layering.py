"""The import layering of docs/architecture.md, read statically from the source with ``ast``.

Layers, lowest first (docs/architecture.md): ``tandem_env.io`` (generic I/O) <-
``tandem_env.physics`` <- ``tandem_env.envs`` (and the ``tandem_env`` package itself, which
registers the envs) <- ``agents`` <- ``train`` <- ``eval``. A module may import its own layer and
the layers below it, never one above; ``tandem_env.io`` imports nothing of the project; physics
imports none of Gymnasium, SB3, torch (but for its optional torch backend, ``torch_model``) or
matplotlib, and agents none of SB3, torch or
matplotlib; and no chain of imports between the project's modules leads back to where it
started. Inside ``eval`` the floors of :data:`EVAL_FLOORS` point one way too: the studies'
vocabulary (records, presets, readings of the paper, tables, claims) <- figures and the study
plan <- the report <- the studies (plans and their report sections) <- the commands. Every
import counts: at module level, inside a function (lazy) or under
``TYPE_CHECKING``. ``benchmarks/`` and ``examples/`` are scripts on top and may import anything.

The checker is tested on a small synthetic tree first, so that a bad import would fail it.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Layer of each package prefix (the longest matching prefix wins), lowest first.
LAYERS: dict[str, int] = {
    "tandem_env.io": 0,
    "tandem_env.physics": 1,
    "tandem_env": 2,  # the package itself and tandem_env.envs
    "tandem_env.envs": 2,
    "agents": 3,
    "train": 4,
    "eval": 5,
}
#: Third-party packages a layer must not import: prefix -> forbidden top-level names.
FORBIDDEN: dict[str, frozenset[str]] = {
    "tandem_env.io": frozenset(),
    "tandem_env.physics": frozenset({"gymnasium", "stable_baselines3", "torch", "matplotlib"}),
    # the optional torch backend: the one physics module that imports torch, only when used
    # (tests/physics/test_torch_backend.py checks that importing tandem_env does not)
    "tandem_env.physics.torch_model": frozenset({"gymnasium", "stable_baselines3", "matplotlib"}),
    "agents": frozenset({"stable_baselines3", "torch", "matplotlib"}),
}
#: The floors inside ``eval`` (the longest matching prefix wins), lowest first
#: (docs/architecture.md): a module imports its own floor and those below it.
EVAL_FLOORS: dict[str, int] = {
    # the studies' vocabulary: jobs and records, presets, readings, tables, claims
    "eval.studies.presets": 0,
    "eval.studies.paper_reading": 0,
    "eval.studies.tables": 0,
    "eval.studies.claims": 0,
    # figures, and the plan and output a study works with
    "eval.figures": 1,
    "eval.kinematics_figures": 1,
    "eval.studies.base": 1,
    # the report's generic parts
    "eval.studies.report": 2,
    # the studies: one plan (and its report section) each, the suite, the registry
    "eval.studies": 3,
    # the commands
    "eval": 4,
}
PACKAGES = ("tandem_env", "agents", "train", "eval")


def module_files(root: Path, packages: Iterable[str] = PACKAGES) -> dict[str, Path]:
    """Dotted module name -> file, for every ``.py`` file under the packages."""
    out: dict[str, Path] = {}
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = path
    return out


def imported_modules(name: str, path: Path, modules: Mapping[str, Path]) -> set[str]:
    """The project modules ``name`` (file ``path``) imports, and the top-level names of all it
    imports (for the third-party rule). ``from P import x`` depends on ``P.x`` if that is a
    module, else on ``P``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base_parts = package.split(".")
                base_parts = base_parts[: len(base_parts) - (node.level - 1)]
                base = ".".join(base_parts + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            for alias in node.names:
                target = f"{base}.{alias.name}"
                found.add(target if target in modules else base)
    return found


def _layer_of(name: str, table: Mapping[str, object]) -> str | None:
    matches = [p for p in table if name == p or name.startswith(p + ".")]
    return max(matches, key=len) if matches else None


def _project_target(name: str, modules: Mapping[str, Path]) -> str | None:
    # `import a.b.c` of a module, or an attribute of one: the longest module prefix.
    parts = name.split(".")
    for end in range(len(parts), 0, -1):
        candidate = ".".join(parts[:end])
        if candidate in modules:
            return candidate
    return None


def import_graph(root: Path, packages: Iterable[str] = PACKAGES) -> dict[str, dict[str, set[str]]]:
    """module -> {"project": project modules it imports, "external": top-level names}."""
    modules = module_files(root, packages)
    graph: dict[str, dict[str, set[str]]] = {}
    for name, path in modules.items():
        project: set[str] = set()
        external: set[str] = set()
        for target in imported_modules(name, path, modules):
            resolved = _project_target(target, modules)
            if resolved is not None:
                if resolved != name:
                    project.add(resolved)
            elif target.split(".")[0] not in packages:
                external.add(target.split(".")[0])
        graph[name] = {"project": project, "external": external}
    return graph


def layering_violations(graph: Mapping[str, Mapping[str, set[str]]]) -> list[str]:
    """Imports that point up a layer, or into a forbidden third-party package."""
    problems = []
    for name, deps in sorted(graph.items()):
        own = _layer_of(name, LAYERS)
        for target in sorted(deps["project"]):
            theirs = _layer_of(target, LAYERS)
            if own is None or theirs is None:
                continue
            if LAYERS[theirs] > LAYERS[own] or (own == "tandem_env.io" and theirs != own):
                problems.append(f"{name} imports {target} ({theirs} is above {own})")
            mine, its = _layer_of(name, EVAL_FLOORS), _layer_of(target, EVAL_FLOORS)
            if mine is not None and its is not None and EVAL_FLOORS[its] > EVAL_FLOORS[mine]:
                problems.append(f"{name} imports {target} ({its} is above {mine} in eval)")
        rule = _layer_of(name, FORBIDDEN)
        for package in sorted(deps["external"] & FORBIDDEN.get(rule or "", frozenset())):
            problems.append(f"{name} imports {package}, which {rule} must not")
    return problems


def import_cycles(graph: Mapping[str, Mapping[str, set[str]]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in sorted(graph[node]["project"]):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return components


# --- the checker on a synthetic tree ------------------------------------------------------------


def two_way_parts(graph: Mapping[str, Mapping[str, set[str]]], package: str) -> list[str]:
    """Pairs of ``package``'s direct parts (its modules and sub-packages, each taken whole)
    that import each other, ``"a <-> b"``: inside a package the parts point one way too."""

    def part(name: str) -> str | None:
        if not name.startswith(package + "."):
            return None
        return ".".join(name.split(".")[: package.count(".") + 2])

    edges = {
        (part(name), part(target))
        for name, imports in graph.items()
        for target in imports["project"]
        if part(name) and part(target) and part(name) != part(target)
    }
    return sorted(f"{a} <-> {b}" for a, b in edges if (b, a) in edges and str(a) < str(b))


def _tree(root: Path, files: Mapping[str, str]) -> Path:
    for relative, text in files.items():
        path = root / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return root


GOOD = {
    "tandem_env/__init__.py": "from .physics import model\nfrom .envs import flight\n",
    "tandem_env/io/__init__.py": "",
    "tandem_env/io/files.py": "import json\n",
    "tandem_env/physics/__init__.py": "from .model import evaluate\n",
    "tandem_env/physics/model.py": "import numpy\nfrom . import kernel\n",
    "tandem_env/physics/kernel.py": "from tandem_env.io.files import json\n",
    "tandem_env/envs/__init__.py": "",
    "tandem_env/envs/flight.py": "import gymnasium\nfrom ..physics.model import evaluate\n",
    "agents/__init__.py": "",
    "agents/harness.py": "import tandem_env.envs.flight\n",
    "train/__init__.py": "",
    "train/run.py": "from agents import harness\n",
    "eval/__init__.py": "",
    "eval/cli.py": "def main():\n    from train.run import x\nfrom eval.studies import speed\n",
    "eval/figures.py": "from eval.studies.tables import Spread\n",
    "eval/studies/report.py": "from eval.studies import claims\n",
    "eval/studies/__init__.py": "",
    "eval/studies/tables.py": "",
    "eval/studies/claims.py": "from .tables import Spread\n",
    "eval/studies/speed.py": "from eval import figures\nfrom eval.studies import report\n",
}


def test_the_checker_passes_a_good_tree(tmp_path: Path) -> None:
    graph = import_graph(_tree(tmp_path, GOOD))
    assert graph["tandem_env.envs.flight"]["project"] == {"tandem_env.physics.model"}
    assert graph["eval.cli"]["project"] == {"train.run", "eval.studies.speed"}  # lazy counts
    assert graph["train.run"]["project"] == {"agents.harness"}  # `from P import module`
    assert layering_violations(graph) == []
    assert import_cycles(graph) == []


@pytest.mark.parametrize(
    ("path", "text", "expected"),
    [
        (
            "agents/harness.py",
            "from train.run import plan\n",
            "agents.harness imports train.run (train is above agents)",
        ),
        (
            "tandem_env/physics/kernel.py",
            "if False:\n    from tandem_env.envs import flight\n",
            "tandem_env.physics.kernel imports tandem_env.envs.flight "
            "(tandem_env.envs is above tandem_env.physics)",
        ),
        (
            "tandem_env/physics/kernel.py",
            "import gymnasium.spaces\n",
            "tandem_env.physics.kernel imports gymnasium, which tandem_env.physics must not",
        ),
        (
            "tandem_env/io/files.py",
            "from tandem_env.physics import model\n",
            "tandem_env.io.files imports tandem_env.physics.model "
            "(tandem_env.physics is above tandem_env.io)",
        ),
        (
            "eval/studies/report.py",
            "from eval.studies import speed\n",
            "eval.studies.report imports eval.studies.speed "
            "(eval.studies is above eval.studies.report in eval)",
        ),
        (
            "eval/figures.py",
            "if False:\n    from eval.studies import report\n",
            "eval.figures imports eval.studies.report "
            "(eval.studies.report is above eval.figures in eval)",
        ),
        (
            "eval/studies/claims.py",
            "def f():\n    from eval.figures import x\n",
            "eval.studies.claims imports eval.figures "
            "(eval.figures is above eval.studies.claims in eval)",
        ),
    ],
)
def test_the_checker_finds_an_import_that_points_up(
    tmp_path: Path, path: str, text: str, expected: str
) -> None:
    graph = import_graph(_tree(tmp_path, {**GOOD, path: text}))
    assert expected in layering_violations(graph)


def test_the_checker_finds_parts_of_a_package_that_import_each_other(tmp_path: Path) -> None:
    graph = import_graph(_tree(tmp_path, GOOD))
    # eval.figures imports eval.studies.tables and eval.studies.speed imports eval.figures
    assert two_way_parts(graph, "eval") == ["eval.figures <-> eval.studies"]
    one_way = {**GOOD, "eval/figures.py": ""}
    assert two_way_parts(import_graph(_tree(tmp_path / "one", one_way)), "eval") == []


def test_the_checker_finds_a_cycle(tmp_path: Path) -> None:
    bad = {**GOOD, "tandem_env/physics/kernel.py": "def f():\n    from .model import evaluate\n"}
    graph = import_graph(_tree(tmp_path, bad))
    assert layering_violations(graph) == []
    assert import_cycles(graph) == [["tandem_env.physics.kernel", "tandem_env.physics.model"]]


# --- the project --------------------------------------------------------------------------------


def test_every_project_module_is_in_a_layer() -> None:
    graph = import_graph(ROOT)
    assert len(graph) > 50
    assert [name for name in graph if _layer_of(name, LAYERS) is None] == []


def test_no_import_points_up_a_layer() -> None:
    assert layering_violations(import_graph(ROOT)) == []


def test_no_import_cycles() -> None:
    assert import_cycles(import_graph(ROOT)) == []


@pytest.mark.parametrize("package", PACKAGES)
def test_the_parts_of_each_package_import_one_way(package: str) -> None:
    assert two_way_parts(import_graph(ROOT), package) == []
