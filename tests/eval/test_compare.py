"""``eval compare``: a default output folder, and no objective statistics of strokes that do not fly."""

from __future__ import annotations

import csv
import dataclasses
import math
from pathlib import Path

import pytest

from agents.jobs import Job
from agents.records import Record
from agents.store import RecordStore
from eval import compare as compare_module
from eval import figures
from eval.__main__ import build_parser, main


def _record(
    method: str, seed: int, objective: float, feasible: bool, **env_kwargs: object
) -> Record:
    job = Job(method, "level", 1.5, 10, seed, env_kwargs=env_kwargs)
    reward = objective if feasible else objective - 1.0
    results = {
        "env_id": "TandemWing/LevelFlight-v0",
        "objective_name": "efficiency",
        "condition_name": "speed",
        "condition_unit": "m/s",
        "evaluations": 10,
        "objective": objective,
        "reward": reward,
        "search_reward": reward,
        "feasible": feasible,
        "selection": "best feasible stroke seen",
        "stroke": {},
        "normalised_stroke": [0.0] * 28,
        "metrics": {},
        "history": [[5, -2.0], [10, objective - 1.0]],
        "wall_time": 1.0,
        "method_settings": {},
        "env": {},
        "versions": {"tandem_env": "test"},
    }
    return Record(job=job, key=job.key, results=results)


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
    assert pso.objective_spread == pytest.approx((0.40 - 0.20) / 0.30)
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


