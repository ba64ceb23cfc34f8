"""Estimate what the readings study costs at another preset, from a measured run's records.

    python -m eval.studies.readings.timing [--measured results/readings] [--preset paper]

Per reading and task, the median seconds per model evaluation of the records a finished run's
studies analysed (``DIR/readings_manifest.json``, the studies' indexes) times each budget of
``--preset``'s jobs under the same readings, run in full (shared jobs once): the job-seconds
per reading, the serial total and the best wall time on W workers
(:func:`eval.studies.bench_workers.makespan`). An estimate: the rates carry the measured run's
machine and load."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from agents.jobs import Job
from agents.records import Record
from agents.store import RECORDS_DIR, read_record_files
from eval.studies import PAPER_STUDIES
from eval.studies.base import INDEX_FILE, StudyPlan
from eval.studies.bench_workers import makespan, seconds_per_evaluation
from eval.studies.paper_reading import Reading
from eval.studies.presets import STUDY_PRESETS, TINY, get_preset
from eval.studies.readings import MANIFEST, reading_jobs
from tandem_env.io.files import read_json

WORKERS: tuple[int, ...] = (1, 2, 8, 32)


def analysed_records(out_dir: Path, reading: Reading) -> dict[Job, Record]:
    """The records that ``reading``'s studies analysed in the readings run ``out_dir``."""
    indexes = (read_json(out_dir / reading.name / name / INDEX_FILE) for name in PAPER_STUDIES)
    keys = dict.fromkeys(entry["key"] for index in indexes for entry in index)
    paths = [out_dir / RECORDS_DIR / f"{key}.json" for key in keys]
    return {record.job: record for record in read_record_files(paths)}


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--measured", default="results/readings", metavar="DIR")
    parser.add_argument("--preset", choices=tuple(STUDY_PRESETS), default="paper")
    args = parser.parse_args(argv)
    manifest = read_json(Path(args.measured) / MANIFEST)
    measured = {**STUDY_PRESETS, TINY.name: TINY}[manifest["preset"]]
    target = StudyPlan(get_preset(args.preset), tuple(manifest["methods"]))
    seen: set[str] = set()
    durations: list[tuple[int, float]] = []
    print(f"measured: {args.measured} ({measured.name}); estimated: {args.preset}")
    for entry in manifest["readings"]:  # each reading rebuilt from its changes
        reading = Reading.from_changes(entry["name"], "as measured", entry["changes"])
        records = analysed_records(Path(args.measured), reading)
        per_eval = seconds_per_evaluation(records)
        spent = sum(r.wall_time for r in records.values())
        new = {j.key: j for j in reading_jobs(target, reading) if j.key not in seen}
        seen.update(new)
        estimate = [(j.budget, per_eval[j.task] * j.budget) for j in new.values()]
        durations += estimate
        rates = ", ".join(f"{t} {1e3 * v:.2f} ms/eval" for t, v in per_eval.items())
        print(
            f"{reading.name:>28}: measured {spent / 60:6.1f} min of jobs ({rates}); "
            f"{args.preset}: {len(new)} new jobs, {sum(d for _, d in estimate) / 60:6.1f} min"
        )
    ordered = [d for _, d in sorted(durations, key=lambda x: -x[0])]
    cells = ", ".join(f"{w} workers {makespan(ordered, w) / 3600:.1f} h" for w in WORKERS)
    total = f"{len(ordered)} jobs, {sum(ordered) / 3600:.1f} h serial"
    print(f"{args.preset}: {total}; at best {cells}")


if __name__ == "__main__":
    main()
