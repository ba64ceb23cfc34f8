"""A model zip whose ``.pth`` member is damaged (its deflate stream broken) is refused with the
file-naming ``ValueError``, as every other unreadable member is (train/saved.py), not with the
zip reader's own exception."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import pytest
import torch

from train.saved import read_model_zip


def test_a_broken_deflate_stream_is_refused_by_name(tmp_path: Path) -> None:
    stream = io.BytesIO()
    torch.save({"weight": torch.arange(4096.0)}, stream)
    path = tmp_path / "model.zip"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("data", json.dumps({"num_timesteps": 0}))
        archive.writestr("policy.pth", stream.getvalue())
    with zipfile.ZipFile(path) as archive:
        info = archive.getinfo("policy.pth")
    raw = bytearray(path.read_bytes())
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    raw[start + 5 : start + 45] = b"\xff" * 40  # inside the member's compressed bytes
    path.write_bytes(bytes(raw))
    with pytest.raises(ValueError, match=r"model\.zip: refused: its policy\.pth fails"):
        read_model_zip(path, set())
