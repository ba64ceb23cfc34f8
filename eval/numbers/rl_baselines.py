"""PPO and SAC envelope policies against the reference optima (docs/training.md, "Scores at
the held-out conditions"): per algorithm, set of hyperparameters (:data:`HYPERPARAMETERS`) and
seed, a policy trained over level flight's envelope by the documented ``python -m train``
command, asked through ``python -m train.envelope`` for its stroke at each held-out condition
and scored against the reference table (100 = the certified optimum).

On request only, each: ``rl-baselines`` (twenty training runs, two at a time, about 45 min on
2 cores; the figure of score against speed is written beside the table), ``amortised-scores``
(the documented ``--algo amortised`` command, five seeds scored the same way; it redraws the
shared figure) and ``envelope-headline`` (README, "One network for the whole envelope": each
policy's median and worst score and the share that flies, read from the stored runs)."""

from __future__ import annotations

import shlex
import statistics
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from eval.figures import PALETTE, plt, save
from eval.numbers import framework
from eval.studies.report import table_head, table_row
from tandem_env.envs.reference import held_out_conditions

ENV_ID = "TandemWing/LevelFlight-v0"
#: (algo, training steps): the documented envelope run's 300 k for PPO; SAC's tuned 100 k.
ALGOS: tuple[tuple[str, int], ...] = (("ppo", 300_000), ("sac", 100_000))
SEEDS: tuple[int, ...] = (0, 1, 2, 3, 4)
ENVELOPE = "speed_range=(0.25, 2.0)"
AMORTISED = "amortised"
FIGURE = Path("docs") / "figures" / "rl_baselines_scores.png"
# One core per training run, two at a time (torch and numba would each take both otherwise).
_ONE_CORE = {"OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


#: The hyperparameters each algorithm is trained with: the shipped file's (None: the default
#: ``train/hyperparams/<algo>.yml``, tuned at V = 1.5 m/s) and the envelope's, tuned by
#: ``python -m train.tune`` (each file says how it was made).
HYPERPARAMETERS = {"shipped": None, "tuned": "train/hyperparams/envelope/{algo}.yml"}

#: Every envelope policy the figure and the README headline (``envelope-headline``) show, in
#: the figure's drawing and legend order: (the measurement that stores its runs, algo, a key of
#: :data:`HYPERPARAMETERS`: "" for the amortised policy).
POLICIES: tuple[tuple[str, str, str], ...] = (
    *(("rl-baselines", algo, hp) for algo, _ in ALGOS for hp in ("tuned", "shipped")),
    ("amortised-scores", "amortised", ""),
)


def train_command(algo: str, steps: int | str, seed: int | str, hyperparams: str) -> list[str]:
    """The documented training command of ``algo``: the envelope's with the ``hyperparams`` of
    :data:`HYPERPARAMETERS`, or the amortised policy's (``-f`` is added)."""
    if algo == AMORTISED:
        return f"python -m train --algo {algo} --env {ENV_ID} --seed {seed} --verbose 0".split()
    conf = HYPERPARAMETERS[hyperparams]
    return [
        *f"python -m train --algo {algo} --env {ENV_ID} --seed {seed} -n {steps}".split(),
        *("--env-kwargs", ENVELOPE, "--no-progress", "--no-tensorboard", "--torch-threads", "1"),
        *(() if conf is None else ("--conf-file", conf.format(algo=algo))),
    ]


def score_run(algo: str, steps: int, seed: int, variant: str, folder: Path) -> dict[str, Any]:
    """Train by :func:`train_command` (``variant``: the hyperparameters) into ``folder``, then
    score its stroke at each held-out condition through ``python -m train.envelope``."""
    logs = folder / f"{algo}{variant and '-' + variant}-{seed}"
    command = [*train_command(algo, steps, seed, variant), "-f", str(logs)]
    seconds = framework.run_command(command, _ONE_CORE)
    run = logs / algo / ENV_ID.replace("/", "-")  # the latest run of the env
    out = folder / f"envelope-{logs.name}"
    envelope = ["python", "-m", "train.envelope", "--run", str(run), "--out", str(out)]
    conditions = map(str, held_out_conditions(ENV_ID))
    framework.run_command([*envelope, "--conditions", *conditions], _ONE_CORE)
    rows = framework.read_rows(out / "envelope.csv")
    trained = {"algo": algo, **({"hyperparams": variant} if variant else {}), "seed": seed}
    return trained | {
        "steps": steps,
        "train_s": round(seconds, 1),
        "conditions": [float(r["condition_value"]) for r in rows],
        "scores": [float(r["score"]) for r in rows],
        "feasible": [r["feasible"] == "True" for r in rows],
    }


def measure() -> dict[str, Any]:
    """Train and score every (algo, seed), two runs at a time."""
    tasks = [
        (algo, steps, seed, hp) for hp in HYPERPARAMETERS for algo, steps in ALGOS for seed in SEEDS
    ]
    return {"env_id": ENV_ID, "envelope": ENVELOPE, "runs": score_runs("rl-baselines", tasks)}


def score_runs(name: str, tasks: list[tuple[str, int, int, str]]) -> list[Any]:
    """:func:`score_run` of each (algo, steps, seed, variant), two at a time; the figure is
    redrawn with them as measurement ``name``'s runs."""
    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as tmp:
        with ThreadPoolExecutor(max_workers=2) as pool:
            runs = list(pool.map(lambda t: score_run(*t, Path(tmp)), tasks))
    write_figure(framework.ROOT / FIGURE, {name: runs})
    return runs


def summary(runs: list[dict[str, Any]]) -> tuple[float, float, float, float]:
    """Median and worst score over every (seed, condition), the share feasible, the median
    training time [s]."""
    scores = [s for r in runs for s in r["scores"]]
    feasible = [f for r in runs for f in r["feasible"]]
    seconds = statistics.median(r["train_s"] for r in runs)
    return statistics.median(scores), min(scores), sum(feasible) / len(feasible), seconds


def runs_of(runs: list[dict[str, Any]], algo: str, hyperparams: str = "") -> list[dict[str, Any]]:
    """The runs of ``algo`` trained with ``hyperparams`` ("" for the amortised policy)."""
    return [r for r in runs if r["algo"] == algo and r.get("hyperparams", "") == hyperparams]


def score_text(value: float) -> str:
    """A score as the tables write it (one decimal)."""
    # + 0.0: a median that rounds to -0.0 (an infeasible stroke's) reads as 0.0
    return f"{round(value, 1) + 0.0:.1f}"


def score_table(training: str, rows: list[tuple[str, str, list[dict[str, Any]]]]) -> str:
    """The scores table: a row per (policy, its ``training`` column, its runs)."""
    scores = ("seeds", "median score", "worst score", "strokes that fly")
    lines = table_head(["policy", training, *scores, "training time (median, 1 core)"])
    for policy, trained, runs in rows:
        median, worst, flies, seconds = summary(runs)
        cells = (len(runs), score_text(median), score_text(worst), f"{100 * flies:.0f} %")
        lines.append(table_row([policy, trained, *cells, f"{seconds:.0f} s"]))
    return "\n".join(lines)


def render(data: dict[str, Any]) -> str:
    rows = [
        (f"{algo.upper()}, {hp} hyperparameters", f"{runs[0]['steps']:,}", runs)
        for algo, _ in ALGOS
        for hp in HYPERPARAMETERS
        if (runs := runs_of(data["runs"], algo, hp))
    ]
    held = ", ".join(f"{c:g}" for c in data["runs"][0]["conditions"])
    return (
        score_table("training steps", rows)
        + f"\n\nScores at the held-out speeds V = {held} m/s (one stroke per policy and speed; "
        "100 = the reference optimum, ≤ 0 = does not fly), over every seed and speed; "
        f"`{shlex.join(train_command('ALGO', 'STEPS', 'SEED', 'shipped'))}` with the steps above "
        f"and seeds {list(SEEDS)} (tuned: `--conf-file "
        f"{HYPERPARAMETERS['tuned'].format(algo='ALGO')}` added), then `python -m train.envelope --conditions ...`. "
        f"{framework.machine_line(data, 'rl-baselines')}\n"
    )


def write_figure(path: Path, fresh: dict[str, list[dict[str, Any]]]) -> None:
    """Score against speed per policy of :data:`POLICIES`: each seed thin, the median thick (the
    shipped hyperparameters' median only, dashed); ``fresh``: runs just measured, by name."""
    colours = dict(zip(dict.fromkeys(algo for _, algo, _ in POLICIES), PALETTE, strict=False))
    measured = {
        name: framework.load(name)["runs"]
        for name in dict.fromkeys(name for name, _, _ in POLICIES)
        if framework.json_path(name).is_file()
    } | fresh
    fig, ax = plt.subplots(figsize=(6.0, 4.8))
    for name, algo, hp in POLICIES:
        runs = runs_of(measured.get(name, []), algo, hp)
        if not runs:
            continue
        shipped = hp == "shipped"  # the reference for what tuning bought: its median only
        if not shipped:
            for r in runs:
                ax.plot(r["conditions"], r["scores"], color=colours[algo], alpha=0.3, lw=0.8)
        medians = [statistics.median(col) for col in zip(*(r["scores"] for r in runs), strict=True)]
        label = f"{algo.upper()}, {hp} hyperparameters" if hp else "amortised policy"
        label += f" (median of {len(runs)} seeds{'' if shipped else '; thin: each'})"
        style = {"lw": 1.4, "ls": "--", "ms": 3} if shipped else {"lw": 2.2, "ls": "-", "ms": 5}
        conditions = runs[0]["conditions"]
        ax.plot(conditions, medians, color=colours[algo], marker="o", label=label, **style)
    ax.axhline(100.0, color="0.3", ls="--", lw=1.0, label="reference optimum (100)")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("flight speed V [m/s] (held-out conditions)")
    ax.set_ylabel("normalised score [-]")
    ax.set_title("Level flight: envelope policies against the reference optima")
    ax.grid(alpha=0.3)
    # below the axes: inside, it would hide the low scores
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)
    save(fig, path)  # atomically, its folder made if need be


