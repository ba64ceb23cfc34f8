"""Env throughput: the single env, the native vector env and the SB3 adapter against the raw model.

Run ``python benchmarks/env_throughput.py`` (about 30 s): strokes evaluated per second, where
stepping n = 1024 envs should cost about one ``evaluate`` call at B = 1024. The native env is
timed in both autoreset modes (next-step resets every other step). ``--json PATH`` also writes
the numbers (``python -m eval numbers`` renders docs/envs.md from them).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial
from typing import Any

import gymnasium as gym
import numpy as np
from shared import parser_with_json, write_numbers

import tandem_env as te

ENV_ID = "TandemWing/LevelFlight-v0"


def rate(run: Callable[[], Any], seconds: float, strokes: int | None = None) -> float:
    """Strokes per second of ``run`` over ``seconds``: ``strokes`` per call, or (None) the
    number ``run`` returns, the strokes it evaluated."""
    run()  # warm-up: numba compilation or cache load, first-call allocations
    count, start = 0, time.perf_counter()
    while (elapsed := time.perf_counter() - start) < seconds:
        done = run()
        count += done if strokes is None else strokes
    return count / elapsed


def main() -> None:
    parser = parser_with_json(__doc__)
    parser.add_argument("--num-envs", type=int, default=1024, help="vector width n (default 1024)")
    parser.add_argument("--seconds", type=float, default=4.0, help="time per measurement [s]")
    args = parser.parse_args()
    n, seconds = args.num_envs, args.seconds
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1.0, 1.0, (n, 28)).astype(np.float32)
    physical = te.normalised_to_physical(actions.astype(np.float64))
    rows = [
        (f"evaluate, B = {b}", rate(partial(te.evaluate, physical[:b], 1.5), seconds, b))
        for b in (1, n)
    ]
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    single = rate(lambda: (env.reset(), env.step(actions[0])), seconds, 1)
    rows.append(("single env (gym.make), reset + step", single))
    vectorised = {"num_envs": n, "vectorization_mode": "vector_entry_point"}
    for mode, label in (("NextStep", "next-step autoreset"), ("SameStep", "same-step autoreset")):
        envs = gym.make_vec(ENV_ID, **vectorised, autoreset_mode=mode)
        envs.reset(seed=0)
        # Count the strokes actually evaluated (terminated envs), not the reset steps.
        vector = rate(lambda: int(envs.step(actions)[2].sum()), seconds)  # noqa: B023
        rows.append((f"native vector env, n = {n}, {label}", vector))
        envs.close()

    from tandem_env.envs.sb3 import make_sb3_vec_env

    venv = make_sb3_vec_env(ENV_ID, n_envs=n, seed=0)
    venv.reset()
    sb3 = rate(partial(venv.step, actions), seconds, n)
    rows.append((f"SB3 adapter (TandemVecEnv), n = {n}", sb3))
    venv.close()

    reference = rows[1][1]
    width = max(len(name) for name, _ in rows)
    print(f"{'':{width}}  strokes/s   vs evaluate(B={n})")
    for name, value in rows:
        print(f"{name:{width}}  {value:9.0f}   {value / reference:6.1%}")
    table = [{"case": c, "strokes_per_s": v, "of_reference": v / reference} for c, v in rows]
    numbers = {"num_envs": n, "seconds": seconds, "reference": rows[1][0], "rows": table}
    write_numbers(args.json, numbers)


if __name__ == "__main__":
    main()
