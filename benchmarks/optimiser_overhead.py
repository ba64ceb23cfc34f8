"""How much of an optimisation run is the optimiser itself?

Runs a harness method (``pso``, ``cmaes``, ``random``) on a flight task as ``agents.harness``
does (ask, one vector-env step of the whole batch, tell) and times separately the model call,
the vector-env step (the model call plus the env's own work), ask + tell and, for ``cmaes``, the
time inside the ``cmaes`` package's public calls (wrapped for the benchmark's duration). The
overhead is everything but the env step, as a share of the run time, measured in one process.
What share is acceptable is stated in docs/harness.md. Usage::

    python benchmarks/optimiser_overhead.py [--method cmaes] [--method-config popsize=20]
        [--task level] [--evaluations 12000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import astuple, dataclass
from functools import partial
from typing import Any

import cmaes
import numpy as np

from agents.evaluator import VectorEnvEvaluator
from agents.methods import AskTellMethod, get_method
from agents.tasks import get_task
from tandem_env.envs import base
from tandem_env.io.keyvalue import add_pairs_argument

CONDITIONS = {"level": ({"speed": 1.5}, 1.5), "accelerate": ({"available_power": 60.0}, 60.0)}
#: The package's public calls our CMA-ES makes (agents/cmaes_search.py): its whole work.
PACKAGE_CALLS = {"cmaes": tuple((cmaes.CMAwM, name) for name in ("ask", "tell", "should_stop"))}


@dataclass
class Timing:
    total: float = 0.0
    env_step: float = 0.0
    model: float = 0.0
    ask_tell: float = 0.0
    package: float = 0.0
    """Time inside the optimiser's package (cmaes only) [s]."""
    evaluations: int = 0
    iterations: int = 0


@contextmanager
def timed_calls(calls: Iterable[tuple[Any, str]], timing: Timing, field: str) -> Iterator[None]:
    """While the block runs, add the time spent in the callables ``calls`` ((owner, name)
    pairs) to ``timing.<field>``, counting the outermost of nested calls only."""
    depth = 0

    def timed(call: Callable[..., Any]) -> Callable[..., Any]:
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            nonlocal depth
            depth += 1
            start = time.perf_counter()
            try:
                return call(*args, **kwargs)
            finally:
                depth -= 1
                if depth == 0:
                    setattr(timing, field, getattr(timing, field) + time.perf_counter() - start)

        return wrapper

    saved = [(owner, name, getattr(owner, name)) for owner, name in calls]
    for owner, name, call in saved:
        setattr(owner, name, timed(call))
    try:
        yield
    finally:
        for owner, name, call in saved:
            setattr(owner, name, call)


def time_run(
    method: str, settings: dict[str, Any], task_name: str, evaluations: int, seed: int
) -> Timing:
    timing = Timing()
    task = get_task(task_name)
    env_kwargs, value = CONDITIONS[task_name]
    search = get_method(method, settings)
    if not isinstance(search, AskTellMethod):
        raise SystemExit(f"{method} is not an ask/tell optimiser")
    optimiser = search.config(evaluations, task).build(28, seed)
    start = time.perf_counter()
    with (
        timed_calls([(base, "evaluate")], timing, "model"),  # every env's one model call
        timed_calls(PACKAGE_CALLS.get(method, ()), timing, "package"),
        timed_calls([(optimiser, "ask"), (optimiser, "tell")], timing, "ask_tell"),
        VectorEnvEvaluator(task, task.condition(value), env_kwargs, seed, evaluations) as evaluator,
    ):
        while not optimiser.done:
            X = optimiser.ask()
            optimiser.tell(X, evaluator(X))
        timing.total = time.perf_counter() - start
        timing.env_step = evaluator.step_time
        timing.evaluations = evaluator.evaluations
        timing.iterations = evaluator.iterations
    return timing


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--method", default="pso", help="pso (default), cmaes or random")
    add_pairs_argument(parser, "--method-config", "method settings")
    parser.add_argument("--task", choices=tuple(CONDITIONS), default="level")
    parser.add_argument("--evaluations", type=int, default=12_000, help="budget per run")
    parser.add_argument("--repeats", type=int, default=3, help="runs (seeds 0..repeats-1)")
    args = parser.parse_args(argv)
    settings = args.method_config
    run = partial(time_run, args.method, settings, args.task)
    run(200, 0)  # warm-up: numba cache, env construction
    timings = [run(args.evaluations, seed) for seed in range(args.repeats)]
    env_kwargs, _ = CONDITIONS[args.task]
    print(
        f"{args.method} {settings or ''} on {args.task} {env_kwargs}: {args.evaluations} "
        f"evaluations per run, {args.repeats} runs"
    )
    print(
        f"{'run':>4} {'batches':>8} {'total [s]':>10} {'model [s]':>10} {'env step [s]':>13} "
        f"{'ask+tell [s]':>13} {'evals/s':>9} {'overhead':>9}"
    )
    for k, t in enumerate(timings):
        print(
            f"{k:>4} {t.iterations:>8} {t.total:>10.3f} {t.model:>10.3f} {t.env_step:>13.3f} "
            f"{t.ask_tell:>13.4f} {t.evaluations / t.total:>9.0f} "
            f"{(t.total - t.env_step) / t.total:>8.2%}"
        )
    total, env_step, model, ask_tell, package, _, iterations = (
        sum(values) for values in zip(*map(astuple, timings), strict=True)
    )
    print(
        f"all  vector-env step {env_step:.3f} s ({env_step / total:.1%} of the run; of which "
        f"the model call {model:.3f} s, the env's own work {env_step - model:.3f} s)"
    )
    print(
        f"all  optimiser overhead (everything but the env step) {total - env_step:.3f} s = "
        f"{(total - env_step) / total:.2%} of {total:.3f} s (ask+tell {ask_tell:.3f} s = "
        f"{ask_tell / total:.2%})"
    )
    if args.method in PACKAGE_CALLS:
        print(
            f"     of which inside the {args.method} package (ask, tell, should_stop) "
            f"{package:.3f} s = {package / total:.2%} of the run, our own code "
            f"{total - env_step - package:.3f} s = {(total - env_step - package) / total:.2%}"
        )
    per_eval = np.array([t.ask_tell / t.evaluations for t in timings])
    in_package = f" (of which the package {package / iterations * 1e3:.3f} ms)"
    in_package = in_package if args.method in PACKAGE_CALLS else ""
    print(
        f"     ask+tell per evaluated point: {per_eval.mean() * 1e6:.1f} µs, per batch "
        f"{ask_tell / iterations * 1e3:.3f} ms{in_package} against "
        f"{env_step / iterations * 1e3:.2f} ms of env step"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
