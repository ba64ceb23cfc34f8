"""A new optimiser is one file plus one registration line: ``toy_optimiser.py`` declares a toy
one (a hill climber with a shrinking step); this runs it through the harness, ``eval optimize``
and, as an installed plug-in would load it, a ``tandem_env.optimisers`` entry point."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from agents.harness import run
from agents.methods import available_methods, get_method, preset_batch_setting
from agents.store import read_record_files

sys.path.insert(0, str(Path(__file__).parent))
from analytic_envs import ACTION_LOG, DIM, optimum, register_analytic
from plugin import PLUGIN_DIR, install_entry_points
from toy_optimiser import HillClimbConfig

register_analytic()


def test_the_toy_is_a_method_with_its_configs_settings() -> None:
    assert "hill-climb" in available_methods()
    assert preset_batch_setting("hill-climb") == "batch_size"
    method = get_method("hill-climb", {"swarm_size": 8, "step": 0.25})
    assert method.config(100) == HillClimbConfig(max_evaluations=100, batch_size=8, step=0.25)
    with pytest.raises(ValueError, match=r"unknown setting\(s\) \['steps'\]; allowed: batch_size"):
        get_method("hill-climb", {"steps": 1})
    with pytest.raises(ValueError, match=r"batch_size = 0; allowed: an integer >= 1$"):
        get_method("hill-climb", {"batch_size": 0})


def test_the_toy_runs_through_the_harness() -> None:
    ACTION_LOG.clear()
    (record,) = run("hill-climb", "sphere", 0.3, 2000, [0], progress=False)
    assert record.evaluations == 2000 and record.history[-1][0] == 2000
    assert [e for e, _ in record.history[:3]] == [16, 32, 48]  # one batch per round
    assert record.config["method"]["algorithm"] == "hill-climb"
    # Measured, seeds 0-3: reward -4e-6 to -1.4e-5, farthest coordinate 0.0016 from the
    # optimum; random search at this budget: reward -4.5 to -5.5.
    assert record.reward > -1e-4
    np.testing.assert_allclose(record.normalised_stroke, optimum(0.3), atol=0.01)
    assert all(np.all(np.abs(a) <= 1.0) for a in ACTION_LOG)
    assert len(record.normalised_stroke) == DIM


def test_the_toy_runs_through_eval_optimize(tmp_path: Path) -> None:
    from eval.__main__ import main

    out = tmp_path / "toy"
    argv = ["optimize", "--task", "sphere", "--shift", "0.3", "--method", "hill-climb"]
    argv += ["--budget", "160", "--seeds", "0", "1", "--out", str(out), "--quiet"]
    assert main([*argv, "--method-config", "step=0.3"]) == 0
    records = read_record_files([out])
    assert sorted(r.seed for r in records) == [0, 1]
    assert all(r.evaluations == 160 and r.config["method"]["step"] == 0.3 for r in records)


def test_an_entry_point_registers_the_toy(tmp_path: Path) -> None:
    """An installed plug-in's ``tandem_env.optimisers`` entry point names the module that
    registers its method: a fresh interpreter offers and builds it with no import of its own."""
    env = install_entry_points(tmp_path, "tandem_env.optimisers", {"hill-climb": "toy_optimiser"})
    code = (
        "from agents.methods import available_methods, get_method\n"
        "assert 'hill-climb' in available_methods(), available_methods()\n"
        "print(get_method('hill-climb', {'swarm_size': 8}).config(100))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    assert "HillClimbConfig(max_evaluations=100, batch_size=8, step=0.5)" in done.stdout
    assert str(PLUGIN_DIR) in env["PYTHONPATH"]
