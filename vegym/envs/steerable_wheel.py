"""SteerableWheel-v0: drive a rolling, steerable wheel through random waypoints in order."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs.base import Info, KernelCall, State, Task, VegymEnv, VegymVectorEnv
from vegym.params import Params, param
from vegym.physics import vmath, wheel
from vegym.physics.columns import scratch
from vegym.physics.wheel import WheelParams

_SETUP_STREAM = 1
OBS_PER_WAYPOINT = 3
"""Observation entries per shown waypoint: normalised distance, sin and cos of the relative bearing."""
SHOWN_WAYPOINTS = 2
"""The current waypoint and the one after it are observed."""
REWARD_TERMS = ("progress", "waypoint", "time", "effort", "exit")
"""Names of ``info["reward_terms"]``, in the order of the step kernel's ``terms`` columns."""
STEP_CONSTANTS = (
    "max_speed",
    "max_acceleration",
    "dt",
    "max_yaw_rate",
    "radius",
    "half_size",
    "capture_radius",
    "progress_weight",
    "waypoint_bonus",
    "time_penalty",
    "effort_penalty",
    "exit_penalty",
    "diagonal",
)
"""Parameters the step kernel reads, in the order of its constants array (SI units, see the fields)."""


@dataclass(frozen=True)
class SteerableWheelParams(Params):
    """Parameters of SteerableWheel-v0 (SI units, radians; the arena is the square |x|, |z| <= arena_size / 2)."""

    radius: float = param(0.3, "wheel radius (m)", low=0.0, low_open=True)
    dt: float = param(0.1, "control step (s); speed and yaw rate are held over it", low=0.0, low_open=True, high=1.0)
    max_speed: float = param(
        2.0, "top forward speed (m/s); the speed command spans [0, max_speed]", low=0.0, low_open=True
    )
    max_acceleration: float = param(
        4.0, "largest change of speed per second (m/s^2), toward the command", low=0.0, low_open=True
    )
    max_yaw_rate: float = param(
        2.0, "largest yaw rate (rad/s); the heading increment is phi = omega dt", low=0.0, low_open=True
    )
    arena_size: float = param(20.0, "side of the square arena centred on the origin (m)", low=0.0, low_open=True)
    n_waypoints: int = param(5, "waypoints per episode, to pass in order", low=1, high=64)
    waypoint_margin: float = param(2.0, "least distance of a waypoint from the arena edge (m)", low=0.0)
    capture_radius: float = param(0.5, "a waypoint is passed when the wheel's centre comes this close (m)", low=0.0)
    progress_weight: float = param(1.0, "reward per metre of progress toward the current waypoint", low=0.0)
    waypoint_bonus: float = param(5.0, "reward per waypoint passed", low=0.0)
    time_penalty: float = param(0.5, "cost per second of episode time", low=0.0)
    effort_penalty: float = param(0.1, "cost per second of full-rate steering (quadratic in the yaw rate)", low=0.0)
    exit_penalty: float = param(5.0, "cost of leaving the arena (ends the episode)", low=0.0)

    def validate(self) -> None:
        half_arena = (f"arena_size / 2 = {self.half_size:g}", self.half_size)
        for name in ("waypoint_margin", "capture_radius"):
            if not getattr(self, name) < self.half_size:
                raise self.between(name, high=half_arena, high_open=True)

    @property
    def wheel(self) -> WheelParams:
        """The wheel's physical parameters."""
        return self.subset(WheelParams)

    @property
    def half_size(self) -> float:
        """Half the arena side (m): the wheel leaves the arena when ``max(|x|, |z|) > half_size``."""
        return 0.5 * self.arena_size

    @property
    def diagonal(self) -> float:
        """Arena diagonal (m): the largest distance between two points of the arena, the distance scale."""
        return float(np.sqrt(2.0) * self.arena_size)


@njit(cache=True, inline="always", error_model="numpy")
def _point_segment_distance(px: float, pz: float, sx: float, sz: float, ex: float, ez: float) -> float:
    """Distance (m) from the point ``(px, pz)`` to the segment from ``(sx, sz)`` to ``(ex, ez)``."""
    dx, dz = ex - sx, ez - sz
    qx, qz = px - sx, pz - sz
    length2 = dx * dx + dz * dz
    t = min(max((qx * dx + qz * dz) / length2, 0.0), 1.0) if length2 > 0.0 else 0.0
    x, z = qx - t * dx, qz - t * dz
    return math.sqrt(x * x + z * z)


