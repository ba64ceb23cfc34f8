"""One vortex-lattice run (free or prescribed wake) of a wing pair or the tandem, with Ptera
Software, as a job of the runner (:class:`SolverJob`, :func:`agents.runner.run_jobs`).

Ptera Software (the ``uvlm`` extra, ``pip install -e ".[uvlm]"``) is imported here only, when a
run starts; :func:`solver_version` says whether it is installed. The mapping of the project's
stroke onto its wings and movements is docs/crosscheck.md's ("The mapping"): each pair is its
own Airplane, so the solver reports each pair's loads apart.
"""

from __future__ import annotations

import hashlib
import json
import time
import warnings
from dataclasses import asdict, dataclass
from importlib import metadata
from typing import Any, ClassVar

import numpy as np

from agents.records import RecordChecksumError, RecordError

from .case import RUN_FORMAT, STATIONS, Run, WingMotion, earth_axes, hind_position

#: The extra's distribution, the command that installs it and what a command without it says.
DISTRIBUTION = "pterasoftware"
INSTALL = 'pip install -e ".[uvlm]"'
MISSING_EXTRA = (
    f"the cross-check needs Ptera Software ({DISTRIBUTION}), which is not installed: "
    f"{INSTALL} (Python >= 3.11)"
)
#: The aerofoil of every section: symmetric, so the panels' mean surface is the flat plate of
#: the blade-element model.
AIRFOIL = "naca0012"


