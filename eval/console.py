"""Console scripts (``[project.scripts]`` in pyproject.toml): ``tandem-study``,
``tandem-optimize`` and ``tandem-compare`` are ``python -m eval study|optimize|compare``."""

from __future__ import annotations

import sys

from eval.__main__ import main


def study() -> int:
    """``tandem-study ARGS`` = ``python -m eval study ARGS``."""
    return main(["study", *sys.argv[1:]])


def optimize() -> int:
    """``tandem-optimize ARGS`` = ``python -m eval optimize ARGS``."""
    return main(["optimize", *sys.argv[1:]])


def compare() -> int:
    """``tandem-compare ARGS`` = ``python -m eval compare ARGS``."""
    return main(["compare", *sys.argv[1:]])
