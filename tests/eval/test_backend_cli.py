"""``--backend`` / ``--device`` of ``python -m eval optimize`` and ``study``: env keywords of the
jobs, left out of the record key (a numba record is reused by a torch run), checked before any
work."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from agents.jobs import Job
from agents.store import read_record_files
from eval.__main__ import main
from eval.compare import series_key
from eval.studies.base import StudyPlan
from eval.studies.presets import get_preset

torch = pytest.importorskip("torch")

TINY = ["--budget", "8", "--swarm-size", "4", "--seeds", "0", "--quiet"]


def optimize(out: Path, *extra: str) -> int:
    argv = ["optimize", "--task", "level", "--speed", "1.0", "--method", "pso", "--out", str(out)]
    return main([*argv, *TINY, *extra])


def test_optimize_on_torch_matches_numba_and_shares_its_record(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    on_torch, on_numba = tmp_path / "torch", tmp_path / "numba"
    assert optimize(on_torch, "--backend", "torch", "--device", "cpu") == 0
    assert optimize(on_numba, "--no-cache") == 0  # computed again, on numba
    (t,) = read_record_files([on_torch])
    (n,) = read_record_files([on_numba])
    assert t.job.env("backend") == "torch" and t.job.env("device") == "cpu"  # what it ran on
    assert n.job.env("backend") is None
    assert t.key == n.key  # the backend is not part of the configuration
    assert series_key(t) == series_key(n)  # nor of a compare series
    # The same search (PSO follows the rewards, equal within 1e-8) finds the same stroke.
    np.testing.assert_allclose(t.normalised_stroke, n.normalised_stroke, rtol=0, atol=1e-8)
    for name, value in n.metrics.items():
        if isinstance(value, float):
            np.testing.assert_allclose(t.metrics[name], value, rtol=1e-8, atol=1e-8, err_msg=name)
    capsys.readouterr()
    assert optimize(on_numba, "--backend", "torch") == 0  # the numba record is reused
    assert "0 run, 1 reused" in capsys.readouterr().err


def test_optimize_refuses_the_backend_twice(tmp_path: Path, capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        optimize(tmp_path / "out", "--backend", "torch", "--env-kwargs", "backend=numba")
    assert exit_info.value.code == 2
    assert "not both" in capsys.readouterr().err


def test_the_key_leaves_the_backend_out_and_the_store_reuses_across_backends(
    tmp_path: Path,
) -> None:
    base = Job("pso", "level", 1.0, 8, 0, env_kwargs={"planform": "real"})
    on_torch = Job("pso", "level", 1.0, 8, 0, {"planform": "real", "backend": "torch"})
    on_cuda = Job("pso", "level", 1.0, 8, 0, {"planform": "real", "backend": "torch", "device": "cuda"})  # fmt: skip
    assert base.key == on_torch.key == on_cuda.key
    assert Job("pso", "level", 1.0, 8, 0, {"planform": "tear-drop"}).key != base.key
    assert on_torch.to_dict()["env_kwargs"]["backend"] == "torch"  # kept in the record's job


def test_study_plan_adds_the_backend_to_every_job() -> None:
    preset = get_preset("quick")
    plain = StudyPlan(preset).jobs("level", [1.0])
    torch_plan = StudyPlan(preset, execution=(("backend", "torch"),))
    on_torch = torch_plan.jobs("level", [1.0])
    assert [j.env("backend") for j in on_torch] == ["torch"] * len(plain)
    assert [j.key for j in on_torch] == [j.key for j in plain]
    with pytest.raises(ValueError, match=r"StudyPlan\.execution = .* allowed: keywords among"):
        StudyPlan(preset, execution=(("planform", "real"),))


CUDA_MISSING = pytest.mark.skipif(torch.cuda.is_available(), reason="CUDA is available here")


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--backend", "jax"], "argument --backend: invalid choice: 'jax'"),
        (["--device", "cpu"], "device = 'cpu' with backend 'numba'"),
        (["--backend", "torch", "--device", "tpu"], "device = 'tpu' is not a torch device"),
        pytest.param(
            ["--backend", "torch", "--device", "cuda"],
            "device = 'cuda' but CUDA is not available",
            marks=CUDA_MISSING,
        ),
    ],
)
@pytest.mark.parametrize("command", ["optimize", "study"])
def test_bad_values_exit_2_before_any_work(
    command: str,
    extra: list[str],
    message: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exit_info:
        if command == "optimize":
            optimize(out, *extra)
        else:
            main(["study", "speed", "--out", str(out), "--quiet", *extra])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
    assert not (out / "records").exists()  # nothing ran
