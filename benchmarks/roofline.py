"""The kernel against the CPU's limit, and against a pinned earlier kernel, in one run.

    python benchmarks/roofline.py [--commit 8e3cf19] [--threads 1 2] [--rounds 7] [--json PATH]

The call timed is ``tandem_env.evaluate(strokes, speed=1.0, options=ModelOptions(slipstream=
"mean"))`` on B = 1024 random Table 4 strokes. Per stroke it prints the element samples (both
wings' blade elements × samples), the force sweeps and slopes (counted by the kernel,
``cycle.W_SWEEPS``, ``W_SLOPES``), and the floating-point operations and square roots, divisions
and libm calls per element sample, counted by running the kernel's own pointwise formulae
(``blade``, ``induction``, ``cycle.add_to_span``) once on counting numbers (``xp.on_namespace``).
Beside them the machine's limits measured here: FMA flops per cycle (a vectorised numba FMA
loop) and 1/sqrt(x) per cycle (the divider, which a sweep needs once per element sample). Cycles
are seconds × the clock the kernel reports in /proc/cpuinfo (a virtual machine's nominal clock).

Speed: the pinned commit's ``tandem_env`` (``git archive``, kept under results/roofline/) runs
in a second process; per round and thread count each process times ``--calls`` calls, back to
back (interleaved rounds), and the ratio old / new of the median seconds per call is printed.
It reports, never fails.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
COUNTS: dict[str, int] = {}
"""What :class:`Counted` numbers counted, by kind of operation."""


def workload(te, batch: int = 1024):
    """The call timed, with its strokes and options."""
    strokes = te.normalised_to_physical(np.random.default_rng(0).uniform(-1, 1, (batch, 28)))
    options = te.ModelOptions(slipstream="mean")
    return lambda: te.evaluate(strokes, 1.0, options=options), strokes, options


def worker() -> None:
    """Time the ``tandem_env`` on the path: read 'threads calls', answer seconds per call."""
    import numba
    from shared import seconds_per_call

    import tandem_env as te

    call = workload(te)[0]
    call()
    for line in sys.stdin:
        threads, calls = map(int, line.split())
        numba.set_num_threads(threads)
        print(*seconds_per_call(call, calls), flush=True)


class Counted(float):
    """A float that counts the arithmetic done on it (:data:`COUNTS`)."""


def _op(kind: str, fn):
    def apply(*args):
        COUNTS[kind] = COUNTS.get(kind, 0) + 1
        return Counted(fn(*map(float, args)))

    return apply


for _name in ("add", "radd", "sub", "rsub", "mul", "rmul", "truediv", "rtruediv"):
    _kind = "div" if _name.endswith("div") else "flop"
    setattr(Counted, f"__{_name}__", _op(_kind, getattr(float, f"__{_name}__")))
Counted.__neg__ = lambda x: Counted(-float(x))
Counted.__abs__ = lambda x: Counted(abs(float(x)))


class CountingNamespace:
    """The names the pointwise formulae call on ``np``, counting square roots and libm calls."""

    def __init__(self, np):
        self.sqrt = _op("sqrt", lambda x: np.sqrt(x))
        self.where = lambda c, a, b: a if c else b
        self.abs = abs
        for name in ("sin", "cos", "arctan2", "arcsin", "tanh"):
            setattr(self, name, _op("libm", getattr(np, name)))


def counted(function, *args) -> dict[str, int]:
    """The operations of one call of a numba function's formulae on :class:`Counted` numbers."""
    from tandem_env.physics.xp import on_namespace

    COUNTS.clear()
    on_namespace(function, CountingNamespace(np))(*args)
    return dict(COUNTS)


def operation_counts() -> dict[str, dict[str, int]]:
    """Per element sample: a force sweep's, a slope's and the span integration's operations."""
    from tandem_env.physics import blade, cycle, induction
    from tandem_env.physics.bundle import Section

    rng = np.random.default_rng(1)
    coef = np.array([[Counted(x) for x in rng.uniform(0.2, 1.0, blade.N_COEF)]], dtype=object)
    section = Section(*(Counted(x) for x in rng.uniform(0.1, 1.0, len(Section._fields))))
    u, v, du, dv, fc, fn, speed = (Counted(x) for x in rng.uniform(0.2, 1.0, 7))

    force_args = (u, v, du, dv, coef[0, blade.C_SPIN], section, speed)
    sweep = Counter(counted(blade.relative_velocity, coef, 0, section.r, u, v))
    sweep += Counter(counted(blade.element_speed, u, v))
    sweep += Counter(counted(blade.element_force_at, *force_args))
    sweep["flop"] += 4  # (F_c·e_c·z + F_n·e_n·z)·w and its running sum
    slope = Counter(counted(induction.normal_force_rate_at, u, v, *force_args))
    slope["flop"] += 2  # the weight and the running sum
    span = np.full((4, 1), Counted(0.0), dtype=object)
    samples = np.array([[Counted(x)] for x in (fc, fn, u, v)], dtype=object)
    integrate = counted(cycle.add_to_span, coef, samples, section, Counted(30.0), span)
    return {"sweep": dict(sweep), "slope": dict(slope), "span": integrate}


