"""The vortex reading's reduced wake refined on random strokes (docs/model.md §5.8, item 9,
*Convergence*): how far the interaction's change of L/W at coarser settings lies from a finer
wake grid or longer wakes.

    python benchmarks/vortex_convergence.py [--strokes 128] [--seed 3]

Random Table 4 strokes at V uniform in 0-2 m/s; the interaction is the vortex reading against
``induction="isolated"``, counted on the strokes where it moves L/W by more than 5 % (at the
finer setting, every setting converged). Per comparison and speed band, |ΔL/W| between the two
settings over the interaction's change of L/W at the finer one, and in L/W itself (percent of
the weight): median, 90th percentile, largest. Each setting is ``interaction.WAKE`` with the fields named replaced.
``--json PATH`` also writes the numbers.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from shared import machine, parser_with_json, write_numbers

import tandem_env as te
from tandem_env.physics import interaction

SETTINGS: dict[str, dict[str, Any]] = {
    "defaults": {},
    "n_w = 32": {"n_wake": 32},
    "n_w = 64": {"n_wake": 64},
    "wakes 4/3 beats": {"fore_beats": 4.0, "hind_beats": 3.0},
    "wakes 6/5 beats": {"fore_beats": 6.0, "hind_beats": 5.0},
    "M = 8": {"read_points": 8},
    "M = 24": {"read_points": 24},
}
#: (coarser, finer) settings compared.
COMPARISONS = (
    ("defaults", "n_w = 64"),
    ("n_w = 32", "n_w = 64"),
    ("defaults", "wakes 4/3 beats"),
    ("defaults", "wakes 6/5 beats"),
    ("defaults", "M = 24"),
    ("M = 8", "M = 24"),
)
BANDS = ((0.0, 0.5), (0.5, 2.0))
"""Speed bands [m/s]: below 0.5 m/s the wakes linger under the wings."""
STRONG = 0.05
"""The strokes counted: the interaction moves L/W by more than this share of it [-]."""


def main() -> None:
    parser = parser_with_json(__doc__)
    parser.add_argument("--strokes", type=int, default=128)
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    strokes = te.normalised_to_physical(rng.uniform(-1, 1, (args.strokes, 28)))
    speeds = rng.uniform(0.0, 2.0, args.strokes)
    print(machine())
    alone = te.evaluate(strokes, speeds, options=te.ModelOptions(induction="isolated"))
    default, results = interaction.WAKE, {}
    for name, fields in SETTINGS.items():  # the reading takes its wake from interaction.WAKE
        interaction.WAKE = replace(default, **fields)
        results[name] = te.evaluate(strokes, speeds, options=te.ModelOptions(slipstream="vortex"))
    interaction.WAKE = default
    print(
        "|dL/W| over the interaction's change of L/W [%], and in % of the weight: median / p90 / max"
    )
    rows = []
    for coarse, fine in COMPARISONS:
        x, y = results[coarse].lift_to_weight, results[fine].lift_to_weight
        effect = y - alone.lift_to_weight
        converged = results[coarse].induction_converged & results[fine].induction_converged
        counted = converged & (np.abs(effect) > STRONG * np.abs(y))
        for low, high in BANDS:
            chosen = counted & (speeds >= low) & (speeds < high)
            n = int(chosen.sum())
            of_effect = 100 * np.abs(x - y)[chosen] / np.abs(effect)[chosen]
            of_weight = 100 * np.abs(x - y)[chosen]
            cells = [np.percentile(v, [50, 90, 100]) for v in (of_effect, of_weight)]
            print(
                f"{coarse:>16} vs {fine:<16} V {low:g}-{high:g} m/s ({n:>3} strokes): "
                + "   ".join("{:.1f} / {:.1f} / {:.1f}".format(*c) for c in cells)
            )
            row = {"coarse": coarse, "fine": fine, "band": [low, high], "strokes": n}
            for key, c in zip(("of_effect", "of_weight"), cells, strict=True):
                row[key] = {"median": c[0], "p90": c[1], "max": c[2]}
            rows.append(row)
    write_numbers(args.json, {"strokes": args.strokes, "seed": args.seed, "rows": rows})


if __name__ == "__main__":
    main()
