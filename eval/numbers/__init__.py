"""``python -m eval numbers``: measure the numbers README and docs quote, and write them in.

A number a document states is produced here, by the command the document names, and written
into the document between two markers::

    <!-- numbers: comparison -->
    ...generated Markdown, never edited by hand...
    <!-- /numbers -->

Each measurement keeps its raw results in ``docs/numbers/<name>.json`` (per-seed values, the
commands, date, machine and load), and the Markdown is rendered from that file alone, so

* ``python -m eval numbers`` reruns every measurement, rewrites its JSON and the documents;
* ``python -m eval numbers --render`` rewrites the documents from the stored JSON only;
* ``tests/test_docs_numbers.py`` checks that every marked region equals its rendering (a hand
  edit or a stale region fails) and reruns seed 0 of every deterministic row at its stated
  settings against the stored value.

* ``python -m eval numbers --only NAME ...`` reruns only those (:data:`MEASUREMENTS` lists
  them: the comparison of methods, the benchmarks of the model, the torch port and the envs,
  SpeedChange's random and steady baselines, the quick preset's and a training run's time,
  readings of the model on random strokes, the resolution study of the defaults, the optimum
  of a second species, the reference optima as packaged and, on request, the PPO and SAC
  envelope policies' scores, the amortised policy's, the README's headline of both, the
  cross-check's lag study and the readings study at the paper preset).

This package is a small framework (:mod:`eval.numbers.framework`: where numbers live, the
machine, the documented commands) and one module per measurement. Adding a number is one
module with its ``measure() -> dict`` and pure ``render(dict) -> str``, its
:class:`~eval.numbers.framework.Measurement` line in :data:`MEASUREMENTS`, and one region in a
document. A benchmark is measured by running its documented command with ``--json``
(:class:`~eval.numbers.framework.Benchmark`). Timings are not deterministic: they are
shown with the machine (CPU model, cores), date and load average before and after they were
taken, the documents read their ratios within one run, and the test does not compare them.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from eval.numbers import (
    amortised_scores,
    comparison,
    convergence,
    crosscheck_lag_study,
    envelope_headline,
    power_conventions,
    quick_preset,
    readings_paper,
    reference_table,
    rl_baselines,
    rotational_coefficient,
    second_species,
    speed_change,
    throughput,
    training_time,
)
from eval.numbers.comparison import (
    COMPARISON_METHODS,
    COMPARISON_ROWS,
    ComparisonRow,
    run_optimize,
)
from eval.numbers.convergence import CONVERGENCE
from eval.numbers.framework import (
    DOCUMENTS,
    REGION,
    ROOT,
    Measurement,
    json_path,
    load,
    machine,
    regions,
    save,
)
from eval.numbers.readings_paper import READINGS_PAPER_FILES
from eval.numbers.speed_change import (
    SPEED_CHANGE_COMMAND,
    speed_change_optima,
    speed_change_rows,
)

NAME = "numbers"
HELP = "rerun the measurements README and docs quote, and write them into the documents"


MEASUREMENTS: dict[str, Measurement] = {
    m.name: m
    for m in (
        Measurement("comparison", comparison.measure_comparison, comparison.render_comparison),
        Measurement(
            "model-throughput",
            throughput.MODEL_THROUGHPUT.run,
            throughput.render_model_throughput,
        ),
        Measurement("inflow-cost", throughput.INFLOW_SOLVE.run, throughput.render_inflow_cost),
        Measurement(
            "torch-throughput",
            throughput.measure_torch_throughput,
            throughput.render_torch_throughput,
        ),
        Measurement(
            "env-throughput", throughput.ENV_THROUGHPUT.run, throughput.render_env_throughput
        ),
        Measurement(
            "speed-change", speed_change.measure_speed_change, speed_change.render_speed_change
        ),
        Measurement(
            "rotational-coefficient",
            rotational_coefficient.measure_rotational_coefficient,
            rotational_coefficient.render_rotational_coefficient,
        ),
        Measurement(
            "power-conventions",
            power_conventions.measure_power_conventions,
            power_conventions.render_power_conventions,
        ),
        Measurement("convergence", CONVERGENCE.run, convergence.render_convergence),
        Measurement(
            "quick-preset", quick_preset.measure_quick_preset, quick_preset.render_quick_preset
        ),
        Measurement(
            "training-time",
            training_time.measure_training_time,
            training_time.render_training_time,
        ),
        Measurement(
            "second-species",
            second_species.measure_second_species,
            second_species.render_second_species,
        ),
        Measurement(
            "reference-table",
            reference_table.measure_reference_table,
            reference_table.render_reference_table,
        ),
        Measurement(
            "rl-baselines",
            rl_baselines.measure_rl_baselines,
            rl_baselines.render_rl_baselines,
            on_request=True,
        ),
        Measurement(
            "amortised-scores",
            amortised_scores.measure_amortised_scores,
            amortised_scores.render_amortised_scores,
            on_request=True,
        ),
        Measurement(
            "envelope-headline",
            envelope_headline.measure_envelope_headline,
            envelope_headline.render_envelope_headline,
            on_request=True,
        ),
        Measurement(
            "crosscheck-lag-study",
            crosscheck_lag_study.measure_crosscheck_lag_study,
            crosscheck_lag_study.render_crosscheck_lag_study,
            on_request=True,
        ),
        Measurement(
            "readings-paper",
            readings_paper.measure_readings_paper,
            readings_paper.render_readings_paper,
            on_request=True,
        ),
    )
}


def render_document(text: str, rendered: dict[str, str]) -> str:
    """``text`` with every marked region replaced by its rendering (a measurement not stored
    yet: left as it is; a name no measurement has: an error)."""

    def body(match: re.Match[str]) -> str:
        name = match["name"]
        if name not in rendered and name in MEASUREMENTS:
            return match.group(0)
        if name not in rendered:
            raise KeyError(f"unknown numbers region {name!r}; known: {sorted(rendered)}")
        return match.group(1) + rendered[name] + match.group(4)

    return REGION.sub(body, text)


def write_documents(rendered: dict[str, str]) -> list[Path]:
    changed = []
    for path in DOCUMENTS:
        text = path.read_text(encoding="utf-8")
        new = render_document(text, rendered)
        if new != text:
            path.write_text(new, encoding="utf-8")
            changed.append(path)
    return changed


def rendered_all() -> dict[str, str]:
    """Every stored measurement's Markdown (one not measured yet has none)."""
    return {
        name: m.render(load(name)) for name, m in MEASUREMENTS.items() if json_path(name).exists()
    }


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--render",
        action="store_true",
        help="rewrite the documents from the stored docs/numbers/*.json without measuring",
    )
    parser.add_argument(
        "--only",
        nargs="+",
        choices=sorted(MEASUREMENTS),
        metavar="NAME",
        help=f"measure only these ({', '.join(sorted(MEASUREMENTS))})",
    )


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    if not args.render:
        every = [name for name, m in sorted(MEASUREMENTS.items()) if not m.on_request]
        for name in args.only or every:
            print(f"measuring {name} ...", file=sys.stderr, flush=True)
            before = machine()
            data = MEASUREMENTS[name].measure()
            save(name, {**data, "machine_before": before, "machine_after": machine()})
    for path in write_documents(rendered_all()):
        print(f"updated {path.relative_to(ROOT)}")
    return 0


__all__ = [
    "COMPARISON_METHODS",
    "COMPARISON_ROWS",
    "CONVERGENCE",
    "DOCUMENTS",
    "HELP",
    "MEASUREMENTS",
    "NAME",
    "READINGS_PAPER_FILES",
    "SPEED_CHANGE_COMMAND",
    "ComparisonRow",
    "Measurement",
    "add_arguments",
    "load",
    "main",
    "regions",
    "render_document",
    "rendered_all",
    "run_optimize",
    "speed_change_optima",
    "speed_change_rows",
]
