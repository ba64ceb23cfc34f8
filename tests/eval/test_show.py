"""``python -m eval show RECORD``: the stroke's picture and its animation, and bad input refused
with one line and exit status 2 before any work."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib import animation
from PIL import Image

from agents.store import read_record_files
from eval.__main__ import main
from eval.show import default_out


@pytest.fixture(scope="module")
def record_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("results")
    argv = ["optimize", "--task", "level", "--speed", "1.5", "--budget", "12", "--seeds", "0",
            "--method", "random", "--out", str(out), "--quiet"]  # fmt: skip
    assert main(argv) == 0
    (record,) = read_record_files([out])
    return out / "records" / f"{record.key}.json"


def test_show_writes_the_picture_and_a_moving_animation(record_file: Path) -> None:
    assert main(["show", str(record_file), "--frames", "8", "--fps", "10"]) == 0
    out = default_out(record_file)
    assert out == record_file.parent.parent / "show"  # beside the records/ folder
    key = record_file.stem
    assert (out / f"{key}.png").read_bytes()[:4] == b"\x89PNG"
    with Image.open(out / f"{key}.gif") as gif:
        assert gif.n_frames == 8  # one per sample of the cycle
        frames = []
        for k in (0, 4):
            gif.seek(k)
            frames.append(np.asarray(gif.convert("RGB"), dtype=int))
    assert np.abs(frames[0] - frames[1]).sum() > 0  # the wings move


@pytest.mark.parametrize(
    ("argument", "message"),
    [
        ("missing.json", "no such file"),
        (".", "not a file"),
        ("bad.json", "not a harness record"),
    ],
)
def test_a_bad_record_is_refused_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture,
    argument: str, message: str,
) -> None:  # fmt: skip
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.json").write_text('{"schema": "something else"}')
    with pytest.raises(SystemExit) as exit_info:
        main(["show", argument])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith("python -m eval show: error:") and message in error
    assert not (tmp_path / "show").exists()  # nothing written


def test_mp4_without_ffmpeg_says_so(record_file: Path, capsys: pytest.CaptureFixture) -> None:
    if animation.writers.is_available("ffmpeg"):
        pytest.skip("ffmpeg is installed here")
    with pytest.raises(SystemExit) as exit_info:
        main(["show", str(record_file), "--format", "mp4"])
    assert exit_info.value.code == 2
    assert "needs the ffmpeg program" in capsys.readouterr().err
