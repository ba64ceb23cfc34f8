"""Follow ``python -m eval study all`` (tiny preset) from eval/study.py's main down to the first
record file, at run time; or, with ``train``, ``python -m train`` (a tiny PPO run with an
evaluation and a checkpoint) from train/__main__.py's main to its end, following the parsed
arguments and the ``TrainConfig`` made of them. A function *stays* when it receives the parsed
arguments (or the config), one of their values, or a value made from them (what such a function returned, or the object it
initialised); a *return* is a call into a file already visited, from another file; a *climb* a
call from a lower package floor to a higher one (tandem_env 1, agents 2, train 3, eval 4).
Counted over distinct functions and call edges, up to the first record file's write.

    python tests/route_count.py                  # from a worktree root (ROUTE_DERIVED=0: args only)
    python tests/route_count.py train            # the route of python -m train
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile

ROOT = os.getcwd()
sys.path.insert(0, ROOT)
#: What the route follows: the parsed arguments (and, for ``train``, the TrainConfig).
FOLLOWED: list[type] = [argparse.Namespace]
FLOORS = {"tandem_env": 1, "agents": 2, "train": 3, "eval": 4}
SCALARS = (int, float, bool, type(None))
#: ROUTE_DERIVED=0 follows only the parsed arguments and their values, not what is made of them.
DERIVED = os.environ.get("ROUTE_DERIVED", "1") != "0"


def floor(rel: str) -> int | None:
    return None if rel.startswith("..") else FLOORS.get(rel.split(os.sep)[0])


def study_route(out: str) -> None:
    """``python -m eval study all --preset tiny``."""
    from eval.__main__ import main as eval_main
    from eval.studies import presets
    from eval.studies.presets import TINY

    table = getattr(presets, "STUDY_PRESETS", None) or presets.PRESETS
    table[TINY.name] = TINY
    eval_main(["study", "all", "--preset", "tiny", "--out", out, "--quiet", "--no-cache"])


def train_route(out: str) -> None:
    """``python -m train``: a tiny PPO run (two rollouts of 2 x 8 strokes, an evaluation and a
    checkpoint after each)."""
    from train.__main__ import main as train_main
    from train.config import TrainConfig

    FOLLOWED.append(TrainConfig)

    train_main(["--algo", "ppo", "--env", "TandemWing/LevelFlight-v0", "-n", "32", "--n-envs",
                "8", "-params", "n_steps=2", "batch_size=16", "n_epochs=1", "--eval-freq", "16",
                "--save-freq", "16", "-f", out, "--no-progress", "--verbose", "0"])  # fmt: skip


def main() -> None:
    route = {"study": study_route, "train": train_route}[(sys.argv[1:] or ["study"])[0]]
    tracked: dict[int, object] = {}
    entered: list[tuple[str, str]] = []
    edges: list[tuple[tuple[str, str], tuple[str, str]]] = []
    receiving: dict[int, tuple[str, str]] = {}
    done = []

    def profile(frame, event, arg):
        rel = os.path.relpath(frame.f_code.co_filename, ROOT)
        if done or floor(rel) is None:
            return
        me = (rel, frame.f_code.co_qualname)
        if event == "call" and me == ("tandem_env/io/files.py", "write_json_atomic"):
            if f"{os.sep}records{os.sep}" in str(frame.f_locals.get("path")):
                done.append(me)  # the first record file: the route ends here
                return
        if event == "call":
            code = frame.f_code
            names = code.co_varnames[: code.co_argcount + code.co_kwonlyargcount]
            values = [frame.f_locals.get(n) for n in names]
            spaces = [v for v in values if isinstance(v, tuple(FOLLOWED))]
            for space in spaces:
                tracked[id(space)] = space
                for value in vars(space).values():
                    if not isinstance(value, SCALARS):
                        tracked[id(value)] = value
            if not any(id(v) in tracked for v in values):
                return
            if DERIVED and code.co_name == "__init__" and values:
                tracked[id(values[0])] = values[0]
            receiving[id(frame)] = me
            if me not in entered:
                entered.append(me)
            back = frame.f_back
            while back is not None and id(back) not in receiving:
                back = back.f_back
            if back is not None and (receiving[id(back)], me) not in edges:
                edges.append((receiving[id(back)], me))
        elif event == "return" and id(frame) in receiving:
            if DERIVED and not isinstance(arg, SCALARS):
                tracked[id(arg)] = arg
            del receiving[id(frame)]

    out = tempfile.mkdtemp()
    sys.setprofile(profile)
    try:
        route(out)
    finally:
        sys.setprofile(None)
    seen = {entered[0][0]}
    returns = climbs = 0
    for caller, callee in edges:
        if callee[0] != caller[0] and callee[0] in seen:
            returns += 1
        seen.add(callee[0])
        if (floor(callee[0]) or 0) > (floor(caller[0]) or 0):
            climbs += 1
            print("climb:", caller, "->", callee)
    for rel, name in entered:
        print(f"  {rel}: {name}")
    print(f"stays {len(entered)}, returns {returns}, climbs {climbs}")


if __name__ == "__main__":
    main()
