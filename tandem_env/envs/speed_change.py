"""``TandemWing/SpeedChange-v0``: change speed and hold altitude over many wing-beats.

One step is one wing-beat cycle chosen from the current state; the episode lasts up to
``max_cycles`` cycles. The batched core (model call, dynamics, reward) is
:mod:`tandem_env.envs.speed_change_task`, shared with the native vector env
(:mod:`tandem_env.envs.speed_change_vector`) and the SB3 adapter.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..physics import stroke_history
from .flight import SingleEnv, action_space, build_config, check_action, check_render_mode
from .speed_change_config import SpeedChangeConfig
from .speed_change_task import OBSERVATION_NAMES, CycleBatch, Flight, SpeedChangeTask
from .task import row


def observation_space() -> spaces.Box:
    """Box(-1, 1, (5,), float32): u, w, h, u*, cycles left, each normalised (see the env)."""
    return spaces.Box(-1.0, 1.0, (len(OBSERVATION_NAMES),), dtype=np.float32)


@dataclass
class LastCycle:
    """What the picture of an env shows: its last flown cycle, or None."""

    batch: CycleBatch
    index: int


def frame_for(
    task: SpeedChangeTask, title: str, flight: Flight | None, index: int, last: LastCycle | None
) -> Any:
    """The render frame of episode ``index`` of ``flight`` (imports matplotlib lazily)."""
    from .render import HISTORY_SAMPLES, Frame

    cfg = task.config
    if flight is None:
        return Frame(title=f"{title}  {cfg.describe()}", subtitle="not reset yet", history=None)
    state = row(flight.columns(), index)
    heading = (
        f"{title}  u = {state['forward_speed']:.3g} m/s -> u* = {state['target_speed']:.3g} m/s, "
        f"h = {state['altitude']:+.3g} m, cycle {state['cycle']}/{cfg.max_cycles}"
    )
    if last is None:
        return Frame(title=heading, subtitle="no cycle flown since reset", history=None)
    batch, k = last.batch, last.index
    result = batch.strokes.result
    subtitle = (
        f"reward {float(batch.reward[k]):.4g} | F_x {float(batch.force_horizontal[k]) * 1e3:+.3f} "
        f"mN | F_z {float(batch.force_vertical[k]) * 1e3:+.3f} mN | "
        f"P/m {float(result.power_per_mass[k]):.1f} W/kg | Δt {float(batch.cycle_time[k]) * 1e3:.1f} ms"
    )
    history = stroke_history(
        batch.strokes.physical[k],
        float(result.speed[k]),
        float(result.available_power[k]),
        flight_path_angle=float(result.flight_path_angle[k]),
        insect=cfg.insect,
        options=cfg.options,
        n_samples=HISTORY_SAMPLES,
    )
    return Frame(title=heading, subtitle=subtitle, history=history)


class SpeedChangeEnv(SingleEnv):
    """Change forward speed and hold altitude over many wing-beats of the tandem-wing dragonfly.

    ## Description

    The quasi-steady tandem-wing model (Faisal & Filippone 2016) evaluates one wing-beat cycle
    of a stroke at the body's current velocity: speed V = sqrt(u² + w²) along a flight path
    inclined by γ = atan2(w, u), forces in earth axes. The cycle-mean wing forces plus the body's
    parasite drag and its weight then move the body as a point mass for one cycle
    (:mod:`tandem_env.envs.dynamics`). The task: reach the target forward speed u*, hold the
    start altitude, spend little energy, within the power cap (90 W/kg). Each stroke is chosen
    from the current state, so a policy can do what no fixed stroke can: accelerate hard, then
    settle.

    ## Action Space

    ``Box(-1, 1, (28,), float32)``: the next cycle's normalised stroke, exactly as in
    ``TandemWing/LevelFlight-v0`` (``tandem_env.normalised_to_physical``; ``clip_actions``).

    ## Observation Space

    ``Box(-1, 1, (5,), float32)``: forward speed u over ``forward_speed_band`` (0-3 m/s),
    vertical speed w / ``vertical_speed_scale`` (2 m/s, clipped), altitude error
    h / ``altitude_band`` (0.5 m), target speed u* over ``speed_envelope`` (0.25-2 m/s) and
    cycles left over (0, ``max_cycles``), each mapped linearly to [-1, 1].

    ## Dynamics

    One step lasts Δt = max(1/f_fore, 1/f_hind) (both pairs complete a beat). The net force
    F = F_wings + D_body + W is held over the cycle and the state advanced exactly for a constant
    force: u' = u + F_x/m·Δt, w' = w + F_z/m·Δt, h' = h + w·Δt + ½F_z/m·Δt².

    ## Rewards

    ``reward = objective − penalty``, ``objective`` the sum of the weighted terms
    (:class:`~tandem_env.envs.speed_change_config.SpeedChangeReward`; u, h before and u', h'
    after the cycle): progress w_progress·(|u − u*| − |u' − u*|) [1/(m/s)], speed error
    −w_speed·|u' − u*|·Δt [1/m], altitude error −w_altitude·|h'|·Δt [1/(m·s)], energy
    −w_energy·P·Δt [1/J], and −w_termination·(cycles not flown) on termination; ``penalty`` the
    power cap of level flight, ``penalty_weight``·max(0, P/m − 90)/90 per cycle (exactly 0
    within the cap).

    ## Starting State

    u = u₀, w = 0, h = 0; u₀ and u* each fixed (``start_speed``, ``target_speed``) or drawn
    uniformly from ``start_speed_range`` / ``target_speed_range`` (default the level-flight
    envelope 0.25-2.0 m/s) with the env's seeded ``np_random``.
    ``reset(options={"start_speed": .., "target_speed": .., "vertical_speed": ..})`` sets them
    for one episode.

    ## Episode End

    Terminates when |h| > ``altitude_band`` (0.5 m) or u leaves ``forward_speed_band``
    (0-3 m/s: the model covers forward flight only); truncates after ``max_cycles`` (48) cycles,
    1.1-1.6 s of flight. ``info`` holds the state after the cycle (``forward_speed``,
    ``vertical_speed``, ``altitude``, ``distance``, ``time``, ``cycle``, ``target_speed``),
    ``cycle_time``, the net ``force_horizontal`` / ``force_vertical`` [N], ``energy`` [J], each
    reward term, the band flags, and every field of the model's ``Result`` for the stroke at the
    cycle's start (``speed`` V, ``flight_path_angle`` γ, ``power``, ``efficiency``, ...).

    ## Arguments

    ``gym.make("TandemWing/SpeedChange-v0", **kwargs)``, see
    :class:`~tandem_env.envs.speed_change_config.SpeedChangeConfig`: ``start_speed``,
    ``start_speed_range``, ``target_speed``, ``target_speed_range``, ``speed_envelope``,
    ``max_cycles``, ``altitude_band``, ``forward_speed_band``, ``vertical_speed_scale``,
    ``reward`` (a dict of weights), and every model, penalty and action option of the other envs
    (``thrust_split`` defaults to ``"body"`` here). Invalid values raise ``ValueError``.

    ## Version History

    * v0: initial version.
    """

    title: ClassVar[str] = "SpeedChange"

    def __init__(
        self,
        render_mode: str | None = None,
        *,
        config: SpeedChangeConfig | None = None,
        **kwargs: Any,
    ) -> None:
        self.render_mode = check_render_mode(render_mode)
        self.config: SpeedChangeConfig = build_config(SpeedChangeConfig, config, kwargs)  # type: ignore[assignment]
        self.task = SpeedChangeTask(self.config)
        self.action_space = action_space()
        self.observation_space = observation_space()
        self._flight: Flight | None = None
        self._done = False
        self._last: LastCycle | None = None
        self._window: Any = None

    @property
    def flight(self) -> Flight | None:
        """The current episode's state (B = 1 arrays), or None before the first reset."""
        return self._flight

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self._flight = self.task.draw(1, lambda _: self.np_random, [options])
        self._done = False
        self._last = None
        if self.render_mode == "human":
            self.render()
        return self.task.observe(self._flight)[0], row(self.task.reset_columns(self._flight), 0)

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._flight is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        if self._done:
            raise gym.error.ResetNeeded("the episode has ended; call reset() before step()")
        actions = check_action(action)
        batch = self.task.step(actions[None, :], self._flight)
        self._flight = batch.after
        terminated, truncated = bool(batch.terminated[0]), bool(batch.truncated[0])
        self._done = terminated or truncated
        self._last = LastCycle(batch, 0)
        if self.render_mode == "human":
            self.render()
        return (
            self.task.observe(batch.after)[0],
            float(batch.reward[0]),
            terminated,
            truncated,
            row(batch.info_columns(), 0),
        )

    def _frame(self, title: str) -> Any:
        return frame_for(self.task, title, self._flight, 0, self._last)