def solver_version() -> str | None:
    """The installed Ptera Software version, or None when the extra is not installed."""
    try:
        return metadata.version(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        return None


def _pair(ps: Any, motion: WingMotion, name: str, run: Run, origin: np.ndarray) -> tuple[Any, Any]:
    """One wing pair as an Airplane and its AirplaneMovement."""
    section = ps.geometry.wing_cross_section.WingCrossSection
    panels = run.resolution.segment_panels()
    chords = motion.chords
    sections = []
    for i, (station, chord) in enumerate(zip(STATIONS, chords, strict=True)):
        last = i == len(STATIONS) - 1
        # Leading points offset by half the change of chord: a straight mid-chord line, the
        # blade-element model's pitch axis (docs/model.md §2.4).
        offset = (0.0, 0.0, 0.0)
        if i:
            span = (station - STATIONS[i - 1]) * motion.length
            offset = (-(chord - chords[i - 1]) / 2, span, 0.0)
        sections.append(
            section(
                airfoil=ps.geometry.airfoil.Airfoil(AIRFOIL),
                num_spanwise_panels=None if last else panels[i],
                chord=chord,
                Lp_Wcsp_Lpp=offset,
                control_surface_symmetry_type="symmetric",
                spanwise_spacing=None if last else "uniform",
            )
        )
    wing = ps.geometry.wing.Wing(
        wing_cross_sections=sections,
        name=name,
        Ler_Gs_Cgs=(-chords[0] / 2, run.root_offset, 0.0),
        angles_Gs_to_Wn_ixyz=(motion.sweep[1], motion.pitch[1], 0.0),
        symmetric=True,
        symmetryNormal_G=(0.0, 1.0, 0.0),
        symmetryPoint_G_Cg=(0.0, 0.0, 0.0),
        num_chordwise_panels=run.resolution.chordwise,
        chordwise_spacing="uniform",
    )
    airplane = ps.geometry.airplane.Airplane(wings=[wing], name=name, Cg_GP1_CgP1=tuple(origin))
    period = 1.0 / motion.frequency
    section_movement = ps.movements.wing_cross_section_movement.WingCrossSectionMovement
    # The root lies off the mid-plane, so the solver splits the wing into a right and a left
    # one; the same parameters on each give mirrored motion.
    movements = [
        ps.movements.wing_movement.WingMovement(
            base_wing=each,
            wing_cross_section_movements=[
                section_movement(base_wing_cross_section=s) for s in each.wing_cross_sections
            ],
            ampAngles_Gs_to_Wn_ixyz=(motion.sweep[0], motion.pitch[0], 0.0),
            periodAngles_Gs_to_Wn_ixyz=(period, period, 0.0),
            spacingAngles_Gs_to_Wn_ixyz=("sine", "sine", "sine"),
            phaseAngles_Gs_to_Wn_ixyz=(motion.sweep[2], motion.pitch[2], 0.0),
            # The wing pitches and sweeps about its root's mid-chord.
            rotationPointOffset_Gs_Ler=(chords[0] / 2, 0.0, 0.0),
        )
        for each in airplane.wings
    ]
    movement = ps.movements.airplane_movement.AirplaneMovement
    return airplane, movement(base_airplane=airplane, wing_movements=movements)


def build(run: Run) -> tuple[Any, Any, list[str]]:
    """The solver's problem of ``run``, its operating point and the names of its Airplanes (the
    pairs, fore first)."""
    import pterasoftware as ps

    # The first Airplane's origin is the problem's origin: the hind pair alone sits there.
    behind = hind_position(run.spacing, run.drop, run.stroke_plane_angle)
    hind_origin = np.zeros(3) if run.fore is None else behind
    candidates = (("fore", run.fore, np.zeros(3)), ("hind", run.hind, hind_origin))
    pairs = [(name, motion, origin) for name, motion, origin in candidates if motion is not None]
    built = [_pair(ps, motion, name, run, origin) for name, motion, origin in pairs]
    operating_point = ps.operating_point.OperatingPoint(
        rho=run.air_density, vCg__E=run.speed, alpha=run.stroke_plane_angle - 90.0, beta=0.0
    )
    period = 1.0 / pairs[0][1].frequency
    movement = ps.movements.movement.Movement(
        airplane_movements=[m for _, m in built],
        operating_point_movement=ps.movements.operating_point_movement.OperatingPointMovement(
            base_operating_point=operating_point
        ),
        delta_time=period / run.resolution.steps_per_beat,
        num_cycles=run.resolution.beats,
    )
    problem = ps.problems.UnsteadyProblem(movement=movement, only_final_results=True)
    return problem, operating_point, [name for name, _, _ in pairs]


def solve(run: Run) -> dict[str, Any]:
    """Run the solver on ``run``; each present pair's cycle-mean forces [N] in the project's
    earth axes (``vertical``, ``forward``, ``lateral``), the vertical and forward force at each
    step of the last beat [N], and the wall time [s]."""
    import pterasoftware as ps

    start = time.perf_counter()
    forward, up = earth_axes(run.stroke_plane_angle)
    problem, operating_point, names = build(run)
    solver = ps.unsteady_ring_vortex_lattice_method.UnsteadyRingVortexLatticeMethodSolver(problem)
    with warnings.catch_warnings():
        # The project runs numba on its work-queue threading layer on purpose
        # (tandem_env/physics/__init__.py); the solver's advice to change it is not for here.
        warnings.filterwarnings("ignore", message=".*workqueue threading layer.*")
        prescribed = run.wake == "prescribed"
        solver.run(prescribed_wake=prescribed, calculate_streamlines=False, show_progress=False)
    to_geometry = np.asarray(operating_point.T_pas_W_CgP1_to_GP1_CgP1)[:3, :3]
    axes = {"vertical": up, "forward": forward, "lateral": np.array([0.0, 1.0, 0.0])}
    out: dict[str, Any] = {}
    for index, name in enumerate(names):
        mean = to_geometry @ np.asarray(problem.finalMeanForces_W[index], dtype=float)
        last_beat = problem.steady_problems[problem.first_averaging_step :]
        history = np.array(
            [to_geometry @ np.asarray(s.airplanes[index].forces_W, dtype=float) for s in last_beat]
        )
        out[name] = {key: float(mean @ axis) for key, axis in axes.items()}
        out[name] |= {f"{k}_history": (history @ axes[k]).tolist() for k in ("vertical", "forward")}
    out["steps"] = int(problem.num_steps)
    out["wall_time"] = time.perf_counter() - start
    return out


def _checksum(body: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest()


@dataclass(frozen=True)
class SolverRecord:
    """A solver run's record: its job and its result (:func:`solve`), in the file format the
    cross-check has always written (``format``, ``key``, ``solver``, ``run``, ``result`` and
    their checksum), so records stored before the runner took the runs are read as they are."""

    job: SolverJob
    result: dict[str, Any]

    @property
    def key(self) -> str:
        return self.job.key

    def label(self) -> str:
        return self.job.label()

    def to_dict(self) -> dict[str, Any]:
        body = {"format": RUN_FORMAT, "key": self.key, **self.job.configuration()}
        # Through JSON first, so the checksum is of what a reader gets back.
        body = json.loads(json.dumps({**body, "result": self.result}))
        return {**body, "checksum": _checksum(body)}

    @classmethod
    def from_dict(cls, data: Any) -> SolverRecord:
        """Inverse of :meth:`to_dict`; :class:`~agents.records.RecordError` for anything else."""
        try:
            body = {k: data[k] for k in ("format", "key", "solver", "run", "result")}
            record = cls(SolverJob(Run.from_dict(body["run"]), body["solver"]), body["result"])
        except (KeyError, TypeError, ValueError, AttributeError) as error:
            msg = f"not a solver run's record ({type(error).__name__}: {error})"
            raise RecordError(msg) from None
        if data.get("checksum") != _checksum(body):
            raise RecordChecksumError("its checksum does not match its contents")
        if record.key != body["key"]:  # the key hashes the format too
            raise RecordError(f"key {body['key']!r} is not its run's in this format ({record.key})")
        return record


@dataclass(frozen=True)
class SolverJob:
    """One solver run as a job of the runner (:class:`agents.jobs.Work`): stored, cached and
    scheduled as the harness's jobs are, under the run's key (:meth:`Run.key
    <eval.crosscheck.case.Run.key>`)."""

    run: Run
    solver: str
    """Ptera Software's version (:func:`solver_version`), part of the key."""

    noun: ClassVar[str] = "solver run"
    record_type: ClassVar[type[SolverRecord]] = SolverRecord

    @property
    def key(self) -> str:
        return self.run.key(self.solver)

    @property
    def budget(self) -> int:
        """The solver's steps times the pairs flown: the tandem runs start first."""
        resolution = self.run.resolution
        pairs = (self.run.fore is not None) + (self.run.hind is not None)
        return resolution.steps_per_beat * resolution.beats * pairs

    def label(self) -> str:
        return self.run.label()

    def configuration(self) -> dict[str, Any]:
        return {"solver": self.solver, "run": asdict(self.run)}

    def compute(self) -> SolverRecord:
        return SolverRecord(self, solve(self.run))
