"""The single flight environments: one wing-beat cycle per episode, over one shared base.

Both tasks are contextual bandits: the observation is the flight condition, the action a whole
stroke (28 normalised parameters), and ``step`` evaluates one wing-beat cycle and ends the
episode. All task logic lives in :mod:`tandem_env.envs.task`, shared with the vector env and
the SB3 adapter.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..physics import N_PARAMETERS
from ..physics.checks import real_array
from .config import AccelerateConfig, FlightConfig, LevelFlightConfig
from .task import FlightTask, StepBatch, make_task, row

RENDER_MODES: tuple[str, ...] = ("human", "rgb_array")
RENDER_FPS = 4


def action_space() -> spaces.Box:
    """Box(-1, 1, (28,), float32): the normalised stroke, fore-wing first (Table 4 order)."""
    return spaces.Box(-1.0, 1.0, (N_PARAMETERS,), dtype=np.float32)


def observation_space() -> spaces.Box:
    """Box(-1, 1, (1,), float32): the flight condition normalised over its envelope."""
    return spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)


def check_render_mode(render_mode: str | None) -> str | None:
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(
            f"render_mode = {render_mode!r}; allowed: None, {', '.join(map(repr, RENDER_MODES))}"
        )
    return render_mode


def build_config(
    config_class: type[FlightConfig], config: FlightConfig | None, kwargs: dict[str, Any]
) -> FlightConfig:
    """The env's config: ``config`` as given, or built from the ``gym.make`` kwargs."""
    if config is None:
        return config_class.from_kwargs(**kwargs)
    if kwargs:
        raise ValueError(
            f"give either config= or keyword options, not both; got config and {sorted(kwargs)}"
        )
    if not isinstance(config, config_class):
        raise ValueError(
            f"config = {config!r}; allowed: a {config_class.__name__} (or keyword options)"
        )
    return config


@dataclass
class LastStep:
    """What the picture of an env shows: its last evaluated stroke, or None."""

    batch: StepBatch
    index: int


def frame_for(task: FlightTask, title: str, condition: float | None, last: LastStep | None) -> Any:
    """The render frame of one env (imports matplotlib lazily)."""
    from .render import Frame, history_of, metrics_line

    cfg = task.config
    if last is not None:
        # The condition the stroke was evaluated in (a same-step autoreset may have moved on).
        speed = float(last.batch.result.speed[last.index])
        power = float(last.batch.result.available_power[last.index])
    elif condition is not None:
        speed, power = (float(v[0]) for v in task.flight_conditions(np.array([condition])))
    else:
        return Frame(title=f"{title}  {cfg.describe()}", subtitle="not reset yet", history=None)
    heading = f"{title}  V = {speed:.3g} m/s, P_avail = {power:.3g} W/kg"
    if last is None:
        return Frame(title=heading, subtitle="no stroke evaluated since reset", history=None)
    info = row(
        {k: v for k, v in last.batch.info_columns().items() if not isinstance(v, dict)}, last.index
    )
    label = "η" if isinstance(cfg, LevelFlightConfig) else f"F̄ ({cfg.objective})"
    return Frame(
        title=heading,
        subtitle=metrics_line(float(last.batch.reward[last.index]), info, label),
        history=history_of(last.batch.physical[last.index], speed, power, cfg.insect, cfg.options),
    )


