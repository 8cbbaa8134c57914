"""Aircraft-v0 and AircraftGusty-v0: fly the altitude, airspeed and heading demands the chapter's autopilot flies."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs.base import Info, State, Task, VegymEnv, VegymVectorEnv
from vegym.envs.schedule import ScheduledParams
from vegym.params import Params, invalid, param
from vegym.physics import aircraft
from vegym.physics.aircraft import STANDARD_RATE, AircraftParams, AircraftState

_SETUP_STREAM = 1
_DEMAND_STREAM = 2
_GUST_STREAM = 4


@dataclass(frozen=True)
class AircraftEnvParams(ScheduledParams, Params):
    """Parameters of Aircraft-v0 and AircraftGusty-v0 (SI units, radians; altitudes are y)."""

    dt: float = param(1.0, "control step (s)", low=0.0, high=10.0, low_open=True)
    max_acceleration: float = param(1.5, "A_acc, largest acceleration (m/s^2)", low=0.0, low_open=True)
    max_deceleration: float = param(2.0, "A_dec, largest deceleration (m/s^2, a magnitude)", low=0.0, low_open=True)
    max_climb_rate: float = param(15.0, "V_cli, largest climb rate (m/s)", low=0.0, low_open=True)
    max_descent_rate: float = param(10.0, "V_des, largest descent rate (m/s, a magnitude)", low=0.0, low_open=True)
    max_turn_rate: float = param(STANDARD_RATE, "M, largest turn rate (rad/s)", low=0.0, high=math.pi, low_open=True)
    min_speed: float = param(60.0, "v_min, slowest airspeed of the airframe (m/s)", low=0.0, low_open=True)
    max_speed: float = param(200.0, "v_max, fastest airspeed of the airframe (m/s)", low=0.0, low_open=True)
    floor_altitude: float = param(0.0, "ground level (m); descents are cut there")
    ceiling_altitude: float = param(6000.0, "service ceiling (m); climbs are cut there")
    wind_x: float = param(0.0, "constant horizontal wind drift, x component (m/s); moves the track only")
    wind_z: float = param(0.0, "constant horizontal wind drift, z component (m/s); moves the track only")
    draft_max: float = param(0.0, "steady vertical wind of an episode uniform in +-draft_max (m/s)", low=0.0)
    gust_amplitude: float = param(0.0, "vertical gust of each step uniform in +-gust_amplitude (m/s)", low=0.0)
    altitude_min: float = param(1000.0, "lowest demanded and starting altitude (m)")
    altitude_max: float = param(1600.0, "highest demanded and starting altitude (m)")
    speed_demand_min: float = param(90.0, "slowest demanded and starting airspeed (m/s)", low=0.0, low_open=True)
    speed_demand_max: float = param(150.0, "fastest demanded and starting airspeed (m/s)", low=0.0, low_open=True)
    change_interval_min: float = param(45.0, "shortest time between demand changes (s)", low=0.0, low_open=True)
    change_interval_max: float = param(120.0, "longest time between demand changes (s)", low=0.0, low_open=True)
    final_hold: float = param(90.0, "no demand change within this time of the planned episode end (s)", low=0.0)
    episode_steps: int = param(300, "planned episode length (steps): the registered max_episode_steps", low=1)
    altitude_scale: float = param(
        300.0, "altitude error of a full unit of observation and reward (m)", low=0.0, low_open=True
    )
    speed_scale: float = param(
        30.0, "airspeed error of a full unit of observation and reward (m/s)", low=0.0, low_open=True
    )
    altitude_tolerance: float = param(15.0, "is_success: largest altitude error (m)", low=0.0)
    speed_tolerance: float = param(2.0, "is_success: largest airspeed error (m/s)", low=0.0)
    heading_tolerance: float = param(math.radians(2.0), "is_success: largest heading error (rad)", low=0.0)
    effort_weight: float = param(0.02, "weight of the mean squared normalised action in the reward", low=0.0)

    def validate(self) -> None:
        if not self.floor_altitude <= self.altitude_min <= self.altitude_max:
            raise invalid(
                "altitude_min",
                self.altitude_min,
                f"[floor_altitude={self.floor_altitude}, altitude_max={self.altitude_max}]",
            )
        if self.altitude_max >= self.ceiling_altitude:
            raise invalid("ceiling_altitude", self.ceiling_altitude, f"(altitude_max={self.altitude_max}, inf)")
        if not self.min_speed <= self.speed_demand_min <= self.speed_demand_max:
            raise invalid(
                "speed_demand_min",
                self.speed_demand_min,
                f"[min_speed={self.min_speed}, speed_demand_max={self.speed_demand_max}]",
            )
        if self.speed_demand_max > self.max_speed:
            raise invalid("speed_demand_max", self.speed_demand_max, f"[speed_demand_min, max_speed={self.max_speed}]")
        _ = self.schedule  # raises ValueError if change_interval_min or final_hold is out of range

    @property
    def physics(self) -> AircraftParams:
        """The aircraft physics parameters (the clean model, not the book-faithful variant)."""
        return AircraftParams(
            max_acceleration=self.max_acceleration,
            max_deceleration=self.max_deceleration,
            max_climb_rate=self.max_climb_rate,
            max_descent_rate=self.max_descent_rate,
            max_turn_rate=self.max_turn_rate,
            min_speed=self.min_speed,
            max_speed=self.max_speed,
            floor_altitude=self.floor_altitude,
            ceiling_altitude=self.ceiling_altitude,
            wind_x=self.wind_x,
            wind_z=self.wind_z,
        )

    @property
    def vertical_speed_scale(self) -> float:
        """Largest possible climb or descent rate, drafts and gusts included (m/s): the unit of the observed
        vertical speeds."""
        return max(self.max_climb_rate, self.max_descent_rate) + self.draft_max + self.gust_amplitude


STEP_CONSTANTS = (
    "max_acceleration",
    "max_deceleration",
    "max_climb_rate",
    "max_descent_rate",
    "max_turn_rate",
    "dt",
    "altitude_scale",
    "speed_scale",
    "effort_weight",
    "altitude_tolerance",
    "speed_tolerance",
    "heading_tolerance",
    "gust_amplitude",
    "min_speed",
    "max_speed",
    "vertical_speed_scale",
    "change_interval_max",
    "floor_altitude",
    "ceiling_altitude",
    "wind_x",
    "wind_z",
)
"""Parameters the kernels read, in the order of their constants array (SI units, see the fields)."""
REWARD_TERMS = ("altitude", "speed", "heading", "effort")
"""Names of ``info["reward_terms"]``, in the order of the step kernel's ``terms`` columns."""


