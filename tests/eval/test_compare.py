"""``eval compare``: a default output folder, and no objective statistics of strokes that do not fly."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from agents.records import Record, RecordStore
from agents.tasks import Condition
from eval import compare as compare_module
from eval.__main__ import build_parser, main


def _record(method: str, seed: int, objective: float, feasible: bool) -> Record:
    return Record(
        method=method,
        task="level",
        env_id="TandemWing/LevelFlight-v0",
        objective_name="efficiency",
        condition=Condition("speed", 1.5, "m/s"),
        seed=seed,
        budget=10,
        evaluations=10,
        objective=objective,
        reward=objective if feasible else objective - 1.0,
        search_reward=objective if feasible else objective - 1.0,
        feasible=feasible,
        stroke={},
        normalised_stroke=(0.0,) * 28,
        metrics={},
        history=((5, -2.0), (10, objective - 1.0)),
        wall_time=1.0,
        config={},
        versions={},
        key=f"{method}-{seed}",
    )


@pytest.fixture
def records(tmp_path: Path) -> Path:
    folder = tmp_path / "records"
    for seed, objective in enumerate((0.30, 0.20, 0.40)):
        RecordStore(folder).save(_record("pso", seed, objective, feasible=seed != 1))
    for seed, objective in enumerate((0.50, 0.60)):
        RecordStore(folder).save(_record("random", seed, objective, feasible=False))
    return folder


def test_out_defaults_to_a_compare_folder_of_the_first_dir(
    records: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["compare", str(records)]) == 0
    out = records / compare_module.DEFAULT_OUT
    assert {p.name for p in out.iterdir()} == {
        "comparison.csv",
        "comparison.md",
        "convergence.png",
    }
    assert str(out / "comparison.csv") in capsys.readouterr().err
    # again, now that the outputs lie inside the records folder: same rows, no error
    assert main(["compare", str(records)]) == 0


def test_help_names_the_output_folder_plainly() -> None:
    parser = build_parser()
    text = parser.parse_known_args(["compare", "x"])[0]
    assert text.out is None
    help_text = " ".join(_help(parser, "compare").split())
    assert "DIR2" not in help_text
    assert "--out OUT" in help_text and "compare/ sub-folder" in help_text


def _help(parser, command: str) -> str:
    import contextlib
    import io

    stream = io.StringIO()
    with contextlib.redirect_stdout(stream), pytest.raises(SystemExit):
        parser.parse_args([command, "-h"])
    return stream.getvalue()


def test_no_median_objective_over_seeds_none_of_which_is_feasible(records: Path) -> None:
    out = records / "table"
    rows = compare_module.compare([records], out)
    pso, random = rows
    # pso: 2 of 3 feasible: the statistics over all seeds, and the median of the feasible ones
    assert pso.objective_median == pytest.approx(0.30)
    assert pso.objective_median_feasible == pytest.approx(0.35)
    assert pso.feasible_share == pytest.approx(2 / 3)
    # random: none feasible: no objective statistic at all (0.55 would not be a result)
    assert math.isnan(random.objective_median) and math.isnan(random.objective_best)
    assert math.isnan(random.objective_median_feasible) and random.feasible_share == 0.0
    markdown = (out / "comparison.md").read_text()
    [line] = [line for line in markdown.splitlines() if "| random |" in line]
    assert "n/a (none feasible)" in line and "0.55" not in line and "0.6" not in line
    with (out / "comparison.csv").open(newline="") as stream:
        table = {row["method"]: row for row in csv.DictReader(stream)}
    assert table["random"]["objective_median"] in ("", "nan")
    assert float(table["pso"]["objective_median_feasible"]) == pytest.approx(0.35)


def test_the_convergence_figure_is_written_in_the_format_asked(records: Path) -> None:
    out = records / "svg"
    compare_module.compare([records], out, "svg")
    assert (out / "convergence.svg").read_bytes().startswith(b"<?xml")
    assert not (out / "convergence.png").exists()
    with pytest.raises(ValueError, match="allowed: png, svg, pdf"):
        compare_module.compare([records], records / "bad", "jpg")