class RenderWindow:
    """The human-mode window of an env (single or vector): opened at its first render, closed by
    ``close``, never pickled (a pyplot window cannot be; a copy opens its own at its next render).
    Matplotlib is imported only when something is rendered."""

    _window: Any = None

    def _show(self, frame: Any) -> np.ndarray | None:
        """``frame`` as an RGB array (``render_mode="rgb_array"``) or in the window (``"human"``)."""
        from .render import HumanWindow, to_rgb_array

        if self.render_mode == "rgb_array":  # type: ignore[attr-defined]
            return to_rgb_array(frame)
        if self._window is None:
            self._window = HumanWindow(self.metadata["render_fps"])  # type: ignore[attr-defined]
        self._window.show(frame)
        return None

    def _close_window(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_window"] = None
        return state


class FlightEnv(RenderWindow, gym.Env[np.ndarray, np.ndarray]):
    """Shared base of the flight environments (see :class:`LevelFlightEnv`, :class:`AccelerateEnv`)."""

    metadata: ClassVar[dict[str, Any]] = {
        "render_modes": list(RENDER_MODES),
        "render_fps": RENDER_FPS,
    }
    config_class: ClassVar[type[FlightConfig]] = FlightConfig
    title: ClassVar[str] = "Flight"
    """Name in render titles when the env was not made by ``gym.make`` (no spec)."""

    def __init__(
        self, render_mode: str | None = None, *, config: FlightConfig | None = None, **kwargs: Any
    ) -> None:
        self.render_mode = check_render_mode(render_mode)
        self.config = build_config(self.config_class, config, kwargs)
        self.task = make_task(self.config)
        self.action_space = action_space()
        self.observation_space = observation_space()
        self._condition: float | None = None
        self._last: LastStep | None = None
        self._window: Any = None

    @property
    def condition(self) -> float | None:
        """The current episode's condition (speed [m/s] or available power [W/kg]), or None."""
        return self._condition

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        values = self.task.draw_conditions(1, lambda _: self.np_random, [options])
        self._condition = float(values[0])
        self._last = None
        if self.render_mode == "human":
            self.render()
        return self.task.observe(values)[0], row(self.task.reset_columns(values), 0)

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._condition is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        values = np.array([self._condition])
        actions = real_array(
            action, "action", f"{N_PARAMETERS} real numbers in [-1, 1] (a normalised stroke)"
        )
        if actions.shape != (N_PARAMETERS,):
            raise ValueError(
                f"action must have shape ({N_PARAMETERS},) (normalised stroke, fore-wing first); "
                f"got shape {actions.shape}"
            )
        batch = self.task.step(actions[None, :], values)
        self._last = LastStep(batch, 0)
        if self.render_mode == "human":
            self.render()
        return (
            self.task.observe(values)[0],
            float(batch.reward[0]),
            True,
            False,
            row(batch.info_columns(), 0),
        )

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without a render mode; make the env with "
                f"render_mode in {list(RENDER_MODES)}"
            )
            return None
        title = self.spec.id if self.spec is not None else self.title
        return self._show(frame_for(self.task, title, self._condition, self._last))

    def close(self) -> None:
        self._close_window()


class LevelFlightEnv(FlightEnv):
    """Steady level flight of the tandem-wing dragonfly: find the most efficient stroke.

    ## Description

    The quasi-steady tandem flapping-wing model of Faisal & Filippone (2016, AIAA J.) evaluates
    one wing-beat cycle of a stroke (both wing pairs, with the fore-wing's slipstream on the
    hind-wing) at flight speed V. The task is the paper's level-flight optimisation
    (docs/model.md §7): maximise the propulsive efficiency η = T·V/P subject to L = W, T = D and
    P/m <= 90 W/kg. Each episode is one cycle (a contextual bandit): observe V, choose a stroke.

    ## Action Space

    ``Box(-1, 1, (28,), float32)``: the 14 stroke parameters of each wing (fore-wing first,
    ``f, φ_m, θ_m, η_m, φ_0, θ_0, η_0, Φ_φ, Φ_θ, Φ_η, K, N, C_η, β_m``), each mapped linearly
    onto its Table 4 range by :func:`tandem_env.normalised_to_physical` (N = 1 below 0, else 2).
    Non-finite actions raise ``ValueError``; so do values outside [-1, 1] unless the env was
    made with ``clip_actions=True``.

    ## Observation Space

    ``Box(-1, 1, (1,), float32)``: the flight speed V [m/s] mapped linearly from
    ``speed_envelope`` (default 0.25-2.0 m/s, the paper's range) to [-1, 1].

    ## Rewards

    ``reward = η − penalty``, ``penalty = weight·violation + offset·[infeasible]`` with
    ``violation = max(0, |L/W − 1| − tol) + max(0, |T − D|/W − tol) + max(0, P/m − P_max)/P_max``
    (tol = ``constraint_tolerance``, default 0.02; P_max = 90 W/kg; weight 10, offset 0 by
    default). A feasible stroke is rewarded with exactly its η. Scale: feasible rewards are
    η in [0, ~0.5] (values above 1 are possible with ``thrust_split="sign"``, flagged in
    ``info["efficiency_above_one"]``, never clipped); uniform random strokes score about −120 to 0
    (median −15 to −45).

    ## Starting State

    V is ``speed`` (default 1.5 m/s) or, with ``speed_range=(low, high)``, drawn uniformly at
    each reset from the env's seeded ``np_random``. ``reset(options={"speed": v})`` sets V for
    one episode.

    ## Episode End

    Every ``step`` evaluates one wing-beat cycle and terminates the episode
    (``terminated=True``, ``truncated=False``). ``info`` holds the named physical stroke
    (``info["stroke"]``), every metric of the model (the :class:`tandem_env.Result` fields:
    the ``METRIC_NAMES``, each constraint's violation, feasibility flags, per-wing
    breakdown, ``speed``, ``available_power``) and the reward terms ``objective``,
    ``constraint_violation``, ``penalty`` and ``feasible``.

    ## Arguments

    ``gym.make("TandemWing/LevelFlight-v0", **kwargs)``, see :class:`LevelFlightConfig` and
    :meth:`FlightConfig.from_kwargs`: ``speed``, ``speed_range``, ``speed_envelope``,
    ``insect``, ``planform`` ("tear-drop" | "real"), ``options`` or its fields (``n_time``,
    ``n_blade``, ``induction`` ("coupled" | "isolated" | "none"), ``interference``,
    ``power_convention`` ("absolute" | "elastic" | "aerodynamic"), ``thrust_split`` ("sign" |
    "body"), ``spin``, ``hover_inflow`` ("momentum" | "none"), ``tolerance``, ``max_evaluations``, ``constraint_tolerance``), ``penalty`` or
    ``penalty_weight`` / ``penalty_offset``, ``clip_actions``, ``render_mode``
    ("rgb_array" | "human"). Invalid values raise ``ValueError`` at construction.

    ## Version History

    * v0: initial version.
    """

    config_class = LevelFlightConfig
    config: LevelFlightConfig
    title = "LevelFlight"


