"""The README's headline of the envelope policies' scores (README, "One network for the whole
envelope"): each policy's median and worst score at level flight's held-out speeds and the share
of its strokes that fly, over every seed, collected from the stored runs of ``rl-baselines`` and
``amortised-scores`` (docs/training.md, "Scores at the held-out conditions"; measure those
first). On request only (``--only envelope-headline``): it reads, it does not train."""

from __future__ import annotations

from typing import Any

from eval.numbers.framework import Measurement, load
from eval.numbers.rl_baselines import POLICIES, runs_of, score_text, summary


def measure() -> dict[str, Any]:
    stored = {name: load(name) for name in dict.fromkeys(p[0] for p in POLICIES)}
    rows = []
    for name, algo, hp in POLICIES:
        runs = runs_of(stored[name]["runs"], algo, hp)
        median, worst, flies, _ = summary(runs)
        rows.append({"algo": algo, "hyperparams": hp, "seeds": len(runs), "median": median,
                     "worst": worst, "flies": flies})  # fmt: skip
    dates = {name: data["machine_before"]["date"] for name, data in stored.items()}
    return {"policies": rows, "measured": dates}


def render(data: dict[str, Any]) -> str:
    def rl(hp: str) -> str:
        rows = [r for r in data["policies"] if r["hyperparams"] == hp]
        return ", ".join(
            f"{r['algo'].upper()} {score_text(r['median'])} ({100 * r['flies']:.0f} % fly)"
            for r in rows
        )

    (amortised,) = [r for r in data["policies"] if r["algo"] == "amortised"]
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


MEASUREMENT = Measurement("envelope-headline", measure, render, on_request=True)
