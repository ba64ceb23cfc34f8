"""``python -m eval crosscheck``: the tandem interaction against a free-wake vortex-lattice solver
(what it runs and refuses: :data:`DESCRIPTION`, docs/crosscheck.md)."""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from agents.store import RECORDS_DIR
from eval.optimize import add_run_arguments, run_options
from tandem_env.io.files import FolderLock, output_directory
from tandem_env.physics import DRAGONFLY, PLANFORMS, SPEED_LIMITS, Dragonfly

from .case import (
    MIN_CLEARANCE,
    PAIRS,
    WAKES,
    Case,
    Resolution,
    base_stroke,
    case_runs,
    check_family,
    check_geometry,
    parse_panels,
)
from .uvlm import INSTALL

NAME = "crosscheck"
HELP = (
    "the fore/hind interaction against a free-wake vortex-lattice solver (Ptera Software; "
    f"{INSTALL})"
)
DEFAULT_OUT = Path("results") / "crosscheck"


@dataclass(frozen=True)
class Point:
    """One case of a grid: the base stroke's changes (Table 4 names and units), the speed
    [m/s], the root spacing [fore-wing mean chords] and drop [mm] (None: the insect's) and the
    lags [deg]."""

    changes: tuple[tuple[str, float], ...] = ()
    speed: float = 1.0
    chords: float | None = None
    drop: float | None = None
    lags: tuple[float, ...] = (90.0,)

    def case(self, insect: Dragonfly, stroke: dict[str, float], lags: tuple | None) -> Case:
        """This point of ``insect`` with the ``stroke`` changes (``--stroke``) on top of its own,
        at ``lags`` if given; ValueError for a stroke outside the family."""
        spacing = (
            insect.root_spacing if self.chords is None else self.chords * insect.fore.mean_chord
        )
        drop = insect.root_drop if self.drop is None else self.drop * 1e-3
        changed = check_family(base_stroke(**(dict(self.changes) | stroke)))
        return Case(tuple(changed), self.speed, spacing, drop, lags or self.lags)


@dataclass(frozen=True)
class Grid:
    """A named set of cases (``--grid``) and the resolution they run at."""

    description: str
    points: tuple[Point, ...]
    resolution: Resolution = field(default_factory=Resolution)


def _both(**changes: float) -> tuple[tuple[str, float], ...]:
    return tuple((f"{pair}_{name}", value) for name, value in changes.items() for pair in PAIRS)


#: The lag study's lags [deg]: 0 to 315 in steps of 45.
STUDY_LAGS = tuple(float(a) for a in range(0, 360, 45))
#: The generalisation grid: the lag study's family away from its one stroke, one or two lags
#: each (docs/crosscheck.md, "Generalisation"). A change of one pair's stroke shares the other
#: pair's run alone with the base case's; the solver has no elevation, so the two elevation
#: offsets share their runs with the base case at lag 90 deg.
GENERALISATION = (
    Point(chords=2.5),
    Point(drop=6.5, lags=(0.0,)),
    Point(drop=14.0, lags=(0.0, 180.0)),
    Point((("hind_elevation_offset", 5.0),)),
    Point((("hind_elevation_offset", -5.0),)),
    Point((("hind_sweep_amplitude", 45.0),)),
    Point((("hind_pitch_amplitude", 35.0),), lags=(0.0,)),
    Point((("hind_pitch_phase", 75.0),), lags=(180.0,)),
    Point((("fore_sweep_amplitude", 30.0),)),
    Point((("fore_pitch_amplitude", 65.0),), lags=(0.0,)),
    Point(_both(stroke_plane_angle=25.0)),
    Point(_both(frequency=30.0), lags=(180.0,)),
    Point(_both(pitch_phase=105.0), speed=0.5, lags=(0.0,)),
    Point(_both(sweep_amplitude=45.0), speed=2.0, lags=(180.0,)),
    Point(_both(stroke_plane_angle=10.0), speed=1.5, drop=12.0),
)
GRIDS: dict[str, Grid] = {
    "single": Grid(
        "one case: V = 1 m/s at the dragonfly's root spacing and drop, lags 0, 90, 180 deg",
        (Point(lags=(0.0, 90.0, 180.0)),),  # the exploratory runs
    ),
    "lag-study": Grid(
        "lags 0-315 deg in 45 deg steps at V = 0.5, 1, 2 m/s at the dragonfly's spacing, and "
        "at 2 fore-wing chords at V = 1 m/s",
        (
            *(Point(speed=v, lags=STUDY_LAGS) for v in (0.5, 1.0, 2.0)),
            Point(chords=2.0, lags=STUDY_LAGS),
        ),
    ),
    "generalisation": Grid(
        f"{len(GENERALISATION)} other strokes, speeds, spacings and drops of the family, one or "
        "two lags each (docs/crosscheck.md)",
        GENERALISATION,
    ),
    "tiny": Grid(
        "a coarse smoke test (under a minute): V = 1 m/s, lag 90 deg, 8 steps per beat, 2x5 "
        "panels, 2 beats",
        (Point(),),
        Resolution(steps_per_beat=8, chordwise=2, spanwise=5, beats=2),
    ),
}

