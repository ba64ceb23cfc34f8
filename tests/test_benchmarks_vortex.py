"""benchmarks/vortex_prototype.py (docs/model.md §5.8's prototype) at a coarse resolution on one
lag-study point, so that the script the §5.8 table cites keeps running against the kernel."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "vortex_prototype.py"
SPEC = importlib.util.spec_from_file_location("vortex_prototype", PATH)
proto = importlib.util.module_from_spec(SPEC)
sys.modules[SPEC.name] = proto  # dataclasses look their module up
SPEC.loader.exec_module(proto)

COARSE = {"n_wake": 12, "strips": 2, "read_points": 3, "beats": 1.0}
POINT = (1.0, 8.8, 9.0)  # 1 m/s, the base spacing and drop [m/s, mm, mm]


def one_point(**choices: float | str) -> dict:
    """The variant's changes at the point's 135° lag, where the UVLM's hind-wing loses most."""
    rows = [r for r in proto.lag_study()[POINT] if float(r["lag_deg"]) == 135.0]
    cases = {POINT: rows}
    return proto.run(proto.Variant(**COARSE, **choices), cases), cases


def test_the_fore_wings_wake_costs_the_hind_wing_lift_and_no_circulation_costs_nothing() -> None:
    ours, cases = one_point(shed="translational", core_growth=2.4e-3, gamma_scale=1.35)
    hind, fore = ours[POINT]["hind"][0], ours[POINT]["fore"][0]
    assert -60.0 < hind < -5.0  # the UVLM: -30.9 %
    assert 0.0 < fore < 20.0  # the UVLM: +2.0 %
    assert ours[POINT]["downwash"][0] < 0.0
    cells = proto.metrics(ours, cases)
    assert cells[0] == "1/1" and cells[3] == "—"  # one lag: no pattern to correlate
    assert "largest loss at 135°" in proto.details(ours, cases)
    # without shed circulation the field vanishes and the re-solved pairs are the isolated ones
    silent, _ = one_point(gamma_scale=0.0)
    assert abs(silent[POINT]["hind"][0]) < 1e-3 and abs(silent[POINT]["fore"][0]) < 1e-3


@pytest.mark.parametrize(
    "argv", [["--passes", "0"], ["--shed", "total"], ["--beats", "0.01"], ["--core", "-1e-3"]]
)
def test_bad_options_are_refused_before_any_run(argv: list[str]) -> None:
    with pytest.raises(SystemExit):
        proto.parse(argv)
