"""The quick preset's claims table under several BLAS kernels (eval/numbers/quick_claims.py):
a run's claims read back from its claims.json, and the kernels' runs merged, on small fake runs (no
study is run here)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from eval.numbers import quick_claims
from eval.studies.claims import Claim
from eval.studies.report import claims_data, verdict_summary
from tandem_env.io.files import write_json_atomic

MACHINE = {"date": "2026-12-06 12:00 UTC", "cpus": 2, "processor": "x86_64", "python": "3.12"}


def claim(id: str, verdict: str, best_verdict: str, median: float = 1.0, **kw: Any) -> Claim:
    return Claim(id, "speed", "Fig. 6", "a claim (|ΔΦ|)", "rises", "trend", median=median,
                 best=2.0, verdict=verdict, best_verdict=best_verdict, flips=0.1, best_flips=0.1, **kw)  # fmt: skip


def run(claims: list[Claim], tmp_path: Path, name: str) -> dict[str, Any]:
    """A fake run's stored data: its claims as read back from the claims.json of a report."""
    path = tmp_path / f"{name}.json"
    write_json_atomic(path, claims_data(claims))
    return {"rows": quick_claims.read_claims(path), "wall_time_s": 80.0}


def test_report_rows_read_back(tmp_path: Path) -> None:
    claims = [claim("S1", "agrees", "undecided", math.nan), claim("K1", "differs", "differs")]
    rows = run(claims, tmp_path, "one")["rows"]
    assert [r["id"] for r in rows] == ["S1", "K1"]
    assert rows[0]["claim"] == "a claim (|ΔΦ|)"  # the pipes are the claim's own
    assert rows[0]["ours: median [IQR]"] == "–"
    assert rows[0]["verdict: best seed"] == "undecided (leans undecided, flips 10 %)"
    assert quick_claims.verdicts(rows[0]) == {"median": "agrees", "best seed": "undecided"}


def test_kernels_merged(tmp_path: Path) -> None:
    own = [claim("S1", "agrees", "agrees"), claim("S2", "differs", "undecided", 3.0)]
    haswell = [claim("S1", "agrees", "agrees"), claim("S2", "undecided", "undecided", 4.0)]
    sandy = [claim("S1", "agrees", "agrees"), claim("S2", "undecided", "differs", 4.0)]
    data = {
        "blas_kernel": "SkylakeX",
        **run(own, tmp_path, "own"),
        "other_kernels": {"Haswell": run(haswell, tmp_path, "h"), "Sandybridge": run(sandy, tmp_path, "s")},
        "machine_before": {**MACHINE, "load_average_1min": 1.0},
        "machine_after": {**MACHINE, "load_average_1min": 1.2},
    }  # fmt: skip
    text = quick_claims.render(data)
    lines = text.splitlines()
    s1 = next(line for line in lines if line.startswith("| S1 |"))
    assert "under" not in s1  # the same under every kernel: plain
    assert s1.count("agrees (flips 10 %)") == 2
    s2 = next(line for line in lines if line.startswith("| S2 |"))
    assert "| 3 under SkylakeX; 4 under Haswell and Sandybridge |" in s2
    assert (
        "differs (flips 10 %) under SkylakeX; undecided (leans undecided, flips 10 %) under "
        "Haswell and Sandybridge"
    ) in s2
    assert "**Verdicts that flip with the BLAS kernel: S2 (both columns).**" in lines
    # the counts per kernel: the report's own summary of each kernel's verdicts
    median_own, best_own = verdict_summary(own)
    assert median_own.replace("the median:", "the median under SkylakeX:") in lines
    median_h, _ = verdict_summary(haswell)
    assert median_h.replace("the median:", "the median under Haswell and Sandybridge:") in lines
    assert best_own.replace("seed:", "seed under SkylakeX and Haswell:") in lines
    assert "1 of 2 decided claims agree" in median_own and "1 of 1 decided" in median_h
    assert "Run under the BLAS kernels SkylakeX (the measuring machine's own), Haswell and" in text
    assert "    OPENBLAS_CORETYPE=Sandybridge python -m eval study all" in text


def test_no_flip_and_one_kernel(tmp_path: Path) -> None:
    same = [claim("S1", "agrees", "differs")]
    data = {
        "blas_kernel": "SkylakeX",
        **run(same, tmp_path, "own"),
        "other_kernels": {"Haswell": run(same, tmp_path, "h")},
        "machine_before": {**MACHINE, "load_average_1min": 1.0},
        "machine_after": {**MACHINE, "load_average_1min": 1.0},
    }
    assert "**No verdict flips with the BLAS kernel.**" in quick_claims.render(data)
    assert "under" not in quick_claims.summary_lines(quick_claims.kernel_views(data))[0]
    alone = quick_claims.render({**data, "other_kernels": {}})
    assert "flip with" not in alone and "OPENBLAS_CORETYPE" not in alone
    assert "Run under the BLAS kernel SkylakeX only" in alone
