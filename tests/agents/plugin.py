"""An installed plug-in, as Python's packaging sees one: a ``*.dist-info`` folder on the path with
an ``entry_points.txt``; ``importlib.metadata.entry_points`` finds it like any installed package's.

The toy task (``toy_task.py``) and optimiser (``toy_optimiser.py``) are its modules, so a fresh
interpreter (``python -m train``, ``python -c``) loads them through the entry points alone.
"""

from __future__ import annotations

import os
from pathlib import Path

#: Where the toy modules are.
PLUGIN_DIR = Path(__file__).resolve().parent
REPO = PLUGIN_DIR.parents[1]


def install_entry_points(folder: Path, group: str, points: dict[str, str]) -> dict[str, str]:
    """Write a plug-in distribution declaring ``points`` (name -> ``module[:object]``) in the
    entry-point ``group`` into ``folder``; return the environment of a subprocess that sees it
    (``folder``, the toy modules and the repository on ``PYTHONPATH``)."""
    info = folder / "tandem_toy_plugin-0.dist-info"
    info.mkdir(parents=True, exist_ok=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: tandem-toy-plugin\nVersion: 0\n")
    lines = [f"[{group}]", *(f"{name} = {value}" for name, value in points.items())]
    (info / "entry_points.txt").write_text("\n".join(lines) + "\n")
    path = [str(folder), str(PLUGIN_DIR), str(REPO), os.environ.get("PYTHONPATH", "")]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in path if p)}
