"""The kernel's equality cases and their stored values (tests/physics/test_kernel_equal.py).

    PYTHONPATH=<tree of commit 8e3cf19> python tests/physics/kernel_cases.py [--per-set 64]
        [--batch 256] [--out tests/data/kernel_8e3cf19.npz]

evaluates, with the ``tandem_env`` found first on the path (the pinned kernel, extracted with
``git archive 8e3cf19 tandem_env | tar -x -C <tree>``), every reference optimum of 8e3cf19's
packaged table (its planform and condition, default options; kept in
tests/data/kernel_8e3cf19_optima.npz, since the packaged table has been regenerated since), ``--batch`` random Table 4 strokes at V = 1 m/s with
``slipstream="mean"`` (the speed benchmark's call) and ``--per-set`` random strokes under every
option set of the torch-backend test (tests/physics/test_torch_backend.py), and writes every
``Result`` array field of all of them to ``--out`` (compressed npz).

    PYTHONPATH=. python tests/physics/kernel_cases.py --canary

writes the same cases, fewer strokes, with this tree's model to :data:`CANARY`, beside its
``MODEL_REVISION`` and ``VORTEX_REVISION`` (after each bump of either: test_kernel_equal.py's
canary).
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

import tandem_env as te

sys.path.insert(0, str(Path(__file__).parent))
from test_torch_backend import OPTION_SETS, _case

FIXTURE = Path(__file__).parents[1] / "data" / "kernel_8e3cf19.npz"
#: 8e3cf19's reference optima: per series its env id, objective and planform, and its
#: normalised strokes and conditions (``strokes_<i>``, ``conditions_<i>``).
OPTIMA = FIXTURE.with_name("kernel_8e3cf19_optima.npz")
#: The canary: today's values of the cases (``--per-set 3 --batch 8``) and ``revision``.
CANARY = FIXTURE.with_name("model_canary.npz")


def options_of(name: str) -> te.ModelOptions:
    """The option set a case's name spells (``repr(ModelOptions(...))``, values literals)."""
    body = name.removeprefix("ModelOptions(").removesuffix(")")
    fields = (item.split("=", 1) for item in body.split(", "))
    return te.ModelOptions(**{key: ast.literal_eval(value) for key, value in fields})


def cases(
    per_set: int, batch: int, option_sets: Sequence[te.ModelOptions] = OPTION_SETS
) -> Iterator[tuple[str, te.Result]]:
    """(name, Result) of every case, in a fixed order. ``option_sets``: the torch test's
    (its pairwise covering grows with the options: the stored fixture names its own)."""
    optima = np.load(OPTIMA)
    paper = te.ModelOptions(slipstream="mean")  # 8e3cf19's default, whatever today's is
    for i, (env_id, objective, planform) in enumerate(optima["series"]):
        strokes = te.normalised_to_physical(optima[f"strokes_{i}"])
        condition = optima[f"conditions_{i}"]
        insect = te.DRAGONFLY.with_planform(str(planform))
        level = env_id.startswith("TandemWing/LevelFlight")
        speed, power = (condition, None) if level else (0.0, condition)
        result = te.evaluate(strokes, speed, power, insect=insect, options=paper)
        yield env_id + objective + planform, result
    rng = np.random.default_rng(2026)
    strokes = te.normalised_to_physical(rng.uniform(-1.0, 1.0, (batch, 28)))
    yield "mean-slipstream", te.evaluate(strokes, 1.0, options=te.ModelOptions(slipstream="mean"))
    for index, options in enumerate(option_sets):
        insect = te.DRAGONFLY.with_planform(("tear-drop", "real")[index % 2])
        strokes, speed, gamma = _case(index, per_set)
        yield (
            repr(options),
            te.evaluate(strokes, speed, flight_path_angle=gamma, insect=insect, options=options),
        )


def stacked(
    per_set: int, batch: int, option_sets: Sequence[te.ModelOptions] = OPTION_SETS
) -> dict[str, np.ndarray]:
    """Every case's fields concatenated, with each case's name and size."""
    names, sizes, fields = [], [], {}
    for name, result in cases(per_set, batch, option_sets):
        names.append(name)
        sizes.append(len(result))
        for field, value in result.as_dict().items():
            fields.setdefault(field, []).append(value)
    return {"case_names": np.array(names), "case_sizes": np.array(sizes)} | {
        field: np.concatenate(values) for field, values in fields.items()
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-set", type=int, default=64)
    parser.add_argument("--batch", type=int, default=256)
    parser.add_argument("--out", type=Path, default=FIXTURE)
    parser.add_argument("--canary", action="store_true", help=f"write {CANARY.name}")
    args = parser.parse_args()
    print(f"evaluating with {te.__file__}")
    per_set, batch = (3, 8) if args.canary else (args.per_set, args.batch)
    revision = (
        {"revision": te.physics.MODEL_REVISION, "vortex_revision": te.physics.VORTEX_REVISION}
        if args.canary
        else {}
    )
    np.savez_compressed(
        CANARY if args.canary else args.out,
        per_set=per_set,
        batch=batch,
        **revision,
        **stacked(per_set, batch),
    )
