"""Resolution study: errors of several resolutions against a 4× refined run.

    python benchmarks/convergence.py [--strokes 100] [--seed 2024] [--resolutions 128x24 ...]

For each (n_time, n_blade), the relative error of L/W, T, D and P against the same model at
4× the samples and blade elements, over random Table 4 strokes at V = 0, 1 and 2 m/s, with an
absolute floor of 0.1·W for forces (0.1 for L/W). Also prints each resolution's throughput.
``--json PATH`` also writes the numbers to PATH (``python -m eval numbers`` renders
docs/model.md §11.4 from it).
"""

from __future__ import annotations

import argparse
from functools import partial
from typing import Any

import numpy as np
from shared import parser_with_json, seconds_per_call, write_numbers

import tandem_env as te

FLOORS = {"lift_to_weight": 0.1, "thrust": 0.1, "drag": 0.1, "power": 0.0}
RESOLUTIONS = ((48, 8), (64, 12), (96, 16), (96, 24), (128, 16), (128, 24), (128, 32))
"""(n_time, n_blade) of the study."""


def resolution(text: str) -> tuple[int, int]:
    """``"128x24"`` -> (128, 24)."""
    n_time, _, n_blade = text.partition("x")
    try:
        return int(n_time), int(n_blade)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}; allowed: N_TIMExN_BLADE, e.g. 128x24"
        ) from None


def errors(strokes, speed, options, refined):
    coarse = te.evaluate(strokes, speed, options=options)
    fine = te.evaluate(strokes, speed, options=refined)
    out = {}
    for name, floor in FLOORS.items():
        scale = floor if name == "lift_to_weight" else floor * te.DRAGONFLY.weight
        ref = getattr(fine, name)
        out[name] = np.abs(getattr(coarse, name) - ref) / np.maximum(np.abs(ref), scale)
    return out


def main() -> None:
    parser = parser_with_json(__doc__)
    parser.add_argument("--strokes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=2024)
    parser.add_argument(
        "--resolutions",
        type=resolution,
        nargs="+",
        default=list(RESOLUTIONS),
        metavar="N_TIMExN_BLADE",
        help="resolutions to study (default: all seven)",
    )
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    strokes = te.normalised_to_physical(rng.uniform(-1, 1, (args.strokes, 28)))
    batch = te.normalised_to_physical(rng.uniform(-1, 1, (1024, 28)))
    default = te.ModelOptions()
    print(
        f"default: n_time={default.n_time}, n_blade={default.n_blade}; errors in % (median / p95 / max)"
    )
    rows: list[dict[str, Any]] = []
    for n_time, n_blade in args.resolutions:
        options = te.ModelOptions(n_time=n_time, n_blade=n_blade)
        refined = te.ModelOptions(n_time=4 * n_time, n_blade=4 * n_blade)
        te.evaluate(batch[:4], 1.0, options=options)
        rate = 1024 / seconds_per_call(partial(te.evaluate, batch, 1.0, options=options))[0]
        for speed in (0.0, 1.0, 2.0):
            cells, percent = [], {}
            for name, e in errors(strokes, speed, options, refined).items():
                p50, p95, p100 = 100 * np.percentile(e, [50, 95, 100])
                cells.append(f"{name[:6]} {p50:.3f}/{p95:.3f}/{p100:.3f}")
                percent[name] = {"median": p50, "p95": p95, "max": p100}
            print(
                f"n_time={n_time:>3} n_blade={n_blade:>2} V={speed:.0f} ({rate:6.0f} evals/s)  "
                + "  ".join(cells)
            )
            row = {"n_time": n_time, "n_blade": n_blade, "speed": speed}
            rows.append(row | {"evaluations_per_s": rate, "error_percent": percent})
    write_numbers(args.json, {"strokes": args.strokes, "seed": args.seed, "rows": rows})


if __name__ == "__main__":
    main()
