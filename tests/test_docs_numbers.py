"""The numbers README and docs quote are the stored measurements, and the measurements are true.

``python -m eval numbers`` measures and writes them (eval/numbers/). Here: every marked region
of every document equals its rendering from ``docs/numbers/*.json`` (no hand edit, no stale
text), every measurement has a region, and the deterministic numbers are rerun at their stated
settings against the stored ones: seed 0 of each comparison row and of the second species by
its documented command, the SpeedChange random and steady baselines from the stored optima, one
of those optima, and the model's readings on random strokes (docs/model.md §1.3, §6.3) and the
resolution study of the defaults (§11.4).
Timings (the benchmarks' regions) are only checked to be their stored rendering.
The optima (the comparison's seed 0, the second species', the SpeedChange optimum) reproduce bit
for bit whatever the load and thread counts, but only under the BLAS kernel that measured them:
``python -m eval numbers`` measures them under the machine's own kernel and under
``framework.OTHER_BLAS_KERNELS``, a fresh optimum is compared bit for bit with the one stored for
the kernel it runs under, and under a kernel that was not measured with what the documents show
(their digits that every measured kernel gives, or the range between kernels).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable

import pytest

from eval import numbers
from eval.numbers import convergence, framework, optimisations, readings_paper, speed_change


def test_every_region_is_its_rendering() -> None:
    rendered = numbers.rendered_all()
    seen = set()
    for path in framework.DOCUMENTS:
        text = path.read_text(encoding="utf-8")
        for match in framework.regions(text):
            name = match["name"]
            assert name in rendered, f"{path.name}: unknown numbers region {name!r}"
            assert match["body"] == rendered[name], (
                f"{path.name}: the {name!r} region differs from docs/numbers/{name}.json "
                "(run `python -m eval numbers --render`, or `python -m eval numbers` to remeasure)"
            )
            seen.add(name)
    assert seen == set(numbers.MEASUREMENTS), (
        f"measurements without a region: {set(numbers.MEASUREMENTS) - seen}"
    )


def test_render_document_rejects_unknown_region() -> None:
    with pytest.raises(KeyError, match="unknown numbers region 'nope'"):
        numbers.render_document("<!-- numbers: nope -->\nx\n<!-- /numbers -->", {})


@pytest.mark.slow
@pytest.mark.parametrize("row", optimisations.COMPARISON_ROWS, ids=lambda r: r.label.split(",")[0])
@pytest.mark.parametrize("method", optimisations.COMPARISON_METHODS)
def test_comparison_seed0_reproduces(row: optimisations.ComparisonRow, method: str) -> None:
    (fresh,) = optimisations.run_optimize(row, method, [0])

    def seed0(view: dict) -> dict:
        stored = next(r for r in view["rows"] if r["label"] == row.label and r["method"] == method)
        return next(s for s in stored["seeds"] if s["seed"] == 0)

    assert_optimum_reproduces(fresh, "comparison", seed0, "{:.4f}")


def assert_optimum_reproduces(
    fresh: dict, name: str, select: Callable[[dict], dict], form: str
) -> None:
    """``fresh`` (an optimum's ``objective`` and ``feasible``) is the one measurement ``name``
    stored for this BLAS kernel, bit for bit (``select`` picks it from a kernel's data); under a
    kernel that was not measured, it is what the documents show (``form``'s digits that every
    measured kernel gives, or inside their range), and feasible if it is under every kernel.

    Bit for bit whatever the load and the thread counts (numba's prange has no cross-thread sums;
    the harness runs BLAS on one thread). Another BLAS kernel, or another numpy, OpenBLAS,
    numba or cmaes version, moves the last bits of the search's and the polish's linear algebra,
    and the search turns that into other digits or another optimum (docs/harness.md,
    "Machine-dependent digits"): remeasure, do not widen."""
    data = framework.load(name)
    kernel = framework.blas_kernel()
    stored = framework.for_kernel(data, kernel)
    if stored is not None:
        old = select(stored)
        assert math.isclose(fresh["objective"], old["objective"], rel_tol=1e-9), (
            f"{name}: under the {kernel} kernel seed {old.get('seed', 0)} gives "
            f"{fresh['objective']!r}, docs/numbers/{name}.json says {old['objective']!r} "
            f"(rerun `python -m eval numbers --only {name}`)"
        )
        assert fresh["feasible"] == old["feasible"]
        return
    olds = [select(view) for view in framework.kernel_views(data).values()]
    values = [old["objective"] for old in olds]
    assert framework.within_shown(fresh["objective"], values, form), (
        f"{name}: under the {kernel} kernel, which was not measured, the optimum is "
        f"{fresh['objective']!r}; the documents show {framework.agreed(values, form)}"
    )
    assert fresh["feasible"] or not all(old["feasible"] for old in olds)


@pytest.mark.slow
def test_second_species_seed0_reproduces() -> None:
    """Seed 0 of the second species' documented command (docs/envs.md, "A second species"), run
    again: the same optimum, and the record holds the example file's insect."""
    from tandem_env.physics.insect import insect_mapping, load_insect

    label, insect = optimisations.SPECIES_INSECTS[-1]

    def seed0(view: dict) -> dict:
        stored = next(r for r in view["rows"] if r["label"] == label)
        return next(s for s in stored["seeds"] if s["seed"] == 0)

    (fresh,) = optimisations.run_species(insect, [0])
    assert_optimum_reproduces(fresh, "second-species", seed0, "{:.4f}")
    expected = insect_mapping(load_insect(framework.ROOT / optimisations.SPECIES_FILE))
    assert fresh["insect"] == expected == seed0(framework.load("second-species"))["insect"]


def assert_same_rows(fresh: list[dict], stored: list[dict], what: str) -> None:
    assert [r["policy"] for r in fresh] == [r["policy"] for r in stored]
    for new, old in zip(fresh, stored, strict=True):
        assert new.keys() == old.keys()
        for key, value in old.items():
            if isinstance(value, float):
                same = math.isclose(new[key], value, rel_tol=1e-9, abs_tol=1e-12) or (
                    math.isnan(new[key]) and math.isnan(value)
                )
            else:
                same = new[key] == value
            assert same, (
                f"{what}: {old['policy']} {key} is {new[key]!r}, docs say {value!r} "
                "(rerun `python -m eval numbers --only speed-change`)"
            )


def test_speed_change_baselines_reproduce() -> None:
    """The random and steady rows, flown again from the stored optima (one batched model call
    per cycle for the 32 episodes): the env, the dynamics and the metrics are deterministic."""
    stored = framework.load("speed-change")
    fresh = speed_change.speed_change_rows(stored["optima"], stored["first_seed"])
    assert_same_rows(fresh, stored["rows"], speed_change.SPEED_CHANGE_COMMAND)


@pytest.mark.slow
def test_speed_change_optimum_reproduces() -> None:
    """One of the steady schedule's optima (the 1.5 m/s one), rerun as ``eval speed-change``
    makes it, gives the stored stroke."""

    def at_15(view: dict) -> dict:
        return next(o for o in view["optima"] if o["speed"] == 1.5)

    stored = at_15(framework.load("speed-change"))
    (fresh,) = speed_change.speed_change_optima([1.5])
    assert (fresh["method"], fresh["budget"], fresh["seed"]) == (
        stored["method"],
        stored["budget"],
        stored["seed"],
    ), (
        "the command's optimiser defaults changed (rerun `python -m eval numbers --only speed-change`)"
    )
    assert_optimum_reproduces(fresh, "speed-change", at_15, "{:.3f}")
    this_kernel = framework.for_kernel(framework.load("speed-change"), framework.blas_kernel())
    if this_kernel is not None:
        assert fresh["normalised_stroke"] == pytest.approx(
            at_15(this_kernel)["normalised_stroke"], abs=1e-9
        )


@pytest.mark.parametrize("name", ["rotational-coefficient", "power-conventions"])
def test_model_readings_reproduce(name: str) -> None:
    """The readings of the model on random strokes (docs/model.md §1.3, §6.3), measured again."""
    stored = framework.load(name)
    fresh = numbers.MEASUREMENTS[name].measure()
    assert fresh.keys() == stored.keys() - {"machine_before", "machine_after"}
    assert fresh["rows"] == [
        {key: pytest.approx(value, rel=1e-9) for key, value in row.items()}
        for row in stored["rows"]
    ], (
        f"{name} differs from docs/numbers/{name}.json (rerun `python -m eval numbers --only {name}`)"
    )


def test_convergence_reproduces() -> None:
    """The resolution study of the defaults (docs/model.md §11.4), its command rerun; the
    throughput it also prints is a timing and not compared."""
    stored = framework.load("convergence")
    fresh = convergence.CONVERGENCE.run()
    assert [(r["n_time"], r["n_blade"], r["speed"]) for r in fresh["rows"]] == [
        (r["n_time"], r["n_blade"], r["speed"]) for r in stored["rows"]
    ]
    for new, old in zip(fresh["rows"], stored["rows"], strict=True):
        for name, error in old["error_percent"].items():
            assert new["error_percent"][name] == pytest.approx(error, rel=1e-9), (
                f"{stored['command']}: {name} at V = {old['speed']} m/s differs from "
                "docs/numbers/convergence.json (rerun `python -m eval numbers --only convergence`)"
            )


def test_the_readings_runs_copies_in_the_docs_are_its_collected_outputs() -> None:
    """docs/readings/ and docs/figures/ hold the paper-preset readings run's own files, as
    collected: the table's rows are the copied readings.csv's, the bias check the manifest's."""
    import csv

    data = framework.load("readings-paper")
    copies = readings_paper.READINGS_PAPER_FILES
    with open(copies["readings.csv"], newline="", encoding="utf-8") as handle:
        assert list(csv.DictReader(handle)) == data["rows"]
    manifest = json.loads(copies["readings_manifest.json"].read_text(encoding="utf-8"))
    assert manifest["continuation_check"] == data["continuation_check"]
    assert [r["name"] for r in manifest["readings"]] == [r["reading"] for r in data["rows"]]
    assert copies["readings_matrix.png"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_paper_reading_is_the_stored_runs_strict_best() -> None:
    """``--reading paper`` names the reading with the most agreeing claims in the stored
    paper-preset readings run, strictly, and its model options are ``ModelOptions.preset``'s."""
    from eval.studies.readings import ALIASES, reading_by_name
    from tandem_env.physics.options import PRESETS, ModelOptions

    rows = framework.load("readings-paper")["rows"]
    agree = {r["reading"]: int(r["agree"]) for r in rows}
    best = ALIASES["paper"]
    assert all(count < agree[best] for name, count in agree.items() if name != best)
    paper = reading_by_name("paper")
    assert paper.name == best and paper.model_options == ModelOptions.preset("paper")
    model_changes = {k: v for k, v in paper.changes().items() if k in PRESETS["paper"]}
    assert model_changes == dict(PRESETS["paper"])


def test_kernel_dependent_digits_are_shown_as_measured() -> None:
    """A number the BLAS kernels agree on at the shown digits is shown once, one they do not as
    their range; a fresh value from an unmeasured kernel is checked against what is shown."""
    assert framework.agreed([1.69243403, 1.69243446], "{:.4f}") == "1.6924"
    assert framework.agreed([1.6740, 1.6831, 1.6740], "{:.4f}") == "1.6740–1.6831"
    assert framework.within_shown(1.67951, [1.6740, 1.6831], "{:.4f}")
    assert not framework.within_shown(1.6466, [1.6740, 1.6831], "{:.4f}")
    assert framework.within_shown(1.69244, [1.69243403, 1.69243446], "{:.4f}")
    assert not framework.within_shown(1.69256, [1.69243403, 1.69243446], "{:.4f}")


def test_optimisation_numbers_are_stored_under_every_kernel() -> None:
    """Every measurement whose numbers come from optimisations holds them under the machine's
    own BLAS kernel and under each of ``framework.OTHER_BLAS_KERNELS``, each with the same rows."""
    dependent = [name for name, m in numbers.MEASUREMENTS.items() if m.blas_dependent]
    assert {"comparison", "second-species", "speed-change"} <= set(dependent)
    for name in dependent:
        data = framework.load(name)
        views = framework.kernel_views(data)
        assert "blas_kernel" in data, f"{name}: rerun `python -m eval numbers --only {name}`"
        missing = {k.lower() for k in framework.OTHER_BLAS_KERNELS} - {k.lower() for k in views}
        assert not missing, f"{name} was not measured under {missing}"
        shapes = {json.dumps(_shape(view)) for view in views.values()}
        assert len(shapes) == 1, f"{name}: the kernels' data differ in shape"


def _shape(data: object) -> object:
    """The keys and lengths of ``data``, without its values."""
    if isinstance(data, dict):
        return {
            k: _shape(v)
            for k, v in data.items()
            if k not in ("machine_before", "machine_after", "other_kernels", "blas_kernel")
        }
    if isinstance(data, list):
        return [_shape(v) for v in data]
    return type(data).__name__