@njit(cache=True, nogil=True)
def _step_kernel(
    action: np.ndarray,
    key: np.ndarray,
    step: np.ndarray,
    position: np.ndarray,
    speed: np.ndarray,
    heading: np.ndarray,
    command: np.ndarray,
    vertical_speed: np.ndarray,
    draft: np.ndarray,
    demand: np.ndarray,
    last_change: np.ndarray,
    next_change: np.ndarray,
    c: np.ndarray,
    gust_offset: np.uint64,
    flown: np.ndarray,
    errors: np.ndarray,
    terms: np.ndarray,
    reward: np.ndarray,
    success: np.ndarray,
    terminated: np.ndarray,
    obs: np.ndarray,
) -> int:
    """The whole step and the next observation, fused per episode, in place on the state arrays (``position`` to
    ``vertical_speed``) and into the outputs (``flown``, the demand of the step, to ``obs``); ``c`` holds the
    parameters named in ``STEP_CONSTANTS``, in that order. The vertical wind is the episode's ``draft`` plus,
    when ``gust_amplitude > 0``, a gust uniform in +-gust_amplitude drawn from the key's stream ``gust_offset``
    at counter ``step``. Returns how many episodes have a demand change due at the new step (the caller advances
    the schedule and observes again then; ``obs`` shows the demand before the change)."""
    high = (c[0], c[2], c[4])  # A_acc, V_cli, M: the upper command limits and the scales of positive actions
    envelope = (c[13], c[14], c[17], c[18], c[19], c[20])  # aircraft.envelope: speeds, floor, ceiling, wind
    low = (-c[1], -c[3], -c[4])
    dt, altitude_scale, speed_scale, effort_weight = c[5], c[6], c[7], c[8]
    altitude_tolerance, speed_tolerance, heading_tolerance, gust = c[9], c[10], c[11], c[12]
    due = 0
    for i in range(len(action)):
        for j in range(3):
            u = action[i, j]
            command[i, j] = min(max(u * (high[j] if u >= 0.0 else -low[j]), low[j]), high[j])
        applied = (command[i, 0], command[i, 1], command[i, 2])
        vertical_wind = draft[i]
        if gust > 0.0:
            base = rng.stream_base(key[i], gust_offset, np.uint64(step[i]))
            vertical_wind = vertical_wind + (-gust + (gust + gust) * rng.lane(base, 0))
        y0 = position[i, 1]
        x, y, z, v, psi = aircraft.fly(
            position[i, 0], y0, position[i, 2], speed[i], heading[i], applied, vertical_wind, dt, envelope, False
        )
        position[i, 0], position[i, 1], position[i, 2] = x, y, z
        speed[i], heading[i], vertical_speed[i] = v, psi, (y - y0) / dt
        e0, e1, e2 = demand[i, 0] - y, demand[i, 1] - v, aircraft.wrap_angle(demand[i, 2] - psi)
        errors[i, 0], errors[i, 1], errors[i, 2] = e0, e1, e2
        flown[i, 0], flown[i, 1], flown[i, 2] = demand[i, 0], demand[i, 1], demand[i, 2]
        effort = action[i, 0] * action[i, 0] + action[i, 1] * action[i, 1] + action[i, 2] * action[i, 2]
        terms[i, 0] = -abs(min(max(e0 / altitude_scale, -1.0), 1.0)) / 3.0
        terms[i, 1] = -abs(min(max(e1 / speed_scale, -1.0), 1.0)) / 3.0
        terms[i, 2] = -abs(e2) / (3.0 * np.pi)
        terms[i, 3] = -effort_weight / 3.0 * effort
        reward[i] = terms[i, 0] + terms[i, 1] + terms[i, 2] + terms[i, 3]
        success[i] = abs(e0) <= altitude_tolerance and abs(e1) <= speed_tolerance and abs(e2) <= heading_tolerance
        terminated[i] = False
        now = step[i] + 1
        if now >= next_change[i]:
            due += 1
        _observe_row(i, now, position, speed, heading, command, vertical_speed, demand, last_change, c, obs)
    return due