def measure_amortised() -> dict[str, Any]:
    """Train and score every seed of the amortised policy, two runs at a time."""
    tasks = [(AMORTISED, 0, seed, "") for seed in SEEDS]
    return {"env_id": ENV_ID, "runs": score_runs("amortised-scores", tasks)}


def render_amortised(data: dict[str, Any]) -> str:
    return (
        score_table("training", [(AMORTISED, "regression + 600 gradient steps", data["runs"])])
        + "\n\nThe same held-out speeds and scoring; "
        f"`{shlex.join(train_command(AMORTISED, 0, 'SEED', ''))}` with seeds {list(SEEDS)}, then "
        "`python -m train.envelope --conditions ...`. "
        f"{framework.machine_line(data, 'amortised-scores')}\n"
    )


def measure_headline() -> dict[str, Any]:
    """Every policy of :data:`POLICIES` summarised from the stored runs."""
    stored = {name: framework.load(name) for name in dict.fromkeys(p[0] for p in POLICIES)}
    rows = []
    for name, algo, hp in POLICIES:
        runs = runs_of(stored[name]["runs"], algo, hp)
        numbers = dict(zip(("median", "worst", "flies"), summary(runs), strict=False))
        rows.append({"algo": algo, "hyperparams": hp, "seeds": len(runs), **numbers})
    measured = {n: d["machine_before"]["date"] for n, d in stored.items()}
    return {"policies": rows, "measured": measured}


