"""The readings study at the paper preset (docs/reproduction.md, "Readings"): its stored
outputs, collected after the long run."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from eval.numbers import framework
from eval.studies.readings import MANIFEST
from eval.studies.readings.plan import COUNTS, HEADLINES
from eval.studies.readings.report import check_table
from eval.studies.report import table_head
from tandem_env.io.files import read_json

READINGS_PAPER_OUT = Path("results") / "readings-paper"
READINGS_PAPER_COMMAND = (
    f"python -m eval study readings --preset paper --scheduler local:2 --out {READINGS_PAPER_OUT}"
)
#: The run's small outputs kept where the docs include them: run's file -> the docs' copy.
READINGS_PAPER_FILES: dict[str, Path] = {
    "readings.csv": framework.ROOT / "docs" / "readings" / "paper_readings.csv",
    "continuation_check.csv": framework.ROOT / "docs" / "readings" / "paper_continuation_check.csv",
    "readings_manifest.json": framework.ROOT / "docs" / "readings" / "paper_readings_manifest.json",
    "readings_matrix.png": framework.ROOT / "docs" / "figures" / "readings_paper_matrix.png",
}
#: The headline columns of the readings table: (title, readings.csv columns).
READINGS_COLUMNS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("η_max [%]", ("eta_max_pct",)),
    ("F̄_v 50 / 90", ("Fv_50", "Fv_90")),
    ("F̄_h 50 / 90", ("Fh_50", "Fh_90")),
    ("F̄_a 50 / 90", ("Fa_50", "Fa_90")),
)


def measure() -> dict[str, Any]:
    """Collect the finished paper-preset readings run in :data:`READINGS_PAPER_OUT` (it takes
    1-2 h on 2 cores: run :data:`READINGS_PAPER_COMMAND` first) and copy its small outputs
    into the docs (:data:`READINGS_PAPER_FILES`)."""
    out = READINGS_PAPER_OUT
    if not (out / MANIFEST).is_file():
        raise SystemExit(f"{out} holds no finished readings run; run `{READINGS_PAPER_COMMAND}`")
    manifest = read_json(out / MANIFEST)
    if manifest.get("preset") != "paper" or "invocations" not in manifest:
        raise SystemExit(
            f"{out / MANIFEST} is not a paper-preset readings run of this version (preset "
            f"{manifest.get('preset')!r}); run `{READINGS_PAPER_COMMAND}`"
        )
    framework.copy_outputs(out, READINGS_PAPER_FILES)
    keep = "claims combination_rule invocations continuation continuation_check run_in_full"
    return {
        "command": READINGS_PAPER_COMMAND,
        "rows": framework.read_rows(out / "readings.csv"),
        **{key: manifest[key] for key in keep.split()},
    }


def _invocation_line(invocation: dict[str, Any]) -> str:
    """One invocation of a readings run: when, where, and each phase's work and time."""
    where = ""
    if "cpus" in invocation:  # an older run's first invocation has none
        loads = " → ".join(str(x) for x in invocation["load_average_1min"])
        where = f", {invocation['cpus']} CPUs, load average (1 min) {loads}"
    phases = "; ".join(
        f"{p['name']} {p['jobs']} optimisations ({p['ran']} run, {p['reused']} reused) in "
        f"{framework.minutes(p['wall_time_s'], padded=True)}"
        for p in invocation["phases"]
    )
    finished = invocation["finished"] or "finished before invocations were recorded"
    return f"- {finished}{where}: {phases}; {framework.minutes(invocation['wall_time_s'], padded=True)} in all."


def render(data: dict[str, Any]) -> str:
    """The readings table (the paper's numbers first, the best count in bold), the run's
    phases, the combination rule and the continuation's bias check with what ran in full."""
    paper = {c["id"]: c["paper"] for c in data["claims"]}
    rows = data["rows"]
    worked = [inv for inv in data["invocations"] if any(p["ran"] for p in inv["phases"])]
    reused = [inv for inv in data["invocations"] if inv not in worked]
    best = max(int(r["agree"]) for r in rows)
    heads = [title for title, _ in READINGS_COLUMNS]
    papers = [" / ".join(paper.get(HEADLINES[c][0], "–") for c in cs) for _, cs in READINGS_COLUMNS]
    lines = [
        *table_head(["reading", "changes from the default", *COUNTS.values(), *heads]),
        "| paper | " + "| " * (1 + len(COUNTS)) + " | ".join(papers) + " |",
    ]
    for r in rows:
        mark = "**" if int(r["agree"]) == best else ""
        numbers = [" / ".join(f"{float(r[c]):.3g}" for c in cs) for _, cs in READINGS_COLUMNS]
        # an older run has no not_identifiable count
        counts = " | ".join(r.get(k, "–") for k in list(COUNTS)[1:])
        lines.append(
            f"| {mark}`{r['reading']}`{mark} | {r['changes']} | {mark}{r['agree']}{mark} | "
            f"{counts} | {' | '.join(numbers)} |"
        )
    counted = all("not_identifiable" in r for r in rows)
    lines += [
        "",
        f"{len(data['claims'])} claims; verdicts on the median over the seeds, undecided where "
        "the bootstrap over seeds leaves it open, not identifiable where the model does not "
        "depend on what the claim is about (docs/reproduction.md, *Agreement rules*)."
        + (
            ""
            if counted
            else " This run was analysed before the identifiability rule (– in its column): "
            "its agree, differ and undecided counts include verdicts on the fore/hind phase "
            "claims K1-K3, which the model does not depend on under any of its readings (all "
            "with the mean slipstream)."
        ),
        f"Combination rule: {data['combination_rule']}.",
        "",
        "The invocations into the run's folder that optimised (a job stored by an earlier "
        "invocation is reused):",
        "",
        *[_invocation_line(inv) for inv in worked],
        "",
        f"{len(reused)} more invocation(s) reused every job and only analysed and redrew "
        f"the outputs ({', '.join(framework.minutes(inv['wall_time_s'], padded=True) for inv in reused) or 'none'}).",
        "",
        "Bias check of the continuation (difference = (continued − full) / |full| of the "
        "reported objective, per job; a single reading's task that falls short ran in full):",
        "",
        *check_table(data["continuation_check"], data["run_in_full"]),
        "",
        "Collected from the run's own outputs by `python -m eval numbers --only readings-paper` "
        f"(after `{data['command']}`; its readings.csv, manifest, bias check and matrix are "
        "copied to docs/readings/ and docs/figures/).",
    ]
    return "\n".join(lines) + "\n"


MEASUREMENT = framework.Measurement("readings-paper", measure, render, on_request=True)