DESCRIPTION = (
    f"""\
Cross-check the model's fore/hind interaction against Ptera Software's free-wake unsteady
vortex-lattice solver (the uvlm extra: {INSTALL}, Python >= 3.11;
docs/crosscheck.md). Per case it runs the fore pair alone, the hind pair alone and the tandem
at each lag, and compares each pair's cycle-mean vertical force change due to the other pair:
UVLM tandem - alone, and the model's each slipstream reading - isolated. Strokes: the base
case (Table 1 wings, f = 37 Hz, sweep +-35 deg, pitch +-50 deg leading by 90 deg, beta = 15
deg) with --stroke changes. Refused before any work (exit status 2): strokes outside the
family the mapping supports, wings within {1e3 * MIN_CLEARANCE:g} mm of each other at any lag,
and a missing extra.

Grids (--grid):
"""
    + "\n".join(f"  {name:14s} {grid.description}" for name, grid in GRIDS.items())
    + """

Writes into --out: records/<key>.json (one record per solver run, reused on a rerun and
from the record cache; those of an older runs/ folder are moved there once),
crosscheck.csv and crosscheck.md (the table) and crosscheck.png (the figure)."""
)

EPILOG = """\
examples:
  python -m eval crosscheck --grid tiny --out results/crosscheck-tiny
  python -m eval crosscheck --steps-per-beat 48 --panels 4x8 --out results/crosscheck
  python -m eval crosscheck --convergence --lags 0 --out results/crosscheck
  python -m eval crosscheck --wake prescribed --out results/crosscheck
  python -m eval crosscheck --grid lag-study --scheduler local:2 --out results/crosscheck"""


