"""SteerableWheel-v0: drive a rolling, steerable wheel through random waypoints in order."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from vegym import rng
from vegym.envs.base import State, Task, Transition, VegymEnv, VegymVectorEnv
from vegym.params import Params, invalid, param
from vegym.physics import wheel
from vegym.physics.wheel import Pose, WheelParams

_SETUP_STREAM = 1
OBS_PER_WAYPOINT = 3
"""Observation entries per shown waypoint: normalised distance, sin and cos of the relative bearing."""
SHOWN_WAYPOINTS = 2
"""The current waypoint and the one after it are observed."""


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
        if not self.waypoint_margin < 0.5 * self.arena_size:
            raise invalid("waypoint_margin", self.waypoint_margin, f"[0, arena_size / 2 = {0.5 * self.arena_size:g})")
        if not self.capture_radius < 0.5 * self.arena_size:
            raise invalid("capture_radius", self.capture_radius, f"[0, arena_size / 2 = {0.5 * self.arena_size:g})")

    @property
    def wheel(self) -> WheelParams:
        """The wheel's physical parameters."""
        return WheelParams(radius=self.radius)

    @property
    def half_size(self) -> float:
        """Half the arena side (m): the wheel leaves the arena when ``max(|x|, |z|) > half_size``."""
        return 0.5 * self.arena_size

    @property
    def diagonal(self) -> float:
        """Arena diagonal (m): the largest distance between two points of the arena, the distance scale."""
        return float(np.sqrt(2.0) * self.arena_size)


def segment_distance(point: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Distance (n,) from points (n, 2) to the segments ``start``-``end`` (n, 2) (a point if they coincide)."""
    sx, sz = end[:, 0] - start[:, 0], end[:, 1] - start[:, 1]
    px, pz = point[:, 0] - start[:, 0], point[:, 1] - start[:, 1]
    length2 = sx * sx + sz * sz
    t = np.divide(px * sx + pz * sz, length2, out=np.zeros_like(length2), where=length2 > 0)
    np.clip(t, 0.0, 1.0, out=t)
    return np.hypot(px - t * sx, pz - t * sz)


class SteerableWheelTask(Task[SteerableWheelParams]):
    """Batched logic of SteerableWheel-v0 (see :class:`SteerableWheelEnv`)."""

    params_cls = SteerableWheelParams
    renderer = "vegym.render.steerable_wheel:SteerableWheelRenderer"

    def __init__(self, params: SteerableWheelParams) -> None:
        super().__init__(params)
        self.wheel = params.wheel
        per_waypoint_low = [0.0, -1.0, -1.0] * SHOWN_WAYPOINTS
        low = np.array([*per_waypoint_low, 0.0, 0.0], np.float32)
        self.observation_space = spaces.Box(low, np.ones_like(low), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)

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
            "position": points[:, :2],
            "heading": np.pi * (2.0 * u[:, 0] - 1.0),
            "roll": zeros,
            "speed": zeros.copy(),
            "waypoints": points[:, 2:].reshape(n, p.n_waypoints, 2),
            "index": np.zeros(n, dtype=np.int64),
        }

    def step(self, state: State, action: np.ndarray) -> Transition:
        p = self.params
        n = len(action)
        command = 0.5 * p.max_speed * (action[:, 0] + 1.0)
        dv = p.max_acceleration * p.dt
        speed = np.clip(command, state["speed"] - dv, state["speed"] + dv)
        yaw_rate = p.max_yaw_rate * action[:, 1]
        start = state["position"]
        pose = Pose(start[:, 0], start[:, 1], state["heading"], state["roll"])
        pose = wheel.steer_step(pose, speed, yaw_rate, p.dt, self.wheel)
        end = np.stack([pose.x, pose.z], axis=-1)

        waypoints, last = state["waypoints"], p.n_waypoints - 1
        target = waypoints[np.arange(n), np.minimum(state["index"], last)]
        progress = np.hypot(*(target - start).T) - np.hypot(*(target - end).T)
        passing = (state["index"] <= last) & (segment_distance(target, start, end) <= p.capture_radius)
        index = state["index"] + passing
        chained = np.flatnonzero(passing & (index <= last))
        while chained.size:
            following = waypoints[chained, index[chained]]
            chained = chained[segment_distance(following, start[chained], end[chained]) <= p.capture_radius]
            index[chained] += 1
            chained = chained[index[chained] <= last]
        passed = index - state["index"]

        success = index > last
        outside = ((np.abs(pose.x) > p.half_size) | (np.abs(pose.z) > p.half_size)) & ~success
        terms = {
            "progress": p.progress_weight * progress,
            "waypoint": p.waypoint_bonus * passed,
            "time": np.full(n, -p.time_penalty * p.dt),
            "effort": -p.effort_penalty * p.dt * action[:, 1] ** 2,
            "exit": np.where(outside, -p.exit_penalty, 0.0),
        }
        new_state = {
            **state,
            "position": end,
            "heading": pose.heading,
            "roll": pose.roll,
            "speed": speed,
            "index": index,
        }
        info = {
            "position": end,
            "heading": pose.heading,
            "roll_angle": pose.roll,
            "speed": speed,
            "steer_increment": yaw_rate * p.dt,
            "radius": np.full(n, p.radius),
            "dt": np.full(n, p.dt),
            "waypoint_index": index,
            "reward_terms": terms,
            "is_success": success,
        }
        reward = terms["progress"] + terms["waypoint"] + terms["time"] + terms["effort"] + terms["exit"]
        return Transition(new_state, reward, success | outside, info)

    def observe(self, state: State) -> np.ndarray:
        p = self.params
        index, position, heading = state["index"], state["position"], state["heading"]
        n = len(index)
        rows = np.arange(n)
        sin_h, cos_h = np.sin(heading), np.cos(heading)
        obs = np.empty((n, OBS_PER_WAYPOINT * SHOWN_WAYPOINTS + 2), np.float32)
        for j in range(SHOWN_WAYPOINTS):
            waypoint = state["waypoints"][rows, np.minimum(index + j, p.n_waypoints - 1)]
            dx, dz = waypoint[:, 0] - position[:, 0], waypoint[:, 1] - position[:, 1]
            ahead, leftward = dx * sin_h + dz * cos_h, dx * cos_h - dz * sin_h
            distance = np.hypot(ahead, leftward)
            away = distance > 0
            column = OBS_PER_WAYPOINT * j
            obs[:, column] = np.minimum(distance / p.diagonal, 1.0)
            obs[:, column + 1] = np.clip(np.divide(leftward, distance, out=np.zeros(n), where=away), -1.0, 1.0)
            obs[:, column + 2] = np.clip(np.divide(ahead, distance, out=np.ones(n), where=away), -1.0, 1.0)
        obs[:, -2] = state["speed"] / p.max_speed
        obs[:, -1] = index / p.n_waypoints
        return obs


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
    one repeated once there is no next), the distance over the arena diagonal in [0, 1] and the sine and cosine
    of its bearing relative to the heading (positive sine: to the left); then the speed over ``max_speed`` in
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