class AccelerateEnv(FlightEnv):
    """Accelerating flight of the tandem-wing dragonfly: find the stroke with most excess force.

    ## Description

    The same quasi-steady tandem-wing model as :class:`LevelFlightEnv` (one wing-beat cycle per
    episode) at a fixed flight speed (default 0: take-off or escape from hover). The task is
    the paper's accelerating-flight optimisation (docs/model.md §7): maximise a specific excess
    force subject to F_v >= 0, F_h >= 0 and P/m <= the available power. The observation is the
    available power, so one policy can cover the paper's 50-90 W/kg sweep.

    ## Action Space

    ``Box(-1, 1, (28,), float32)``, as in :class:`LevelFlightEnv`.

    ## Observation Space

    ``Box(-1, 1, (1,), float32)``: the available power per body mass [W/kg] mapped linearly from
    ``power_envelope`` (default 50-90 W/kg) to [-1, 1].

    ## Rewards

    ``reward = F̄ − penalty`` where F̄ is the ``objective``: ``"vertical"`` F̄_v = (L − W)/W,
    ``"horizontal"`` F̄_h = (T − D)/W, ``"resultant"`` F̄_a = sqrt(F̄_v² + F̄_h²) or
    ``"horizontal_literal"`` (D_f + D_h)/W (Eq. 24 read literally, docs/model.md §7.6);
    ``penalty = weight·violation + offset·[infeasible]`` with
    ``violation = max(0, −F̄_v) + max(0, −F̄_h) + max(0, P/m − P_avail)/P_avail``
    (weight 10, offset 0 by default). A feasible stroke is rewarded with exactly its F̄.
    Scale: feasible rewards are F̄ in [0, ~6] (the paper reports F̄_v ≈ 2.7-4.4 for 50-90 W/kg);
    uniform random strokes score about −100 to 0 (median about −15).

    ## Starting State

    The available power is ``power`` (default 90 W/kg) or, with ``power_range=(low, high)``,
    drawn uniformly at each reset from the env's seeded ``np_random``.
    ``reset(options={"power": p})`` sets it for one episode.

    ## Episode End

    As in :class:`LevelFlightEnv`: one cycle, ``terminated=True``, ``truncated=False``, and the
    same ``info`` keys.

    ## Arguments

    ``gym.make("TandemWing/Accelerate-v0", **kwargs)``, see :class:`AccelerateConfig`:
    ``objective`` ("vertical" | "horizontal" | "resultant" | "horizontal_literal"), ``power``, ``power_range``,
    ``power_envelope``, ``speed`` [m/s], and every model, penalty and action option of
    :class:`LevelFlightEnv` (``thrust_split`` among them). Invalid values raise ``ValueError``
    at construction.

    ## Version History

    * v0: initial version.
    """

    config_class = AccelerateConfig
    config: AccelerateConfig
    title = "Accelerate"
