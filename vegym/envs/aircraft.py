"""Aircraft-v0 and AircraftGusty-v0: fly the altitude, airspeed and heading demands the chapter's autopilot flies."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs import schedule
from vegym.envs.base import Info, KernelCall, State, Task, VegymEnv, VegymVectorEnv
from vegym.envs.schedule import ScheduledParams
from vegym.params import Params, param
from vegym.physics import aircraft, vmath
from vegym.physics.aircraft import STANDARD_RATE, AircraftParams, AircraftState
from vegym.physics.columns import prefer_wide_vectors

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
            raise self.between("altitude_min", "floor_altitude", "altitude_max")
        if self.altitude_max >= self.ceiling_altitude:
            raise self.between("ceiling_altitude", "altitude_max", low_open=True)
        if not self.min_speed <= self.speed_demand_min <= self.speed_demand_max:
            raise self.between("speed_demand_min", "min_speed", "speed_demand_max")
        if self.speed_demand_max > self.max_speed:
            raise self.between("speed_demand_max", "speed_demand_min", "max_speed")
        _ = self.schedule  # raises ValueError if change_interval_min or final_hold is out of range

    @property
    def physics(self) -> AircraftParams:
        """The aircraft physics parameters (the clean model, not the book-faithful variant)."""
        return self.subset(AircraftParams, book_faithful=False)

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


@njit(cache=True, nogil=True, error_model="numpy")
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
    changes: np.ndarray,
    c: np.ndarray,
    gust_offset: np.uint64,
    timing: schedule.Timing,
    ranges: tuple[float, float, float, float],
    demand_offset: np.uint64,
    flown: np.ndarray,
    errors: np.ndarray,
    terms: np.ndarray,
    reward: np.ndarray,
    success: np.ndarray,
    terminated: np.ndarray,
    obs: np.ndarray,
) -> None:
    """The whole step and the next observation, in place on the state arrays (``position`` to ``changes``)
    and into the outputs (``flown``, the demand of the step, to ``obs``); ``c`` holds the parameters named in
    ``STEP_CONSTANTS``, in that order. The vertical wind is the episode's ``draft`` plus, when
    ``gust_amplitude > 0``, a gust uniform in +-gust_amplitude drawn from the key's stream ``gust_offset`` at
    counter ``step``. Where demand changes are due at the new step, :func:`_change_demands` hands them out last
    (``timing``, ``ranges`` and ``demand_offset`` are its).

    Written as passes over the batch that the compiler turns into SIMD code (loops without calls or exits): the
    gusts, the commands, the flight, the errors with the reward, the observation, the count of changes due. The
    2-D arrays (C-contiguous) are indexed through flat views, whose constant strides vectorise (``a[i, k]`` does
    not); no pass makes more than 16 such strided accesses, and the scratch arrays are separate allocations
    (rows of one array would overlap as far as the compiler can tell): either keeps a loop scalar.
    """
    prefer_wide_vectors()
    n = len(action)
    high = (c[0], c[2], c[4])  # A_acc, V_cli, M: the upper command limits and the scales of positive actions
    envelope = (c[13], c[14], c[17], c[18], c[19], c[20])  # aircraft.envelope: speeds, floor, ceiling, wind
    low = (-c[1], -c[3], -c[4])
    dt, altitude_scale, speed_scale, effort_weight = c[5], c[6], c[7], c[8]
    altitude_tolerance, speed_tolerance, heading_tolerance, gust = c[9], c[10], c[11], c[12]
    wind = draft
    if gust > 0.0:
        wind = np.empty(n)
        for i in range(n):
            base = rng.stream_base(key[i], gust_offset, np.uint64(step[i]))
            wind[i] = draft[i] + (-gust + (gust + gust) * rng.lane(base, 0))
    u, p, d, applied = action.reshape(3 * n), position.reshape(3 * n), demand.reshape(3 * n), command.reshape(3 * n)
    e, demanded, t, o = errors.reshape(3 * n), flown.reshape(3 * n), terms.reshape(4 * n), obs.reshape(8 * n)
    accel, climb, turn, effort = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):  # the commands
        u0, u1, u2 = u[3 * i], u[3 * i + 1], u[3 * i + 2]
        a = min(max(u0 * (high[0] if u0 >= 0.0 else -low[0]), low[0]), high[0])
        b = min(max(u1 * (high[1] if u1 >= 0.0 else -low[1]), low[1]), high[1])
        w = min(max(u2 * (high[2] if u2 >= 0.0 else -low[2]), low[2]), high[2])
        accel[i], climb[i], turn[i] = a, b, w
        applied[3 * i], applied[3 * i + 1], applied[3 * i + 2] = a, b, w
        effort[i] = -effort_weight / 3.0 * (u0 * u0 + u1 * u1 + u2 * u2)
    for i in range(n):  # the flight
        y0, applied_i = p[3 * i + 1], (accel[i], climb[i], turn[i])
        x, y, z, v, psi = aircraft.fly(
            p[3 * i], y0, p[3 * i + 2], speed[i], heading[i], applied_i, wind[i], dt, envelope, False
        )
        p[3 * i], p[3 * i + 1], p[3 * i + 2] = x, y, z
        speed[i], heading[i], vertical_speed[i] = v, psi, (y - y0) / dt
    for i in range(n):  # the errors, reward and success
        d0, d1, d2 = d[3 * i], d[3 * i + 1], d[3 * i + 2]
        e0, e1, e2 = d0 - p[3 * i + 1], d1 - speed[i], aircraft.wrap_angle(d2 - heading[i])
        e[3 * i], e[3 * i + 1], e[3 * i + 2] = e0, e1, e2
        demanded[3 * i], demanded[3 * i + 1], demanded[3 * i + 2] = d0, d1, d2
        t0 = -abs(min(max(e0 / altitude_scale, -1.0), 1.0)) / 3.0
        t1 = -abs(min(max(e1 / speed_scale, -1.0), 1.0)) / 3.0
        t2 = -abs(e2) / (3.0 * np.pi)
        t3 = effort[i]
        t[4 * i], t[4 * i + 1], t[4 * i + 2], t[4 * i + 3] = t0, t1, t2, t3
        reward[i] = t0 + t1 + t2 + t3
        success[i] = (abs(e0) <= altitude_tolerance) & (abs(e1) <= speed_tolerance) & (abs(e2) <= heading_tolerance)
        terminated[i] = False
    scales = _scales(c)
    for i in range(n):  # the observation
        values = _observation(
            step[i] + 1, p[3 * i + 1], speed[i], heading[i], climb[i], vertical_speed[i], d[3 * i], d[3 * i + 1],
            d[3 * i + 2], last_change[i], scales,
        )  # fmt: skip
        o[8 * i], o[8 * i + 1], o[8 * i + 2], o[8 * i + 3] = values[0], values[1], values[2], values[3]
        o[8 * i + 4], o[8 * i + 5], o[8 * i + 6], o[8 * i + 7] = values[4], values[5], values[6], values[7]
    due = 0
    for i in range(n):  # the demand changes due at the new step
        due += step[i] + 1 >= next_change[i]
    if due:
        _change_demands(
            key, step, changes, last_change, next_change, timing, ranges, demand_offset, demand, position, speed,
            heading, command, vertical_speed, c, obs,
        )  # fmt: skip


@njit(cache=True, nogil=True, inline="always")
def _scales(c: np.ndarray) -> tuple[float, float, float, float, float, float, float]:
    """The parameters :func:`_observation` reads, from the constants ``c`` named in ``STEP_CONSTANTS``: ``dt``,
    ``altitude_scale``, ``speed_scale``, ``min_speed``, ``max_speed``, ``vertical_speed_scale`` and
    ``change_interval_max``."""
    return c[5], c[6], c[7], c[13], c[14], c[15], c[16]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observation(
    now: int,
    altitude: float,
    speed: float,
    heading: float,
    climb_command: float,
    vertical_speed: float,
    demand_altitude: float,
    demand_speed: float,
    demand_heading: float,
    last_change: int,
    scales: tuple[float, float, float, float, float, float, float],
) -> tuple[float, float, float, float, float, float, float, float]:
    """Observation (8 entries) of one episode at step ``now``; ``scales`` from :func:`_scales`."""
    dt, altitude_scale, speed_scale, min_speed, max_speed, vertical_speed_scale, interval_max = scales
    sine, cosine = vmath.sincos(demand_heading - heading)  # heading error: no wrap needed for its sine and cosine
    return (
        min(max((demand_altitude - altitude) / altitude_scale, -1.0), 1.0),
        min(max((demand_speed - speed) / speed_scale, -1.0), 1.0),
        sine,
        cosine,
        (speed - min_speed) / (max_speed - min_speed),
        min(max(vertical_speed / vertical_speed_scale, -1.0), 1.0),
        climb_command / vertical_speed_scale,
        min((now - last_change) * (dt / interval_max), 1.0),
    )


@njit(cache=True, nogil=True, error_model="numpy")
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
    scales = _scales(c)
    for i in rows:
        values = _observation(
            step[i] + ahead, position[i, 1], speed[i], heading[i], command[i, 1], vertical_speed[i], demand[i, 0],
            demand[i, 1], demand[i, 2], last_change[i], scales,
        )  # fmt: skip
        for k in range(8):
            obs[i, k] = values[k]


@njit(cache=True, nogil=True, inline="always")
def _demand(
    key: np.uint64, index: int, ranges: tuple[float, float, float, float], offset: np.uint64
) -> tuple[float, float, float]:
    """Demand number ``index`` of the episode ``key``: ``(altitude, airspeed, heading)``, uniform in the ranges
    ``(altitude_min, altitude_max, speed_demand_min, speed_demand_max)`` and in [-pi, pi), from the stream
    ``offset``."""
    base = rng.stream_base(key, offset, np.uint64(index))
    return (
        ranges[0] + (ranges[1] - ranges[0]) * rng.lane(base, 0),
        ranges[2] + (ranges[3] - ranges[2]) * rng.lane(base, 1),
        np.pi * (2.0 * rng.lane(base, 2) - 1.0),
    )


@njit(cache=True, nogil=True)
def _draw_demands(
    keys: np.ndarray, index: np.ndarray, ranges: tuple[float, float, float, float], offset: np.uint64
) -> np.ndarray:
    """:func:`_demand` of each key (n, 3)."""
    out = np.empty((len(keys), 3))
    for i in range(len(keys)):
        out[i, 0], out[i, 1], out[i, 2] = _demand(keys[i], index[i], ranges, offset)
    return out


@njit(cache=True, nogil=True)
def _change_demands(
    key: np.ndarray,
    step: np.ndarray,
    changes: np.ndarray,
    last_change: np.ndarray,
    next_change: np.ndarray,
    timing: schedule.Timing,
    ranges: tuple[float, float, float, float],
    demand_offset: np.uint64,
    demand: np.ndarray,
    position: np.ndarray,
    speed: np.ndarray,
    heading: np.ndarray,
    command: np.ndarray,
    vertical_speed: np.ndarray,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """The demand changes due at the new step (``step`` not yet counted), in place (:func:`schedule.advance_due`
    and :func:`_demand`), and the observations of the episodes that changed, into those rows of ``obs``."""
    rows = schedule.advance_due(key, step, changes, last_change, next_change, timing)
    for i in rows:
        demand[i, 0], demand[i, 1], demand[i, 2] = _demand(key[i], changes[i], ranges, demand_offset)
    _observe_kernel(rows, step, 1, position, speed, heading, command, vertical_speed, demand, last_change, c, obs)


class AircraftTask(Task[AircraftEnvParams]):
    """Batched logic of Aircraft-v0 (see :class:`AircraftEnv`)."""

    params_cls = AircraftEnvParams
    planned_length_param = "episode_steps"
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
        self._demand_offset = rng.stream_offset(_DEMAND_STREAM)
        self._demand_ranges = (
            params.altitude_min,
            params.altitude_max,
            params.speed_demand_min,
            params.speed_demand_max,
        )
        self._timing = self.schedule.timing

    @property
    def control_rate(self) -> float:
        return 1.0 / self.params.dt

    def draw_demand(self, keys: np.ndarray, index: np.ndarray) -> np.ndarray:
        """Demand number ``index`` (n,) of each episode: ``(altitude, airspeed, heading)`` (n, 3), uniform in the
        demand ranges and in [-pi, pi)."""
        return _draw_demands(*schedule.per_key(keys, index), self._demand_ranges, self._demand_offset)

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

    def step_call(self, state: State, action: np.ndarray, out: State) -> KernelCall:
        return _step_kernel, (
            action, state["key"], state["step"], state["position"], state["speed"], state["heading"],
            state["command"], state["vertical_speed"], state["draft"], state["demand"], state["last_change"],
            state["next_change"], state["changes"], self._constants, self._gust_offset, self._timing,
            self._demand_ranges, self._demand_offset, out["demand"], out["errors"], out["terms"], out["reward"],
            out["success"], out["terminated"], out["obs"],
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
        self.observe_rows(state, np.arange(len(obs)), obs)

    def observe_rows(self, state: State, rows: np.ndarray, obs: np.ndarray) -> None:
        _observe_kernel(
            rows, state["step"], 0, state["position"], state["speed"], state["heading"], state["command"],
            state["vertical_speed"], state["demand"], state["last_change"], self._constants, obs,
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
    Another episode length takes both ``episode_steps=N`` and ``max_episode_steps=N``: the task plans for
    ``episode_steps``, and ``max_episode_steps`` alone only moves the time limit. A shorter one cuts episodes, whose
    demand may then change within ``final_hold`` of the cut; a longer one outlives the plan and warns (a vector env
    when made, a single env at the step past the plan).
    ``episode_steps`` alone keeps the registered time limit, with the same effects: it cuts a longer plan and is
    outlived by a shorter one. A vector env warns when made; a single env cannot see its limit and warns only at a step
    past its plan (``vegym`` train, evaluate and compare make the plan the time limit).

    ## Version History
    * v0: initial version.
    """

    task_cls = AircraftTask


class AircraftVectorEnv(VegymVectorEnv[AircraftEnvParams]):
    """Native vector twin of :class:`AircraftEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = AircraftTask