#: The command's options (argparse keywords); ``--scheduler``, ``--no-cache`` and ``--rerun``
#: besides (:data:`RUN_OPTIONS <eval.optimize.RUN_OPTIONS>`).
OPTIONS: dict[str, dict[str, Any]] = {
    "--grid": {"choices": list(GRIDS), "default": "single", "help": "the cases (above)"},
    "--lags": {
        "type": float,
        "nargs": "+",
        "metavar": "DEG",
        "help": "hind-wing phase shifts [deg], -360 to 360 (default: the grid's)",
    },
    "--speed": {"type": float, "metavar": "V", "help": "flight speed [m/s] (--grid single)"},
    "--spacing": {
        "type": float,
        "metavar": "MM",
        "help": "fore root to hind root along the body, + aft [mm] (--grid single; default the "
        "insect's Dragonfly.root_spacing)",
    },
    "--drop": {
        "type": float,
        "metavar": "MM",
        "help": "hind root below the fore root [mm] (--grid single; default Dragonfly.root_drop)",
    },
    "--stroke": {
        "nargs": "+",
        "default": [],
        "metavar": "NAME=VALUE",
        "help": "change base-case stroke parameters, e.g. fore_sweep_amplitude=40 (Table 4 units)",
    },
    "--planform": {"choices": PLANFORMS, "default": "tear-drop", "help": "both wings' planform"},
    "--steps-per-beat": dict(type=int, metavar="N", help="solver time steps per beat (default 48)"),
    "--panels": {"metavar": "CxS", "help": "chordwise x spanwise panels per wing (default 4x8)"},
    "--beats": {"type": int, "metavar": "N", "help": "beats run; loads from the last (default 3)"},
    "--wake": {
        "choices": WAKES,
        "default": WAKES[0],
        "help": "the solver's wake: free (moved by the local flow) or prescribed (carried by the "
        "free stream alone, about 5-10x cheaper); default free",
    },
    "--convergence": {
        "action": "store_true",
        "help": "also run the first case at 2/3 and 4/3 of the time steps and at 1.5x2 the panels",
    },
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    for flag, keywords in OPTIONS.items():
        parser.add_argument(flag, **keywords)
    add_run_arguments(parser, "--scheduler", "--no-cache", "--rerun", "--quiet")
    parser.add_argument("--out", default=str(DEFAULT_OUT), help=f"output folder ({DEFAULT_OUT})")


def plan(args: argparse.Namespace) -> tuple[Dragonfly, list[Case], list[Resolution]]:
    """The insect, the cases and the resolutions (the base one first; only the first case runs
    at the others); ValueError naming the first bad value."""
    grid = GRIDS[args.grid]
    # --speed [m/s], --spacing and --drop [mm] given, in the Case's units [m/s, m]
    where = {
        name: value if name == "speed" else 1e-3 * value
        for name in ("speed", "spacing", "drop")
        if (value := getattr(args, name)) is not None
    }
    if where and args.grid != "single":
        raise ValueError(
            f"{' and '.join(f'--{n}' for n in where)} apply to --grid single; --grid {args.grid} "
            "sets its own"
        )
    if bad := [a for a in args.lags or () if not -360.0 <= a <= 360.0]:
        raise ValueError(f"--lags {bad[0]:g}; allowed: -360 to 360 deg")
    given = {"steps_per_beat": args.steps_per_beat, "beats": args.beats}
    given |= {} if args.panels is None else parse_panels(args.panels)
    resolution = replace(grid.resolution, **{k: v for k, v in given.items() if v is not None})
    insect = DRAGONFLY.with_planform(args.planform)  # type: ignore[arg-type]
    stroke: dict[str, float] = {}  # the --stroke NAME=VALUE changes
    for item in args.stroke:
        name, sep, value = item.partition("=")
        try:
            stroke[name.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep:
            msg = f"--stroke {item!r}; allowed: NAME=NUMBER, e.g. fore_sweep_amplitude=40"
            raise ValueError(msg)
    lags = None if args.lags is None else tuple(dict.fromkeys(float(a) for a in args.lags))
    cases = [point.case(insect, stroke, lags) for point in grid.points]
    if where:
        case = replace(cases[0], **where)
        if not SPEED_LIMITS[0] < case.speed <= SPEED_LIMITS[1]:
            raise ValueError(
                f"--speed {case.speed:g}; allowed: above {SPEED_LIMITS[0]:g} (the solver needs a "
                f"free stream) to {SPEED_LIMITS[1]:g} m/s"
            )
        if not 0.0 <= case.spacing <= 0.1 or not -0.1 <= case.drop <= 0.1:
            raise ValueError(
                f"--spacing {1e3 * case.spacing:g} mm, --drop {1e3 * case.drop:g} mm; allowed: "
                "spacing 0 to 100 mm, drop -100 to 100 mm"
            )
        cases = [case]
    resolutions = list(resolution.refined()) if args.convergence else [resolution]
    return insect, cases, resolutions


def locked(out_dir: Path) -> FolderLock:
    """The lock of ``OUT/.crosscheck.lock`` (made if absent), held while a command writes there;
    :class:`~tandem_env.io.files.FolderInUse` naming the folder if another process holds it."""
    out_dir.mkdir(parents=True, exist_ok=True)
    return FolderLock(
        out_dir,
        ".crosscheck.lock",
        lambda pid: (
            f"--out {str(out_dir)!r}: another cross-check (pid {pid}) is writing there; "
            "allowed: one command per folder at a time (wait for it, or give another --out)"
        ),
    )


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from agents.dask_cluster import SchedulerUnreachable
    from agents.runner import JobsFailed, run_jobs

    from . import report
    from .uvlm import MISSING_EXTRA, SolverJob, solver_version

    try:
        insect, cases, resolutions = plan(args)
        output_directory(args.out)  # the text given: Path('') would be the current folder
        args.out = Path(args.out)
        clearance = {case: check_geometry(case, insect) for case in cases}
    except ValueError as error:
        parser.error(str(error))
    if (version := solver_version()) is None:
        print(f"{parser.prog}: error: {MISSING_EXTRA}", file=sys.stderr)
        return 2
    start = time.perf_counter()
    planned = [
        report.Planned(case, each, case_runs(case, insect, each, args.wake), clearance[case])
        for index, case in enumerate(cases)
        for each in (resolutions if index == 0 else resolutions[:1])
    ]
    try:
        with locked(args.out):
            # the records of OUT/runs (kept there before the runner ran the solver's runs: the
            # same files) move into the store's OUT/records once; one already there is kept
            for path in (args.out / "runs").glob("*.json"):
                (args.out / RECORDS_DIR).mkdir(exist_ok=True)
                if not (args.out / RECORDS_DIR / path.name).exists():
                    path.replace(args.out / RECORDS_DIR / path.name)
            jobs = [SolverJob(run, version) for p in planned for run in p.runs.values()]
            summary = run_jobs(jobs, args.out, **run_options(args))
            if not args.quiet:
                print(f"{summary.total} solver runs: {summary.describe(args.out)}", file=sys.stderr)
            results = {job.run: summary.records[job.key].result for job in jobs}
            table = report.rows(planned, results, insect)
            csv_path, md_path = report.write_table(args.out, table)
            if args.grid == "generalisation":
                figure = report.write_scatter(args.out, table)
            else:
                figure = report.write_figure(args.out, table, resolutions[0])
    except ValueError as error:
        parser.error(str(error))
    except (JobsFailed, SchedulerUnreachable) as error:
        print(f"{parser.prog}: {error}", file=sys.stderr)
        return 1
    print(report.markdown(table) + "\n" + report.agreement(table), end="")
    print(f"wrote {csv_path}, {md_path}, {figure} ({time.perf_counter() - start:.0f} s)")
    return 0
