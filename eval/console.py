"""Console scripts (``[project.scripts]`` in pyproject.toml): ``tandem-study``,
``tandem-optimize``, ``tandem-compare`` and ``tandem-measured`` are
``python -m eval study|optimize|compare|measured``."""

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


def measured() -> int:
    """``tandem-measured ARGS`` = ``python -m eval measured ARGS``."""
    return main(["measured", *sys.argv[1:]])
