"""The console scripts of pyproject.toml run the same commands as ``python -m``."""

from __future__ import annotations

import importlib
import re
import sys
from pathlib import Path

import pytest

tomllib = pytest.importorskip("tomllib")  # Python >= 3.11

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]


def test_every_script_names_a_function() -> None:
    assert {"tandem-study", "tandem-optimize", "tandem-train"} <= set(SCRIPTS)
    for target in SCRIPTS.values():
        module, _, name = target.partition(":")
        assert callable(getattr(importlib.import_module(module), name)), target


@pytest.mark.parametrize(
    ("script", "usage"),
    [
        ("tandem-study", "usage: tandem-study [-h]"),
        ("tandem-optimize", "usage: tandem-optimize [-h]"),
        ("tandem-compare", "usage: tandem-compare [-h]"),
        ("tandem-measured", "usage: tandem-measured [-h]"),
        ("tandem-speed-change", "usage: tandem-speed-change [-h]"),
        ("tandem-eval", "usage: tandem-eval [-h]"),
        ("tandem-train", "usage: tandem-train"),
        ("tandem-envelope", "usage: tandem-envelope"),
    ],
)
def test_scripts_show_their_command(
    script: str, usage: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    module, _, name = SCRIPTS[script].partition(":")
    function = getattr(importlib.import_module(module), name)
    monkeypatch.setattr(sys, "argv", [f"/venv/bin/{script}", "-h"])
    with pytest.raises(SystemExit) as exit_:
        function()
    assert exit_.value.code == 0
    assert capsys.readouterr().out.startswith(usage)


def test_readme_lists_every_script() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    listed = set(re.findall(r"^\| `(tandem-[a-z-]+)` \|", readme, flags=re.MULTILINE))
    assert listed == set(SCRIPTS)