def render_headline(data: dict[str, Any]) -> str:
    def rl(hp: str) -> str:
        rows = [r for r in data["policies"] if r["hyperparams"] == hp]
        fly = lambda r: f"{100 * r['flies']:.0f} % fly"  # noqa: E731
        return ", ".join(f"{r['algo'].upper()} {score_text(r['median'])} ({fly(r)})" for r in rows)

    (amortised,) = [r for r in data["policies"] if r["algo"] == AMORTISED]
    return (
        f"At level flight's held-out speeds the amortised policy's strokes score a median of "
        f"**{score_text(amortised['median'])}** (worst {score_text(amortised['worst'])}, "
        f"{100 * amortised['flies']:.0f} % fly; 100 = the reference optimum, ≤ 0 = does not "
        f"fly); envelope policies of PPO and SAC with hyperparameters tuned for the envelope "
        f"score {rl('tuned')}, with the shipped ones {rl('shipped')}; "
        f'{amortised["seeds"]} seeds each (docs/training.md, "Scores at the held-out '
        'conditions"; regenerate with `python -m eval numbers --only envelope-headline` after '
        "`rl-baselines` and `amortised-scores`).\n"
    )


MEASUREMENTS = (
    framework.Measurement("rl-baselines", measure, render, on_request=True),
    framework.Measurement("amortised-scores", measure_amortised, render_amortised, on_request=True),
    framework.Measurement("envelope-headline", measure_headline, render_headline, on_request=True),
)