def test_records_of_different_configurations_are_never_merged(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A real-planform and a tear-drop run are two rows (main reported them as one row of
    4 seeds), and a record found twice counts once."""
    runs = [_record("pso", s, 0.3 + 0.01 * s, True, planform="tear-drop") for s in (0, 1)]
    runs += [_record("pso", s, 0.2 + 0.01 * s, True, planform="real") for s in (0, 1)]
    runs += [_record("pso", 0, 0.25, True, planform="real", n_time=64)]
    rows = compare_module.table_rows([*runs, runs[0]])
    assert "found twice" in capsys.readouterr().err
    assert [(r.seeds, r.distinct) for r in rows] == [
        (1, "n_time=64, planform=real"),
        (2, "n_time=default, planform=real"),
        (2, "n_time=default, planform=tear-drop"),
    ]
    assert [r.objective_median for r in rows] == pytest.approx([0.25, 0.205, 0.305])
    assert rows[1].settings == "planform=real; tandem_env=test"
    markdown = compare_module.comparison_markdown(rows)
    assert "| pso (n_time=64, planform=real) |" in markdown
    assert "spread = (max - min) / |median|" in markdown
    # Another budget is another row too.
    longer = Job("pso", "level", 1.5, 20, 0, env_kwargs={"planform": "real"})
    other = Record(job=longer, key=longer.key, results=runs[2].results)
    assert len(compare_module.table_rows([runs[2], other])) == 2


def test_colours_are_fixed_per_method_and_labels_count_seeds_right() -> None:
    import matplotlib.pyplot as plt

    def lines(records: list[Record]) -> dict[str, tuple[str, str]]:
        fig = compare_module.best_so_far_figure(records)
        try:
            ax = fig.axes[0]
            return {
                line.get_label(): (line.get_color(), line.get_linestyle())
                for line in ax.get_lines()
                if not line.get_label().startswith("_")
            }
        finally:
            plt.close(fig)

    pso = [_record("pso", 0, 0.3, True)]
    alone = lines(pso)
    assert "PSO (1 seed)" in alone  # not "1 seeds"
    both = lines([*pso, _record("cmaes", 0, 0.4, True), _record("cmaes", 1, 0.5, True)])
    assert both["PSO (1 seed)"] == alone["PSO (1 seed)"]  # adding a series keeps pso's colour
    assert both["CMA-ES (2 seeds)"][0] == figures.METHOD_COLORS["cmaes"]
    assert both["PSO (1 seed)"][0] == figures.METHOD_COLORS["pso"]
    # the reported objective is drawn and named beside the best-so-far reward
    assert any(label.startswith("reported efficiency") for label in both)
    variants = lines([_record("pso", 0, 0.3, True, planform="real"),
                      _record("pso", 0, 0.3, True, planform="tear-drop")])  # fmt: skip
    drawn = {(colour, style) for colour, style in variants.values() if style != "None"}
    # one method, two variants: two Okabe-Ito hues and two line styles
    assert len({c for c, _ in drawn}) == 2 and len({s for _, s in drawn}) == 2
    assert {c for c, _ in drawn} <= set(figures.PALETTE)


def test_the_polish_is_drawn_from_the_end_of_the_search_to_the_reported_marker() -> None:
    import matplotlib.pyplot as plt

    # The search reported up to 6 evaluations, the polish spent the other 4 of 10.
    runs = [_record("cmaes", seed, 0.5, True) for seed in (0, 1)]
    for r in runs:
        r.results["history"] = [[3, -2.0], [6, 0.4]]
    fig = compare_module.best_so_far_figure(runs)
    try:
        ax = fig.axes[0]
        [marker] = [ln for ln in ax.get_lines() if ln.get_marker() == "D" and len(ln.get_xdata())]
        assert (list(marker.get_xdata()), list(marker.get_ydata())) == ([10.0], [0.5])
        [segment] = [
            ln for ln in ax.get_lines() if ln.get_linestyle() == ":" and len(ln.get_xdata())
        ]
        assert list(segment.get_xdata()) == [6.0, 10.0] and list(segment.get_ydata()) == [0.4, 0.5]
        assert compare_module.POLISH_LABEL in ax.get_legend_handles_labels()[1]
    finally:
        plt.close(fig)
    # without a polish (the history reaches the evaluations spent) there is no segment
    fig = compare_module.best_so_far_figure([_record("cmaes", 0, 0.5, True)])
    try:
        assert compare_module.POLISH_LABEL not in fig.axes[0].get_legend_handles_labels()[1]
    finally:
        plt.close(fig)


def test_the_convergence_figure_is_written_in_the_format_asked(records: Path) -> None:
    out = records / "svg"
    compare_module.compare([records], out, "svg")
    assert (out / "convergence.svg").read_bytes().startswith(b"<?xml")
    assert not (out / "convergence.png").exists()
    with pytest.raises(ValueError, match="allowed: png, svg, pdf"):
        compare_module.compare([records], records / "bad", "jpg")


def test_method_settings_tell_apart_only_the_variants_of_one_method() -> None:
    base = _record("pso", 0, 0.3, True)

    def variant(method: str, **settings: object) -> Record:
        job = Job(method, "level", 1.5, 10, 0, method_config=settings)
        return Record(job=job, key=job.key, results=base.results)

    rows = compare_module.table_rows(
        [variant("pso", swarm_size=8), variant("pso", swarm_size=16), variant("cmaes", popsize=8)]
    )
    assert {(r.method, r.distinct) for r in rows} == {
        ("cmaes", ""),
        ("pso", "method.swarm_size=16"),
        ("pso", "method.swarm_size=8"),
    }


def test_certificate_columns_are_the_records_medians() -> None:
    runs = [_record("cmaes", seed, 0.4, feasible=True) for seed in range(3)]
    certified = [
        dataclasses.replace(
            r, results={**r.results, "certificate": {"gain": gain, "kkt_residual": kkt}}
        )
        for r, gain, kkt in zip(runs, (0.01, 0.05, 0.03), (1e-6, None, 1e-2), strict=True)
    ]
    (row,) = compare_module.table_rows(certified)
    assert row.polish_gain_median == pytest.approx(0.03)
    assert row.kkt_residual_median == pytest.approx(0.5 * (1e-6 + 1e-2))  # unknown left out
    assert "+3.00 %" in compare_module.comparison_markdown([row])
    # records without a certificate (older formats, no polish): no numbers, not zeros
    (row,) = compare_module.table_rows(runs)
    assert math.isnan(row.polish_gain_median) and math.isnan(row.kkt_residual_median)
