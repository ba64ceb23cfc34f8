"""Tests for tandem_env.io.files (atomic JSON/CSV writes) and agents.records.package_versions."""

from __future__ import annotations

import csv
import json
import math
import os
import platform
import stat
import sys
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest

from agents import records
from agents.pso import PSOConfig
from agents.records import package_versions
from tandem_env.io import files as fileio
from tandem_env.io.files import read_json, write_csv_atomic, write_json_atomic

sys.path.insert(0, str(Path(__file__).parent))
from analytic_envs import drive


def test_json_round_trip_with_numpy_types(tmp_path: Path) -> None:
    path = tmp_path / "record.json"
    obj = {
        "f32": np.float32(1.5),
        "i64": np.int64(7),
        "flag": np.bool_(True),
        "matrix": np.arange(6, dtype=np.int32).reshape(2, 3),
        "pair": (np.float64(0.25), "a"),
        "where": tmp_path,
        "worst": -math.inf,
        np.int64(3): "numpy key",
    }
    write_json_atomic(path, obj)
    loaded = read_json(path)
    assert loaded == {
        "f32": 1.5,
        "i64": 7,
        "flag": True,
        "matrix": [[0, 1, 2], [3, 4, 5]],
        "pair": [0.25, "a"],
        "where": str(tmp_path),
        "worst": -math.inf,
        "3": "numpy key",
    }
    assert type(loaded["i64"]) is int
    assert sorted(os.listdir(tmp_path)) == ["record.json"]  # no temp files left behind


def test_optimiser_record_serialises(tmp_path: Path) -> None:
    optimiser = PSOConfig(max_evaluations=120).build(3, 0)
    drive(optimiser, lambda X: -np.sum(X**2, axis=1))
    result = {"config": optimiser.record(), "history": optimiser.history}
    write_json_atomic(tmp_path / "result.json", result)
    loaded = read_json(tmp_path / "result.json")
    assert loaded["config"]["citation"] == PSOConfig(max_evaluations=120).citation
    assert np.array_equal(loaded["history"], optimiser.history)


def test_failed_serialisation_keeps_old_file(tmp_path: Path) -> None:
    path = tmp_path / "record.json"
    write_json_atomic(path, {"version": 1})
    with pytest.raises(TypeError, match="cannot convert object to JSON"):
        write_json_atomic(path, {"version": 2, "bad": object()})
    assert read_json(path) == {"version": 1}
    assert sorted(os.listdir(tmp_path)) == ["record.json"]


@pytest.mark.parametrize("failing", ["fsync", "replace"])
def test_failed_write_keeps_old_file_and_cleans_up(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, failing: str
) -> None:
    path = tmp_path / "record.json"
    write_json_atomic(path, {"version": 1})
    old_bytes = path.read_bytes()

    def crash(*args: object) -> None:
        raise OSError(f"simulated {failing} failure")

    # A crash after the data is (partly) on disk but before the rename.
    monkeypatch.setattr(fileio.os, failing, crash)
    with pytest.raises(OSError, match="simulated"):
        write_json_atomic(path, {"version": 2, "payload": list(range(10_000))})
    monkeypatch.undo()
    assert path.read_bytes() == old_bytes
    assert sorted(os.listdir(tmp_path)) == ["record.json"]


def test_creates_parent_directories_and_sane_mode(tmp_path: Path) -> None:
    path = tmp_path / "a" / "b" / "record.json"
    write_json_atomic(path, [1, 2])
    assert read_json(path) == [1, 2]
    if os.name == "posix":
        assert stat.S_IMODE(path.stat().st_mode) == 0o644  # not mkstemp's private 0600
        path.chmod(0o640)
        write_json_atomic(path, [3])
        assert stat.S_IMODE(path.stat().st_mode) == 0o640  # an existing file keeps its mode


def test_csv_union_of_keys_in_stable_order(tmp_path: Path) -> None:
    path = tmp_path / "table.csv"
    rows = [
        {"seed": np.int64(0), "return": np.float32(1.5)},
        {"seed": 1, "steps": 200, "return": 2.0},
        {"note": None, "seed": 2, "position": np.array([0.5, -0.5])},
    ]
    write_csv_atomic(path, rows)
    with open(path, newline="", encoding="utf-8") as handle:
        reader = csv.DictReader(handle)
        assert reader.fieldnames == ["seed", "return", "steps", "note", "position"]
        read = list(reader)
    assert read[0] == {"seed": "0", "return": "1.5", "steps": "", "note": "", "position": ""}
    assert read[1]["steps"] == "200"
    assert json.loads(read[2]["position"]) == [0.5, -0.5]
    assert sorted(os.listdir(tmp_path)) == ["table.csv"]


def test_csv_without_rows_is_empty(tmp_path: Path) -> None:
    write_csv_atomic(tmp_path / "empty.csv", [])
    assert (tmp_path / "empty.csv").read_text() == ""


def test_package_versions(monkeypatch: pytest.MonkeyPatch) -> None:
    versions = package_versions()
    assert set(versions) == {
        "numpy",
        "scipy",
        "gymnasium",
        "stable_baselines3",
        "torch",
        "numba",
        "python",
        "tandem_env",
        "model",
    }
    assert versions["numpy"] == np.__version__
    assert versions["python"] == platform.python_version()

    real_version = metadata.version

    def without_numba(name: str) -> str:
        if name == "numba":
            raise metadata.PackageNotFoundError(name)
        return real_version(name)

    monkeypatch.setattr(records.metadata, "version", without_numba)
    assert package_versions()["numba"] == "not installed"


def test_one_converter_for_dataclasses_keys_and_unknown_values() -> None:
    from dataclasses import dataclass

    from tandem_env.io.files import to_jsonable

    @dataclass(frozen=True)
    class Wing:
        length: float
        pitch: tuple[float, float]

    obj = {"wing": Wing(0.04, (1.0, 2.0)), True: None, 2: np.float32(0.5)}
    assert to_jsonable(obj) == {
        "wing": {"length": 0.04, "pitch": [1.0, 2.0]},
        "true": None,
        "2": 0.5,
    }
    assert to_jsonable(obj) == json.loads(json.dumps(to_jsonable(obj)))  # as written to a file
    with pytest.raises(TypeError, match="cannot convert object"):
        to_jsonable({"x": object()})
    assert to_jsonable({"cls": int, "x": [object]}, default=repr) == {
        "cls": "<class 'int'>",
        "x": ["<class 'object'>"],
    }


def test_atomic_path_for_writers_that_need_a_path(tmp_path: Path) -> None:
    target = tmp_path / "figures" / "fig.png"
    with fileio.atomic_path(target) as tmp:
        assert tmp.parent == target.parent and tmp.suffix == ".png" and tmp != target
        tmp.write_bytes(b"png")
    assert target.read_bytes() == b"png"
    with pytest.raises(RuntimeError), fileio.atomic_path(target) as tmp:
        tmp.write_bytes(b"half")
        raise RuntimeError("killed while rendering")
    assert target.read_bytes() == b"png"
    assert sorted(os.listdir(target.parent)) == ["fig.png"]
