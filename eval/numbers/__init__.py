"""``python -m eval numbers``: measure the numbers README and docs quote, and write them in.

A number a document states is produced here, by the command the document names, and written
between the markers ``<!-- numbers: NAME -->`` and ``<!-- /numbers -->`` (generated Markdown,
never edited by hand). Each measurement keeps its raw results in ``docs/numbers/<name>.json``
(per-seed values, commands, date, machine and load) and its Markdown is rendered from that
file alone: ``--only NAME ...`` measures those (the ``on_request`` ones, which collect a long
run's outputs, only when named), ``--render`` rewrites the documents from the stored JSON.
``tests/test_docs_numbers.py`` checks every region against its rendering and reruns the
deterministic rows. A new number is a :class:`~eval.numbers.framework.Measurement` in a
module of this package (its ``MEASUREMENT`` or ``MEASUREMENTS``) and one region in a document.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import re
import sys

from eval.numbers import framework

NAME = "numbers"
HELP = "rerun the measurements README and docs quote, and write them into the documents"


#: Every measurement by name: each module's ``MEASUREMENT`` (or its ``MEASUREMENTS``), every
#: module of this package but the framework holding one measurement (or a set of them).
MEASUREMENTS: dict[str, framework.Measurement] = {
    m.name: m
    for info in pkgutil.iter_modules(__path__)
    if info.name != "framework"
    for module in [importlib.import_module(f"{__name__}.{info.name}")]
    for m in getattr(module, "MEASUREMENTS", None) or (module.MEASUREMENT,)
}


def render_document(text: str, rendered: dict[str, str]) -> str:
    """``text`` with every marked region replaced by its rendering (a measurement not stored
    yet: left as it is; a name no measurement has: KeyError)."""

    def body(match: re.Match[str]) -> str:
        if (name := match["name"]) in rendered:
            return match.group(1) + rendered[name] + match.group(4)
        if name in MEASUREMENTS:
            return match.group(0)
        raise KeyError(f"unknown numbers region {name!r}; known: {sorted(rendered)}")

    return framework.REGION.sub(body, text)


def rendered_all() -> dict[str, str]:
    """Every stored measurement's Markdown (one not measured yet has none)."""
    return {
        name: m.render(framework.load(name))
        for name, m in MEASUREMENTS.items()
        if framework.json_path(name).exists()
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
            before = framework.machine()
            data = MEASUREMENTS[name].measure()
            if MEASUREMENTS[name].blas_dependent:
                data |= framework.measure_other_kernels(name)
            data |= {"machine_before": before, "machine_after": framework.machine()}
            framework.save(name, data)
    rendered = rendered_all()
    for path in framework.DOCUMENTS:
        text = path.read_text(encoding="utf-8")
        if (new := render_document(text, rendered)) != text:
            path.write_text(new, encoding="utf-8")
            print(f"updated {path.relative_to(framework.ROOT)}")
    return 0
