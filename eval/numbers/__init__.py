"""``python -m eval numbers``: measure the numbers README and docs quote, write them in."""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import re
import sys
from pathlib import Path
from types import ModuleType

from eval.numbers import framework as fw

NAME = "numbers"
HELP = "rerun the measurements README and docs quote, and write them into the documents"


#: Every module of this package but the framework: one per measurement (or set of them).
_MODULES: list[ModuleType] = [
    importlib.import_module(f"{__name__}.{m.name}")
    for m in pkgutil.iter_modules(__path__)
    if m.name != "framework"
]
#: Every measurement by name: each module's ``MEASUREMENT`` (or its ``MEASUREMENTS``).
MEASUREMENTS: dict[str, fw.Measurement] = {
    m.name: m
    for module in _MODULES
    for m in getattr(module, "MEASUREMENTS", None) or (module.MEASUREMENT,)
}


def render_document(text: str, rendered: dict[str, str]) -> str:
    """``text`` with every marked region rendered (KeyError for an unknown name)."""

    def body(match: re.Match[str]) -> str:
        name = match["name"]
        if name not in rendered and name in MEASUREMENTS:
            return match.group(0)
        if name not in rendered:
            raise KeyError(f"unknown numbers region {name!r}; known: {sorted(rendered)}")
        return match.group(1) + rendered[name] + match.group(4)

    return fw.REGION.sub(body, text)


def write_documents(rendered: dict[str, str]) -> list[Path]:
    changed = []
    for path in fw.DOCUMENTS:
        text = path.read_text(encoding="utf-8")
        if (new := render_document(text, rendered)) != text:
            path.write_text(new, encoding="utf-8")
            changed.append(path)
    return changed


def rendered_all() -> dict[str, str]:
    """Every stored measurement's Markdown (one not measured yet has none)."""
    return {n: m.render(fw.load(n)) for n, m in MEASUREMENTS.items() if fw.json_path(n).exists()}


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
            before, data = fw.machine(), MEASUREMENTS[name].measure()
            if MEASUREMENTS[name].blas_dependent:  # measured again under the other kernels
                kernels = {"blas_kernel": fw.blas_kernel()}
                data |= {**kernels, "other_kernels": fw.measure_other_kernels(name)}
            fw.save(name, {**data, "machine_before": before, "machine_after": fw.machine()})
    for path in write_documents(rendered_all()):
        print(f"updated {path.relative_to(fw.ROOT)}")
    return 0
