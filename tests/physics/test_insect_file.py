"""Another insect as data: a mapping or YAML file of what differs from the paper's specimen
(tandem_env.physics.insect.load_insect / insect_mapping), as the env keyword, the CLIs' --insect
and eval measured read it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from tandem_env import Dragonfly, Wing
from tandem_env.physics.insect import DRAGONFLY, describe_insect, insect_mapping, load_insect

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "scaled_dragonfly.yaml"


def test_the_specimen_is_the_empty_mapping() -> None:
    assert insect_mapping(DRAGONFLY) == {}
    assert load_insect({}) == DRAGONFLY
    assert "the paper's specimen" in describe_insect({})


@pytest.mark.parametrize(
    "spec",
    [
        {"body_mass": 2e-4},
        {"body_mass": 1, "wings_per_pair": 1},  # an integer mass is a float field's value
        {"fore": {"length": 0.03, "planform": "real"}, "hind": {"coefficients": "dickinson1999"}},
        {"hind": {"coefficients": {"model": "table", "alpha": [0, 45, 90], "lift": [0, 1, 0],
                                   "drag": [0.1, 1, 2]}}},
        {"fore": {"real_edges": [[0.0, 0.5, -0.5], [0.0, -0.5, 0.5]], "planform": "real"}},
    ],
)  # fmt: skip
def test_mapping_round_trip(spec: dict) -> None:
    insect = load_insect(spec)
    mapping = insect_mapping(insect)
    assert load_insect(mapping) == insect
    assert insect_mapping(load_insect(mapping)) == mapping
    assert insect != DRAGONFLY


def test_fields_flow_from_the_dataclasses() -> None:
    # every field of Dragonfly (and of each Wing) is a key, without a list of them to update
    with pytest.raises(ValueError) as error:
        load_insect({"no_such_field": 1})
    for f in dataclasses.fields(Dragonfly):
        assert f.name in str(error.value)
    for f in dataclasses.fields(Wing):
        changed = {f.name: getattr(DRAGONFLY.hind, f.name)}  # each one is read and kept
        assert load_insect({"fore": changed}).fore == dataclasses.replace(DRAGONFLY.fore, **changed)


def test_example_file(tmp_path: Path) -> None:
    insect = load_insect(EXAMPLE)
    assert insect.body_mass == pytest.approx(DRAGONFLY.body_mass * 1.5**3, rel=1e-3)
    assert insect.fore.length == pytest.approx(DRAGONFLY.fore.length * 1.5, rel=1e-3)
    assert insect.planform == "real"
    assert load_insect(str(EXAMPLE)) == insect
    # a file and its canonical mapping written out again are one insect
    copy = tmp_path / "copy.yaml"
    copy.write_text(str(insect_mapping(insect)).replace("'", '"'), encoding="utf-8")
    assert load_insect(copy) == insect


@pytest.mark.parametrize(
    "spec, message",
    [
        ({"bodymass": 1e-4}, r"^insect\.bodymass: unknown field; allowed: fore, hind, body_mass"),
        ({"fore": {"lenght": 0.03}}, r"^insect\.fore\.lenght: unknown field; allowed: mean_chord"),
        ({"fore": 3}, r"^insect\.fore = 3; allowed: a mapping of Wing fields"),
        ({"body_mass": -1.0}, r"Dragonfly\.body_mass = -1 kg; allowed: 0 < body_mass <= 10 kg"),
        ({"body_mass": "heavy"}, r"Dragonfly\.body_mass = 'heavy'"),
        ({"fore": {"planform": "round"}}, r"Wing\.planform = 'round'; allowed"),
        ({"fore": {"coefficients": "dickson"}}, r"coefficients\.model = 'dickson'"),
        ({"wings_per_pair": 3}, r"wings_per_pair = 3; allowed: 1 or 2"),
        (5, r"^insect = 5; allowed: a tandem_env\.Dragonfly"),
        ("no/such/file.yaml", r"no such file; allowed: a tandem_env\.Dragonfly"),
    ],
)
def test_bad_insects_name_the_key_and_what_is_allowed(spec: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        load_insect(spec)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "text, message",
    [
        ("body_mass: 1e-4\nbody_mass: 2e-4\n", r"duplicate key 'body_mass' on lines 1 and 2"),
        ("", r"is empty; allowed: a mapping of Dragonfly fields"),
        ("- 1\n- 2\n", r"insect = \[1, 2\]; allowed: a mapping of Dragonfly fields"),
        ("fore: {lenght: 1}\n", r"insect file '.*bad\.yaml': insect\.fore\.lenght: unknown field"),
        ("!!python/object:os.system {}\n", r"is not valid YAML"),  # the safe loader
    ],
)
def test_bad_insect_files(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ValueError, match=message):
        load_insect(path)