def machine_limits() -> dict[str, float]:
    """FMA flops and 1/sqrt(x) per ns of CPU time, each from a vectorised numba loop over data
    in L1 (best of 5)."""
    import numba
    from shared import seconds_per_call

    @numba.njit(fastmath={"contract"})
    def fma(x, n):
        for _ in range(n):
            for j in range(x.shape[0]):
                x[j] = x[j] * 0.999999 + 1e-7

    @numba.njit(error_model="numpy")
    def rsqrt(x, y, n):
        for _ in range(n):
            for j in range(x.shape[0]):
                y[j] = 1.0 / np.sqrt(x[j])

    x, y, n = np.ones(256), np.empty(256), 20_000
    fma(x, 1), rsqrt(x, y, 1)
    fma_s = min(seconds_per_call(lambda: fma(x, n), 1)[1] for _ in range(5))
    rsqrt_s = min(seconds_per_call(lambda: rsqrt(x, y, n), 1)[1] for _ in range(5))
    return {
        "fma_flops_per_ns": 2e-9 * x.size * n / fma_s,
        "rsqrt_per_ns": 1e-9 * x.size * n / rsqrt_s,
    }


def stages(te, options, strokes, inputs, repeats: int = 3) -> dict[str, float]:
    """CPU ms per call of one thread, the call split where its time goes: the angle histories
    (``parametric_kernel_inputs``), the frame coefficients and the cycle means of both wings
    (each timed alone in a compiled loop over the batch), the rest of the kernel (the force
    sweeps, slopes and span integrals of the inflow solve) and what is left outside it."""
    import numba
    from shared import seconds_per_call

    from tandem_env.physics import blade, cycle, model

    numba.set_num_threads(1)

    @numba.njit
    def frames(angles, weight, beta, out):
        for b in range(angles.shape[0]):
            blade.fill_frame_coefficients(angles[b], weight[b], beta[b], True, 1, out)

    @numba.njit
    def means(history, weight, out, cos_table, sin_table):
        for b in range(history.shape[0]):
            for wing in range(2):
                cycle.cycle_means(history[b, wing], weight[wing, b], out, cos_table, sin_table)

    angles, weights, _, beta, _, _ = inputs
    speed, path = np.ones(len(strokes)), np.zeros(len(strokes))
    kept = model.Kept(history=True)
    history = model.run_kernel(*inputs[:5], speed, path, te.DRAGONFLY, options, keep=kept).history
    coef = np.empty((options.n_time, blade.N_COEF))
    out = np.empty(cycle.N_WING_OUT)
    tables = cycle.fourier_tables(options.n_time)
    calls = {
        "whole call": lambda: te.evaluate(strokes, 1.0, options=options),
        "angle histories": lambda: model.parametric_kernel_inputs(strokes, options.n_time, False),
        "kernel": lambda: model.run_kernel(*inputs[:5], speed, path, te.DRAGONFLY, options),
        "frame coefficients": lambda: [
            frames(angles[w], weights[w], np.ascontiguousarray(beta[:, w]), coef) for w in (0, 1)
        ],
        "cycle means": lambda: means(history, np.stack(weights), out, *tables),
    }
    # twice each first: a process's first calls map fresh pages for the batch's arrays (glibc
    # serves them from the heap once it has freed a few), which alone doubled a call's time
    for call in [*calls.values(), *calls.values()]:
        call()
    ms = {k: 1e3 * min(seconds_per_call(c, 1)[1] for _ in range(repeats)) for k, c in calls.items()}
    sweeps = ms["kernel"] - ms["frame coefficients"] - ms["cycle means"]
    return {
        **{k: ms[k] for k in ("angle histories", "frame coefficients", "cycle means")},
        "sweeps, slopes and span integrals": sweeps,
        "outside the kernel": ms["whole call"] - ms["angle histories"] - ms["kernel"],
        "whole call": ms["whole call"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--commit", default="8e3cf19")
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--calls", type=int, default=3)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    os.environ["NUMBA_NUM_THREADS"] = str(max(args.threads))
    import numba
    from shared import seconds_per_call, write_numbers  # it loads numba: after NUMBA_NUM_THREADS

    import tandem_env as te
    from tandem_env.physics import cycle, model

    numbers = {key: getattr(args, key) for key in ("commit", "rounds", "calls")} | {"batch": 1024}
    mhz = [x for x in Path("/proc/cpuinfo").read_text().splitlines() if x.startswith("cpu MHz")]
    ghz = float(mhz[0].partition(":")[2]) / 1e3 if mhz else float("nan")
    numbers |= {"load_before": os.getloadavg()[0], "ghz": ghz, **machine_limits()}
    call, strokes, options = workload(te)
    inputs = model.parametric_kernel_inputs(strokes, options.n_time)
    out = model.run_kernel(*inputs[:5], np.ones(1024), np.zeros(1024), te.DRAGONFLY, options).means
    annuli = 2 * options.n_blade
    sweeps, slopes = (float(out[:, :, k].sum(1).mean()) for k in (cycle.W_SWEEPS, cycle.W_SLOPES))
    per_stroke = {"element_samples": annuli * options.n_time, "sweeps": sweeps, "slopes": slopes}
    ops = operation_counts()
    per_sample = {
        key: (sweeps * ops["sweep"].get(key, 0) + slopes * ops["slope"].get(key, 0)) / annuli
        + ops["span"].get(key, 0)
        for key in ("flop", "div", "sqrt", "libm")
    }
    numbers |= {"per_stroke": per_stroke, "operations": ops, "per_element_sample": per_sample}
    numbers["stages_ms"] = stages(te, options, strokes, inputs)
    print(
        "where the time goes (CPU ms per call, 1 thread):",
        ", ".join(f"{k} {v:.1f}" for k, v in numbers["stages_ms"].items()),
    )
    tree = ROOT / "results" / "roofline" / args.commit
    if not (tree / "tandem_env").exists():
        tree.mkdir(parents=True, exist_ok=True)
        git = ["git", "-C", str(ROOT), "archive", args.commit, "tandem_env"]
        archive = subprocess.run(git, check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
    env = {**os.environ, "PYTHONPATH": str(tree)}
    pipes = {"stdin": subprocess.PIPE, "stdout": subprocess.PIPE, "text": True}
    old = subprocess.Popen([sys.executable, __file__, "--worker"], env=env, cwd=tree, **pipes)
    call()
    times = {t: {"old": [], "new": []} for t in args.threads}  # (wall, CPU) s per call
    for _ in range(args.rounds):
        for threads in args.threads:
            print(threads, args.calls, file=old.stdin, flush=True)
            times[threads]["old"].append([float(x) for x in old.stdout.readline().split()])
            numba.set_num_threads(threads)
            times[threads]["new"].append(seconds_per_call(call, args.calls))
    old.stdin.close()
    old.wait()
    numbers["speed"] = []
    print(
        f"{numba.config.NUMBA_NUM_THREADS} numba threads at most, load average {os.getloadavg()[0]:.1f}"
    )
    for threads, t in times.items():
        row: dict = {"threads": threads}
        for i, kind in enumerate(("wall", "cpu")):
            before, now = np.array(t["old"])[:, i], np.array(t["new"])[:, i]
            ratios = before / now
            row |= {
                f"{kind}_old_ms": 1e3 * np.median(before),
                f"{kind}_new_ms": 1e3 * np.median(now),
                f"{kind}_ratio": float(np.median(ratios)),
                f"{kind}_range": [float(ratios.min()), float(ratios.max())],
            }
            print(
                f"{threads} thread(s), {kind}: {args.commit} {row[kind + '_old_ms']:.1f} ms, now "
                f"{row[kind + '_new_ms']:.1f} ms per call: {row[kind + '_ratio']:.2f}x "
                f"(rounds {ratios.min():.2f}-{ratios.max():.2f})"
            )
        numbers["speed"].append(row)
    ns = 1e-3 * numbers["speed"][0]["cpu_new_ms"] * 1e9 / 1024 / per_stroke["element_samples"]
    numbers |= {"ns_per_element_sample": ns, "load_after": os.getloadavg()[0]}
    print(f"per stroke: {per_stroke}; per element sample: {per_sample}")
    print(
        f"measured: {ns:.2f} ns = {ns * numbers['ghz']:.1f} cycles per element sample (whole call, "
        f"CPU time); machine: {numbers['fma_flops_per_ns'] / numbers['ghz']:.1f} FMA flops/cycle, "
        f"{numbers['rsqrt_per_ns'] / numbers['ghz']:.2f} 1/sqrt per cycle at {numbers['ghz']:.2f} GHz"
    )
    write_numbers(args.json, numbers)


if __name__ == "__main__":
    worker() if sys.argv[1:] == ["--worker"] else main()