@njit(cache=True)
def _segment_distances(point: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    out = np.empty(len(point))
    for i in range(len(point)):
        out[i] = _point_segment_distance(point[i, 0], point[i, 1], start[i, 0], start[i, 1], end[i, 0], end[i, 1])
    return out


def segment_distance(point: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Distance (n,) from points (n, 2) to the segments ``start``-``end`` (n, 2) (a point if they coincide)."""
    return _segment_distances(*(np.ascontiguousarray(a, dtype=np.float64) for a in (point, start, end)))


@njit(cache=True, nogil=True, error_model="numpy")
def _step_kernel(
    action: np.ndarray,
    position: np.ndarray,
    heading: np.ndarray,
    roll: np.ndarray,
    speed: np.ndarray,
    waypoints: np.ndarray,
    index: np.ndarray,
    c: np.ndarray,
    steer: np.ndarray,
    terms: np.ndarray,
    reward: np.ndarray,
    success: np.ndarray,
    terminated: np.ndarray,
    obs: np.ndarray,
) -> None:
    """The whole step and the next observation, in place on the state arrays (``position`` to ``index``) and
    into the outputs (``steer`` to ``obs``); ``c`` holds the parameters named in ``STEP_CONSTANTS``, in that order.

    Written as passes over the batch that compile to SIMD code (the move with the capture test of the current
    waypoint, the rewards, the observation from the move's sines and cosines of the new headings), with the
    waypoints passed found in a pass over the capturing episodes only. 2-D arrays are read and written through
    flat views, whose fixed row widths let the compiler vectorise the strided accesses."""
    max_speed, max_acceleration, dt, max_yaw_rate = c[0], c[1], c[2], c[3]
    radius, half_size, capture_radius = c[4], c[5], c[6]
    progress_weight, waypoint_bonus, time_penalty, effort_penalty, exit_penalty = c[7], c[8], c[9], c[10], c[11]
    n, n_waypoints = len(action), waypoints.shape[1]
    last = n_waypoints - 1
    dv = max_acceleration * dt
    actions, xz, points, term = action.reshape(-1), position.reshape(-1), waypoints.reshape(-1), terms.reshape(-1)
    # separate allocations: the compiler knows they do not overlap (rows of one array keep the loops slow)
    progress, start_x, start_z, end_x, end_z = scratch(n), scratch(n), scratch(n), scratch(n), scratch(n)
    target_x, target_z, passed, capturing = scratch(n), scratch(n), scratch(n), scratch(n)
    # the new heading's sine and cosine (from the arc's, one sincos fewer) take the targets' place once read: two
    # more arrays written in the first pass kept it from SIMD code, at twice the cost
    sines, cosines = target_x, target_z
    _gather_waypoints(waypoints, index, 0, target_x, target_z)
    for i in range(n):
        command = 0.5 * max_speed * (actions[2 * i] + 1.0)
        v = min(max(command, speed[i] - dv), speed[i] + dv)
        yaw_rate = max_yaw_rate * actions[2 * i + 1]
        sx, sz, tx, tz = xz[2 * i], xz[2 * i + 1], target_x[i], target_z[i]
        ex, ez, heading[i], roll[i], sines[i], cosines[i] = wheel.oriented_arc_step(
            sx, sz, heading[i], roll[i], v, yaw_rate, dt, radius
        )
        ax, az, bx, bz = tx - sx, tz - sz, tx - ex, tz - ez
        progress[i] = math.sqrt(ax * ax + az * az) - math.sqrt(bx * bx + bz * bz)
        capture = (index[i] <= last) & (_point_segment_distance(tx, tz, sx, sz, ex, ez) <= capture_radius)
        capturing[i], passed[i] = 1.0 if capture else 0.0, 0.0
        start_x[i], start_z[i], end_x[i], end_z[i] = sx, sz, ex, ez
        speed[i], steer[i] = v, yaw_rate * dt
    for i in range(n):  # strided stores in a pass of their own
        xz[2 * i], xz[2 * i + 1] = end_x[i], end_z[i]
    for i in range(n):  # the waypoints passed, for the episodes that pass their current one
        if capturing[i] != 0.0:
            k = index[i] + 1
            while k <= last:
                w = 2 * (i * n_waypoints + k)
                if (
                    _point_segment_distance(points[w], points[w + 1], start_x[i], start_z[i], xz[2 * i], xz[2 * i + 1])
                    > capture_radius
                ):
                    break
                k += 1
            passed[i], index[i] = k - index[i], k
    for i in range(n):
        done = index[i] > last
        ex, ez = xz[2 * i], xz[2 * i + 1]
        outside = (abs(ex) > half_size or abs(ez) > half_size) and not done
        t0, t1, t2 = progress_weight * progress[i], waypoint_bonus * passed[i], -time_penalty * dt
        a1 = actions[2 * i + 1]
        t3, t4 = -effort_penalty * dt * (a1 * a1), -exit_penalty if outside else 0.0
        term[5 * i], term[5 * i + 1], term[5 * i + 2], term[5 * i + 3], term[5 * i + 4] = t0, t1, t2, t3, t4
        reward[i] = t0 + t1 + t2 + t3 + t4
        success[i], terminated[i] = done, done or outside
    _observe_oriented(position, sines, cosines, speed, waypoints, index, c, obs)


@njit(cache=True, nogil=True, inline="always")
def _gather_waypoints(waypoints: np.ndarray, index: np.ndarray, ahead: int, x: np.ndarray, z: np.ndarray) -> None:
    """Coordinates (m) of waypoint ``index + ahead`` (the last one past the end) of each episode into ``x``, ``z``:
    a scalar pass of its own, since data-dependent reads keep a loop from SIMD code."""
    last = waypoints.shape[1] - 1
    for i in range(len(index)):
        w = min(index[i] + ahead, last)
        x[i], z[i] = waypoints[i, w, 0], waypoints[i, w, 1]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe(
    position: np.ndarray,
    heading: np.ndarray,
    speed: np.ndarray,
    waypoints: np.ndarray,
    index: np.ndarray,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """Observations (n, 8) written into ``obs``; ``c`` holds the parameters named in ``STEP_CONSTANTS``: the
    heading's sine and cosine in a SIMD pass, then :func:`_observe_oriented`."""
    sines, cosines = scratch(len(heading)), scratch(len(heading))
    for i in range(len(heading)):
        sines[i], cosines[i] = vmath.sincos(heading[i])
    _observe_oriented(position, sines, cosines, speed, waypoints, index, c, obs)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe_oriented(
    position: np.ndarray,
    sines: np.ndarray,
    cosines: np.ndarray,
    speed: np.ndarray,
    waypoints: np.ndarray,
    index: np.ndarray,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """:func:`_observe` from the sines and cosines of the headings. Written as SIMD passes over the batch: per
    shown waypoint (gathered first) its distance and bearing, then speed and progress."""
    max_speed, diagonal = c[0], c[12]
    n, n_waypoints = len(index), waypoints.shape[1]
    per_diagonal, per_max_speed, per_waypoint = 1.0 / diagonal, 1.0 / max_speed, 1.0 / n_waypoints
    xz, out = position.reshape(-1), obs.reshape(-1)
    width = OBS_PER_WAYPOINT * SHOWN_WAYPOINTS + 2
    shown_x, shown_z = scratch(n), scratch(n)
    for j in range(SHOWN_WAYPOINTS):
        _gather_waypoints(waypoints, index, j, shown_x, shown_z)
        for i in range(n):
            dx, dz = shown_x[i] - xz[2 * i], shown_z[i] - xz[2 * i + 1]
            ahead, leftward = dx * sines[i] + dz * cosines[i], dx * cosines[i] - dz * sines[i]
            distance = math.sqrt(ahead * ahead + leftward * leftward)
            per_distance = 1.0 / distance  # one division, where three were slower
            column = width * i + OBS_PER_WAYPOINT * j
            out[column] = min(distance * per_diagonal, 1.0)
            out[column + 1] = min(max(leftward * per_distance, -1.0), 1.0) if distance > 0.0 else 0.0
            out[column + 2] = min(max(ahead * per_distance, -1.0), 1.0) if distance > 0.0 else 1.0
    for i in range(n):
        out[width * i + width - 2] = speed[i] * per_max_speed
        out[width * i + width - 1] = index[i] * per_waypoint


@njit(cache=True, nogil=True, inline="always")
def _start(
    keys: np.ndarray,
    rows: np.ndarray,
    setup_offset: np.uint64,
    extent: float,
    position: np.ndarray,
    heading: np.ndarray,
    roll: np.ndarray,
    speed: np.ndarray,
    waypoints: np.ndarray,
    index: np.ndarray,
) -> None:
    """Fresh episodes of ``keys`` written in place into the rows ``rows`` of the state arrays, as
    ``SteerableWheelTask.initial_state`` draws them (the setup stream's lanes: heading, then the start and the
    waypoints, uniform in ``[-extent, extent]`` m)."""
    n_waypoints = waypoints.shape[1]
    for j in range(len(rows)):
        r = rows[j]
        base = rng.stream_base(keys[j], setup_offset, np.uint64(0))
        heading[r] = np.pi * (2.0 * rng.lane(base, 0) - 1.0)
        position[r, 0] = extent * (2.0 * rng.lane(base, 1) - 1.0)
        position[r, 1] = extent * (2.0 * rng.lane(base, 2) - 1.0)
        for k in range(n_waypoints):
            waypoints[r, k, 0] = extent * (2.0 * rng.lane(base, 3 + 2 * k) - 1.0)
            waypoints[r, k, 1] = extent * (2.0 * rng.lane(base, 4 + 2 * k) - 1.0)
        roll[r], speed[r], index[r] = 0.0, 0.0, 0


@njit(cache=True, nogil=True, error_model="numpy")
def _restart_kernel(
    keys: np.ndarray,
    rows: np.ndarray,
    setup_offset: np.uint64,
    extent: float,
    position: np.ndarray,
    heading: np.ndarray,
    roll: np.ndarray,
    speed: np.ndarray,
    waypoints: np.ndarray,
    index: np.ndarray,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """The next episode of the episodes ``rows`` (:meth:`~vegym.envs.base.Task.restart`): their ``keys`` advanced
    in place, the episodes started (:func:`_start`) and observed (:func:`_observe` over copies of their rows) into
    those rows of ``obs``."""
    m = len(rows)
    next_keys = rng.advance_rows(keys, rows)
    _start(next_keys, rows, setup_offset, extent, position, heading, roll, speed, waypoints, index)
    observed = np.empty((m, obs.shape[1]), np.float32)
    _observe(position[rows], heading[rows], speed[rows], waypoints[rows], index[rows], c, observed)
    for j in range(m):
        obs[rows[j]] = observed[j]


class SteerableWheelTask(Task[SteerableWheelParams]):
    """Batched logic of SteerableWheel-v0 (see :class:`SteerableWheelEnv`)."""

    params_cls = SteerableWheelParams
    renderer = "vegym.render.steerable_wheel:SteerableWheelRenderer"

    def __init__(self, params: SteerableWheelParams) -> None:
        super().__init__(params)
        per_waypoint_low = [0.0, -1.0, -1.0] * SHOWN_WAYPOINTS
        low = np.array([*per_waypoint_low, 0.0, 0.0], np.float32)
        self.observation_space = spaces.Box(low, np.ones_like(low), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self._constants = np.array([getattr(params, name) for name in STEP_CONSTANTS])
        self._setup_offset = rng.stream_offset(_SETUP_STREAM)

    @property
    def control_rate(self) -> float:
        return 1.0 / self.params.dt

    def initial_state(self, keys: np.ndarray) -> State:
        p = self.params
        n = len(keys)
        u = rng.uniform(keys, _SETUP_STREAM, 3 + 2 * p.n_waypoints)
        points = (p.half_size - p.waypoint_margin) * (2.0 * u[:, 1:] - 1.0)
        zeros = np.zeros(n)
        return {
            "position": np.ascontiguousarray(points[:, :2]),
            "heading": np.pi * (2.0 * u[:, 0] - 1.0),
            "roll": zeros,
            "speed": zeros.copy(),
            "waypoints": np.ascontiguousarray(points[:, 2:]).reshape(n, p.n_waypoints, 2),
            "index": np.zeros(n, dtype=np.int64),
        }

    def start(self, state: State, keys: np.ndarray, rows: np.ndarray) -> None:
        _start(
            keys, rows, self._setup_offset, self.params.half_size - self.params.waypoint_margin, state["position"],
            state["heading"], state["roll"], state["speed"], state["waypoints"], state["index"],
        )  # fmt: skip

    def restart_call(self, state: State, rows: np.ndarray, obs: np.ndarray) -> KernelCall | None:
        return _restart_kernel, (
            state["key"], rows, self._setup_offset, self.params.half_size - self.params.waypoint_margin,
            state["position"], state["heading"], state["roll"], state["speed"], state["waypoints"], state["index"],
            self._constants, obs,
        )  # fmt: skip

    def output_shapes(self) -> dict[str, tuple[tuple[int, ...], type]]:
        return {"steer": ((), np.float64), "terms": ((len(REWARD_TERMS),), np.float64), "success": ((), np.bool_)}

    def step_call(self, state: State, action: np.ndarray, out: State) -> KernelCall:
        return _step_kernel, (
            action, state["position"], state["heading"], state["roll"], state["speed"], state["waypoints"],
            state["index"], self._constants, out["steer"], out["terms"], out["reward"], out["success"],
            out["terminated"], out["obs"],
        )  # fmt: skip

    def info(self, state: State, out: State) -> Info:
        return {
            "position": state["position"],
            "heading": state["heading"],
            "roll_angle": state["roll"],
            "speed": state["speed"],
            "steer_increment": out["steer"],
            "radius": self.params.radius,
            "dt": self.params.dt,
            "waypoint_index": state["index"],
            "reward_terms": dict(zip(REWARD_TERMS, out["terms"].T, strict=True)),
            "is_success": out["success"],
        }

    def observe(self, state: State, obs: np.ndarray) -> None:
        _observe(
            state["position"], state["heading"], state["speed"], state["waypoints"], state["index"], self._constants,
            obs,
        )  # fmt: skip


class SteerableWheelEnv(VegymEnv[SteerableWheelParams]):
    """Waypoint driving: steer a rolling wheel through random waypoints, in order, inside a square arena.

    ## Description
    The steerable wheel of the chapter (8.29-8.43, corrected as in PHYSICS.md section 3): a wheel of radius r
    rolls without slipping on the ground plane; over each step of ``dt`` its speed v and yaw rate omega are held,
    and it moves along the exact arc (chord ``v dt sinc(phi/2)`` at the mid-step heading, ``phi = omega dt``),
    turning its roll angle by ``v dt / r``. Heading psi: forward is ``(sin psi, 0, cos psi)`` and positive psi
    turns left (anticlockwise seen from above). The wheel starts at rest and must pass within
    ``capture_radius`` of ``n_waypoints`` waypoints in order without leaving the arena.

    ## Action Space
    ``Box(-1, 1, (2,), float32)``: ``a0`` is the speed command ``(a0 + 1)/2 * max_speed`` in [0, max_speed],
    which the speed follows at up to ``max_acceleration``; ``a1`` is the yaw rate ``a1 * max_yaw_rate``
    (positive: left turn). The speed a step applies is the previous speed moved toward the command by at most
    ``max_acceleration * dt``.

    ## Observation Space
    ``Box(low, 1, (8,), float32)`` in the wheel's own frame: for the current waypoint and the next one (the last
    one repeated once there is no next), the distance over the arena diagonal in [0, 1] (1 beyond it, as after
    leaving the arena) and the sine and cosine of its bearing relative to the heading (positive sine: to the left;
    sine 0 and cosine 1 for a waypoint at the wheel's centre); then the speed over ``max_speed`` in
    [0, 1] and the fraction of waypoints passed in [0, 1]. ``low`` is 0 for distances, speed and progress, -1
    for the sines and cosines.

    ## Rewards
    Named in ``info["reward_terms"]``: ``progress`` (``progress_weight`` times the metres gained toward the
    waypoint that was current at the start of the step), ``waypoint`` (``waypoint_bonus`` per waypoint passed),
    ``time`` (``-time_penalty * dt``), ``effort`` (``-effort_penalty * dt * a1^2``) and ``exit``
    (``-exit_penalty`` on leaving the arena).

    ## Starting State
    At rest, roll angle 0, heading uniform in [-pi, pi); the start position and the waypoints uniform in the
    square ``|x|, |z| <= arena_size / 2 - waypoint_margin``. All drawn from the episode seed.

    ## Episode End
    Terminated when the last waypoint is passed (``info["is_success"]``) or when the wheel's centre leaves the
    arena (``max(|x|, |z|) > arena_size / 2``); truncated after ``max_episode_steps`` steps (400, i.e. 40 s at
    the default dt, when registered). A waypoint is passed when the step's chord (the straight segment from the
    start to the end of the step, within ``max_speed * dt * |phi| / 8`` of the arc) comes within
    ``capture_radius`` of it; several may be passed in one step.

    ## Arguments
    ``gymnasium.make("vegym/SteerableWheel-v0", render_mode=None, **params)`` with the fields of
    :class:`SteerableWheelParams`. ``info`` per step (SI units, radians): ``position`` (x, z of the centre on
    the ground plane), ``heading`` (wrapped to [-pi, pi]), ``roll_angle`` (accumulated), ``speed`` (v applied
    this step), ``steer_increment`` (phi applied this step), ``radius``, ``dt``, ``waypoint_index`` (waypoints
    passed so far), ``reward_terms``, ``is_success``. Reference controller: pure pursuit (``agents.analytic``).

    ## Version History
    * v0: initial version.
    """

    task_cls = SteerableWheelTask


class SteerableWheelVectorEnv(VegymVectorEnv[SteerableWheelParams]):
    """Native vector twin of :class:`SteerableWheelEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = SteerableWheelTask