@njit(cache=True, nogil=True, inline="always")
def _observe_row(
    i: int,
    now: int,
    position: np.ndarray,
    speed: np.ndarray,
    heading: np.ndarray,
    command: np.ndarray,
    vertical_speed: np.ndarray,
    demand: np.ndarray,
    last_change: np.ndarray,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """Observation of episode ``i`` at step ``now`` into ``obs[i]``; ``c`` holds the parameters named in
    ``STEP_CONSTANTS``."""
    dt, altitude_scale, speed_scale = c[5], c[6], c[7]
    min_speed, max_speed, vertical_speed_scale, interval_max = c[13], c[14], c[15], c[16]
    heading_error = demand[i, 2] - heading[i]  # only its sine and cosine are observed: no wrap needed
    obs[i, 0] = min(max((demand[i, 0] - position[i, 1]) / altitude_scale, -1.0), 1.0)
    obs[i, 1] = min(max((demand[i, 1] - speed[i]) / speed_scale, -1.0), 1.0)
    obs[i, 2] = math.sin(heading_error)
    obs[i, 3] = math.cos(heading_error)
    obs[i, 4] = (speed[i] - min_speed) / (max_speed - min_speed)
    obs[i, 5] = min(max(vertical_speed[i] / vertical_speed_scale, -1.0), 1.0)
    obs[i, 6] = command[i, 1] / vertical_speed_scale
    obs[i, 7] = min((now - last_change[i]) * (dt / interval_max), 1.0)


@njit(cache=True, nogil=True)
def _observe_kernel(
    rows: np.ndarray,
    step: np.ndarray,
    ahead: int,
    position: np.ndarray,
    speed: np.ndarray,
    heading: np.ndarray,
    command: np.ndarray,
    vertical_speed: np.ndarray,
    demand: np.ndarray,
    last_change: np.ndarray,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """Observations (8,) of the episodes ``rows`` (int indices) at steps ``step + ahead`` into those rows of
    ``obs``; ``c`` holds the parameters named in ``STEP_CONSTANTS``."""
    for i in rows:
        _observe_row(i, step[i] + ahead, position, speed, heading, command, vertical_speed, demand, last_change, c, obs)


class AircraftTask(Task[AircraftEnvParams]):
    """Batched logic of Aircraft-v0 (see :class:`AircraftEnv`)."""

    params_cls = AircraftEnvParams
    renderer = "vegym.render.aircraft:AircraftRenderer"

    def __init__(self, params: AircraftEnvParams) -> None:
        super().__init__(params)
        self.physics = params.physics
        self.schedule = params.schedule
        low = np.array([-1, -1, -1, -1, 0, -1, -1, 0], np.float32)
        self.observation_space = spaces.Box(low, np.ones(8, np.float32), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (3,), np.float32)
        self._constants = np.array([getattr(params, name) for name in STEP_CONSTANTS], dtype=np.float64)
        self._gust_offset = rng.stream_offset(_GUST_STREAM)

    @property
    def control_rate(self) -> float:
        return 1.0 / self.params.dt

    def draw_demand(self, keys: np.ndarray, index: np.ndarray) -> np.ndarray:
        """Demand number ``index`` (n,) of each episode: ``(altitude, airspeed, heading)`` (n, 3), uniform in the
        demand ranges and in [-pi, pi)."""
        p = self.params
        u = rng.uniform(keys, _DEMAND_STREAM, 3, counter=index)
        return np.stack(
            [
                p.altitude_min + (p.altitude_max - p.altitude_min) * u[:, 0],
                p.speed_demand_min + (p.speed_demand_max - p.speed_demand_min) * u[:, 1],
                np.pi * (2.0 * u[:, 2] - 1.0),
            ],
            axis=-1,
        )

    def initial_state(self, keys: np.ndarray) -> State:
        p = self.params
        n = len(keys)
        u = rng.uniform(keys, _SETUP_STREAM, 4)
        altitude = p.altitude_min + (p.altitude_max - p.altitude_min) * u[:, 0]
        zeros = np.zeros(n, dtype=np.int64)
        return {
            "position": np.stack([np.zeros(n), altitude, np.zeros(n)], axis=-1),
            "speed": p.speed_demand_min + (p.speed_demand_max - p.speed_demand_min) * u[:, 1],
            "heading": np.pi * (2.0 * u[:, 2] - 1.0),
            "command": np.zeros((n, 3)),
            "vertical_speed": np.zeros(n),
            "draft": p.draft_max * (2.0 * u[:, 3] - 1.0),
            "demand": self.draw_demand(keys, zeros),
            **self.schedule.initial(keys),
        }

    @staticmethod
    def aircraft_state(state: State) -> AircraftState:
        """The physics state of a task state."""
        return AircraftState(state["position"], state["speed"], state["heading"], state["command"])

    def output_shapes(self) -> dict[str, tuple[tuple[int, ...], type]]:
        return {
            "demand": ((3,), np.float64),
            "errors": ((3,), np.float64),
            "terms": ((len(REWARD_TERMS),), np.float64),
            "success": ((), np.bool_),
        }

    def step(self, state: State, action: np.ndarray, out: State) -> None:
        due = _step_kernel(
            action, state["key"], state["step"], state["position"], state["speed"], state["heading"],
            state["command"], state["vertical_speed"], state["draft"], state["demand"], state["last_change"],
            state["next_change"], self._constants, self._gust_offset, out["demand"], out["errors"],
            out["terms"], out["reward"], out["success"], out["terminated"], out["obs"],
        )  # fmt: skip
        if due:  # a demand changes at the new step: advance the schedule, then observe the new demands
            changed = self.schedule.advance(state, state["step"] + 1, "demand", self.draw_demand)
            _observe_kernel(
                changed, state["step"], 1, state["position"], state["speed"], state["heading"], state["command"],
                state["vertical_speed"], state["demand"], state["last_change"], self._constants, out["obs"],
            )  # fmt: skip

    def info(self, state: State, out: State) -> Info:
        return {
            "position": state["position"],
            "speed": state["speed"],
            "heading": state["heading"],
            "vertical_speed": state["vertical_speed"],
            "dt": self.params.dt,
            "demand": out["demand"],
            "errors": out["errors"],
            "reward_terms": dict(zip(REWARD_TERMS, out["terms"].T, strict=True)),
            "is_success": out["success"],
        }

    def observe(self, state: State, obs: np.ndarray) -> None:
        _observe_kernel(
            np.arange(len(obs)), state["step"], 0, state["position"], state["speed"], state["heading"],
            state["command"], state["vertical_speed"], state["demand"], state["last_change"], self._constants, obs,
        )  # fmt: skip


class AircraftEnv(VegymEnv[AircraftEnvParams]):
    """Flying clearances: hold the altitude, airspeed and heading demanded, as the chapter's autopilot does.

    ## Description
    The first-order aircraft of the chapter (8.113-8.128) in the corrected form of PHYSICS.md section 10:
    a point with horizontal airspeed v along its heading psi and a climb rate, driven by three commands, the
    acceleration a, the climb rate v_y and the turn rate omega, held over each step of ``dt`` seconds (chord
    update at the mid-heading, speed clipped to the airframe's ``[min_speed, max_speed]`` and the altitude to
    ``[floor_altitude, ceiling_altitude]``). Like an air-traffic controller, the episode hands the aircraft a
    demand (altitude, airspeed, heading) and changes it at random times, every ``change_interval_min`` to
    ``change_interval_max`` seconds; the agent must fly each demand quickly and hold it.

    ``vegym/AircraftGusty-v0`` is the same task in a steady vertical wind w of the episode (updraft or
    downdraft, uniform in +-4 m/s) plus gusts (uniform in +-2 m/s, independent each step). The chapter's
    proportional autopilot then settles with a steady altitude error ``|w| / k_v`` (k_v = 0.2 /s). Measured
    as the mean ``|y_d - y|`` over the last 30 s of 500 episodes (seed 0, ``tests/test_aircraft.py``) it is
    **10.1 m** (the drafts' mean ``|w| / k_v``: 10.0 m), and the autopilot ends within the altitude tolerance
    on 75% of the episodes (100% on Aircraft-v0). That is the number to beat: a policy that subtracts the
    draft it infers from the observation (vertical speed achieved minus its own climb command) gets 1.0 m and
    100%.

    ## Action Space
    ``Box(-1, 1, (3,), float32)``: the commands ``(a, v_y, omega)``, each mapped asymmetrically onto its
    saturation range ``[-A_dec, A_acc] x [-V_des, V_cli] x [-M, M]``: ``u >= 0`` gives ``u`` times the upper
    limit, ``u < 0`` ``|u|`` times the lower one, so 0 holds speed, altitude and heading.

    ## Observation Space
    ``Box([-1, -1, -1, -1, 0, -1, -1, 0], 1, (8,), float32)``: altitude error ``(y_d - y) / altitude_scale``
    and airspeed error ``(v_d - v) / speed_scale``, both clipped to [-1, 1]; ``sin`` and ``cos`` of the
    heading error ``psi_d - psi``; airspeed ``(v - min_speed) / (max_speed - min_speed)``; the vertical speed
    achieved in the last step (drafts and gusts included) and the climb rate commanded in it, both over
    ``vertical_speed_scale = max(V_cli, V_des) + draft_max + gust_amplitude``; time since the last demand
    change over ``change_interval_max``, capped at 1. The two errors are clipped, and so is the vertical speed
    against round-off; the other entries lie in their bounds by construction. Errors are demand minus current value.

    ## Rewards
    Per step, the sum of ``-|altitude error| / (3 altitude_scale)`` and ``-|airspeed error| / (3 speed_scale)``
    (each error clipped to its scale), ``-|heading error| / (3 pi)`` and the effort penalty
    ``-effort_weight * mean(action^2)``: the terms ``altitude``, ``speed``, ``heading``, ``effort`` of
    ``info["reward_terms"]``. The tracking part lies in [-1, 0].

    ## Starting State
    Position ``(0, y0, 0)`` with altitude, airspeed and heading uniform in ``[altitude_min, altitude_max]``,
    ``[speed_demand_min, speed_demand_max]`` and [-pi, pi); the first demand is drawn from the same ranges.
    The demand schedule (values and change times) comes from the episode seed alone, never from the actions.
    It is planned for ``episode_steps`` steps (the registered ``max_episode_steps``, 300 steps of 1 s): no
    change comes within ``final_hold`` (90 s) of that end, which leaves time to fly any demand in still air
    (about 60 s at most at the default limits; a long descent against a 4 m/s updraft can take 100 s). If an
    episode runs longer, the last demand simply holds.

    ## Episode End
    Never terminated; truncated after ``max_episode_steps`` (300). ``info["is_success"]`` at every step:
    the aircraft is within ``altitude_tolerance`` (15 m), ``speed_tolerance`` (2 m/s) and
    ``heading_tolerance`` (2 deg) of the demand it flew; at the last step that is the final demand.

    ## Arguments
    ``gymnasium.make("vegym/Aircraft-v0", render_mode=None, **params)`` with the fields of
    :class:`AircraftEnvParams`. ``info`` per step (SI, radians, y up): ``position`` (x, y, z; y = altitude),
    ``speed``, ``heading``, ``vertical_speed`` (climb rate applied this step, drafts and gusts included),
    ``dt``, ``demand`` (altitude, speed, heading flown this step; the observation already shows a change
    made at this step), ``errors`` (altitude, speed, heading: demand minus value, heading wrapped),
    ``reward_terms``, ``is_success``. Reference controller: the chapter's autopilot, three decoupled
    saturated P loops with gains 0.2, 0.5, 0.5 /s (``agents.analytic``).

    ## Version History
    * v0: initial version.
    """

    task_cls = AircraftTask


class AircraftVectorEnv(VegymVectorEnv[AircraftEnvParams]):
    """Native vector twin of :class:`AircraftEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = AircraftTask
