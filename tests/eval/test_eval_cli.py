"""``python -m eval optimize`` and ``compare`` end to end with tiny budgets."""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from agents.store import read_record, read_record_files
from eval import compare as compare_module
from eval.__main__ import SUBCOMMANDS, build_parser, main
from tandem_env import PARAMETER_NAMES, describe_bounds

ROOT = Path(__file__).resolve().parents[2]
TINY = ["--budget", "12", "--swarm-size", "4", "--quiet"]


def optimize(out: Path, *extra: str) -> int:
    return main(["optimize", "--task", "level", "--speed", "1.5", "--out", str(out), *TINY, *extra])


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("results")
    assert optimize(out, "--method", "pso", "--seeds", "0", "1", "2") == 0
    assert optimize(out, "--method", "random", "--seeds", "0", "1") == 0
    return out


def _stored(out: Path, method: str, seed: int) -> Path:
    """The store's file of a record, found by its configuration."""
    (record,) = [r for r in read_record_files([out]) if (r.method, r.seed) == (method, seed)]
    return out / "records" / f"{record.key}.json"


def test_optimize_writes_one_record_per_seed_and_a_summary(results: Path) -> None:
    assert sorted(p.name for p in results.iterdir()) == ["records", "summary.csv"]
    records = sorted(read_record_files([results]), key=lambda r: (r.method, r.seed))
    # One file per seed, named by its key, and no temporary files.
    assert sorted(p.name for p in (results / "records").iterdir()) == sorted(
        f"{r.key}.json" for r in records
    )
    assert [(r.method, r.seed) for r in records] == [
        ("pso", 0), ("pso", 1), ("pso", 2), ("random", 0), ("random", 1)
    ]  # fmt: skip
    assert all(r.budget == 12 and r.evaluations == 12 for r in records)
    assert records[0].config["method"]["swarm_size"] == 4
    assert records[3].config["method"]["batch_size"] == 4
    with open(results / "summary.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 5  # the summary covers every record in the directory
    assert {row["method"] for row in rows} == {"pso", "random"}
    assert float(rows[0]["objective"]) == records[0].objective
    # the stroke itself, all 28 parameters in Table 4 units, and those at a Table 4 bound
    by_key = {r.key: r for r in records}
    for row in rows:
        stroke = by_key[row["key"]].stroke
        assert {n: float(row[n]) for n in PARAMETER_NAMES} == {
            n: stroke[n] for n in PARAMETER_NAMES
        }
        assert row["at_bounds"] == describe_bounds([stroke[n] for n in PARAMETER_NAMES])


def test_optimize_is_deterministic(results: Path, tmp_path: Path) -> None:
    assert optimize(tmp_path, "--method", "pso", "--seeds", "1") == 0
    (again,) = read_record_files([tmp_path])
    first = read_record(_stored(results, "pso", 1))
    assert again.key == first.key  # the same configuration
    assert again.history == first.history
    assert again.normalised_stroke == first.normalised_stroke
    assert again.metrics == first.metrics


def test_optimize_passes_env_kwargs_and_method_config(tmp_path: Path) -> None:
    argv = [
        "optimize", "--task", "accelerate", "--power", "70", "--objective", "horizontal",
        "--method", "pso", "--budget", "8", "--seeds", "5", "--out", str(tmp_path), "--quiet",
        "--env-kwargs", "thrust_split=body", "penalty_weight=20",
        "--method-config", "swarm_size=4", "boundary=reflect", "velocity_clamp=0.25",
    ]  # fmt: skip
    assert main(argv) == 0
    (record,) = read_record_files([tmp_path])
    assert record.task == "accelerate" and record.objective_name == "excess_horizontal"
    assert record.condition.to_dict() == {"name": "available_power", "value": 70.0, "unit": "W/kg"}
    assert {**dict(record.job.env_kwargs), "available_power": record.job.condition} == {
        "thrust_split": "body", "penalty_weight": 20, "objective": "horizontal",
        "available_power": 70.0,
    }  # fmt: skip
    assert record.config["env"]["options"]["thrust_split"] == "body"
    assert record.config["env"]["penalty"]["weight"] == 20.0
    assert record.config["method"]["boundary"] == "reflect"
    assert record.config["method"]["velocity_clamp"] == 0.25
    assert record.objective == record.metrics["excess_horizontal"]
    assert (tmp_path / "records" / f"{record.key}.json").exists()
    assert record.job.to_dict()["env_kwargs"] == {
        "thrust_split": "body", "penalty_weight": 20, "objective": "horizontal"
    }  # fmt: skip


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--task", "level", "--power", "50"], "--task level takes --speed V [m/s]"),
        (["--task", "accelerate", "--speed", "1"], "--task accelerate takes --power P [W/kg]"),
        (["--task", "level", "--speed", "1", "--objective", "vertical"], "--objective is for"),
        (["--task", "level", "--speed", "9"], "allowed"),
        (["--task", "level", "--speed", "1", "--method", "cma"], "unknown method 'cma'"),
        (["--task", "level", "--speed", "1", "--budget", "0"], "budget = 0"),
        (["--task", "level", "--speed", "1", "--env-kwargs", "x"], "expected key=value"),
        (["--task", "level", "--speed", "1", "--env-kwargs", "nope=1"], "unknown argument"),
        (["--task", "level", "--speed", "1", "--method-config", "inertia=x"], "inertia must be"),
        (["--task", "hover", "--speed", "1"], "invalid choice: 'hover'"),
    ],
)
def test_optimize_rejects_bad_input(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    base = {"--method": "pso", "--budget": "4", "--seeds": "0", "--out": str(tmp_path)}
    for flag, value in base.items():
        if flag not in argv:
            argv = [*argv, flag, value]
    with pytest.raises(SystemExit) as exit_info:
        main(["optimize", *argv])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
    assert not any(tmp_path.iterdir())  # nothing written for a rejected run


def test_compare_writes_table_and_plot(results: Path, tmp_path: Path) -> None:
    out = tmp_path / "cmp"
    assert main(["compare", str(results), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "comparison.csv",
        "comparison.md",
        "convergence.png",
    ]
    with open(out / "comparison.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["method"], r["seeds"]) for r in rows] == [("pso", "3"), ("random", "2")]
    pso = [r for r in read_record_files([results]) if r.method == "pso"]
    objective = [r.objective for r in pso]
    if any(r.feasible for r in pso):
        assert float(rows[0]["objective_median"]) == pytest.approx(np.median(objective))
        q25, q75 = np.percentile(objective, [25, 75])
        assert float(rows[0]["objective_iqr"]) == pytest.approx(q75 - q25)
    else:  # budget 12: no seed feasible, so no objective statistics (tests/eval/test_compare.py)
        assert rows[0]["objective_median"] in ("", "nan")
    assert float(rows[0]["feasible_share"]) == pytest.approx(np.mean([r.feasible for r in pso]))
    assert float(rows[0]["evaluations_median"]) == 12
    markdown = (out / "comparison.md").read_text()
    assert markdown.startswith("| task | objective | condition | method |")
    assert "| level | efficiency | speed = 1.5 m/s | pso | 12 | 3 |" in markdown
    assert (out / "convergence.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_convergence_curve_on_mixed_grids(results: Path) -> None:
    a = read_record(_stored(results, "pso", 0))
    b = read_record(_stored(results, "pso", 1))
    b = replace(b, results={**b.results, "history": [[6, -3.0], [12, -1.0]]})
    x, q25, median, q75 = compare_module.convergence_curve([a, b])
    assert x.tolist() == [4, 6, 8, 12]
    assert median[0] == a.history[0][1]  # only run a reports at 4 evaluations
    assert median[-1] == pytest.approx(np.median([a.history[-1][1], -1.0]))
    assert np.all(q25 <= median) and np.all(median <= q75)


def test_compare_without_records_says_so(tmp_path: Path, capsys) -> None:
    with pytest.raises(SystemExit):
        main(["compare", str(tmp_path), "--out", str(tmp_path / "x")])
    assert "no harness records found" in capsys.readouterr().err


def test_subcommands_are_registered_modules() -> None:
    assert SUBCOMMANDS[:2] == ("eval.optimize", "eval.compare")
    parser = build_parser()
    help_text = parser.format_help()
    assert "optimize" in help_text and "compare" in help_text


def test_module_entry_point_help() -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-m", "eval", "optimize", "--help"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=env,
        timeout=120,
        check=True,
    )
    assert "--task {level,accelerate}" in done.stdout
    assert "--swarm-size N" in done.stdout and "examples:" in done.stdout


def test_options_are_parsed_and_checked_as_the_command_line_is() -> None:
    """KEY=VALUE lists arrive as dicts, a converted option in its final form, and a bad value is
    the usage error (exit status 2) naming the option once."""
    import argparse

    from tandem_env.io.command import checked_by
    from tandem_env.io.keyvalue import KeyValuePairs

    def positive(text: str) -> float:
        if float(text) <= 0:
            raise ValueError(f"value {text!r}; allowed: a number > 0")
        return float(text)

    def named(text: str) -> str:
        raise ValueError(f"--named {text!r}; allowed: nothing")

    parser = argparse.ArgumentParser(prog="p", exit_on_error=False)
    parser.add_argument("--env-kwargs", nargs="+", action=KeyValuePairs, default={})
    parser.add_argument("--size", action=checked_by(positive))
    parser.add_argument("--named", action=checked_by(named))
    args = parser.parse_args(["--env-kwargs", "speed_range=(0.25, 2.0)", "n=3", "--size", "2"])
    assert args.env_kwargs == {"speed_range": (0.25, 2.0), "n": 3} and args.size == 2.0
    assert parser.parse_args([]).env_kwargs == {} and parser.parse_args([]).size is None
    errors = []
    parser.error = lambda message: errors.append(message)  # type: ignore[method-assign]
    parser.parse_args(["--size", "-1"])
    parser.parse_args(["--named", "x"])
    parser.parse_args(["--env-kwargs", "n=1", "n=2"])
    assert errors == [
        "--size: value '-1'; allowed: a number > 0",  # prefixed: the message did not name it
        "--named 'x'; allowed: nothing",  # named already: as it is
        "--env-kwargs: 'n' is given twice",
    ]


def test_eval_and_train_parse_key_values_the_same_way() -> None:
    """One parser for every command: a tuple is a tuple in `python -m eval` as in `python -m train`."""
    from tandem_env.io.keyvalue import parse_pairs

    parsed = parse_pairs(
        ["speed_range=(0.25, 2.0)", "thrust_split=body", "penalty_weight=20"], "--env-kwargs"
    )
    assert parsed == {"speed_range": (0.25, 2.0), "thrust_split": "body", "penalty_weight": 20}
