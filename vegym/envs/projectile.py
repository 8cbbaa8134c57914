"""Projectile-v0: aim a launcher at a ground target in a constant wind; one step is one shot."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs.base import Info, KernelCall, State, Task, VegymEnv, VegymVectorEnv
from vegym.params import Params, param
from vegym.physics import projectile, vmath
from vegym.physics.columns import scratch
from vegym.physics.particle import STANDARD_GRAVITY
from vegym.physics.projectile import ProjectileParams

ELEVATION_LIMIT = np.pi / 2
"""Elevation actions span [-pi/2, pi/2] (rad): every shot from straight down to straight up."""
AZIMUTH_LIMIT = np.pi / 2
"""Azimuth actions span +-pi/2 (rad) about the bearing of the target."""
_SETUP_STREAM = 1


@dataclass(frozen=True)
class ProjectileEnvParams(Params):
    """Parameters of Projectile-v0 (SI units, radians)."""

    gravity: float = param(STANDARD_GRAVITY, "gravitational acceleration magnitude (m/s^2)", low=0.0, low_open=True)
    radius: float = param(0.05, "projectile radius (m); it lands when its centre reaches y = radius", low=0.0)
    launch_height_min: float = param(1.0, "lowest launch height of the projectile's centre (m)", low=0.0)
    launch_height_max: float = param(20.0, "highest launch height of the projectile's centre (m)", low=0.0)
    target_distance_min: float = param(10.0, "nearest target, horizontal distance (m)", low=0.0, low_open=True)
    target_distance_max: float = param(
        60.0, "farthest target (m); at most the guaranteed range (see reachable_distance)", low=0.0, low_open=True
    )
    wind_speed_max: float = param(5.0, "largest horizontal wind speed (m/s); direction uniform", low=0.0)
    speed_min: float = param(5.0, "slowest launch speed (m/s, relative to the air)", low=0.0)
    speed_max: float = param(30.0, "fastest launch speed (m/s, relative to the air)", low=0.0, low_open=True)
    hit_radius: float = param(
        2.0, "a landing within this horizontal distance of the target is a hit (m)", low=0.0, low_open=True
    )
    hit_bonus: float = param(1.0, "reward for a dead-centre hit; (1 - (miss / hit_radius)^2) of it for a hit", low=0.0)

    def validate(self) -> None:
        if self.launch_height_min < self.radius:
            raise self.between("launch_height_min", "radius", "launch_height_max")
        if self.launch_height_max < self.launch_height_min:
            raise self.between("launch_height_max", "launch_height_min")
        if self.target_distance_min > self.target_distance_max:
            raise self.between("target_distance_min", high="target_distance_max")
        if self.speed_min > self.speed_max:
            raise self.between("speed_min", high="speed_max")
        if self.wind_speed_max >= self.speed_max:
            raise self.between("wind_speed_max", high="speed_max", high_open=True)
        if self.target_distance_max > self.reachable_distance:
            raise self.between(
                "target_distance_max",
                high=(f"reachable_distance = {self.reachable_distance:.4g}", self.reachable_distance),
                reason=f", the range at speed_max - wind_speed_max = {self.speed_max} - {self.wind_speed_max} m/s from "
                f"launch_height_min - radius = {self.launch_height_min} - {self.radius} m under gravity={self.gravity} "
                "m/s^2",
            )

    @property
    def physics(self) -> ProjectileParams:
        """The projectile physics parameters."""
        return self.subset(ProjectileParams)

    @property
    def reachable_distance(self) -> float:
        """Distance (m) every target within which is reachable at ``speed_max`` in any allowed wind.

        The wind-free maximum range at ``speed_max - wind_speed_max`` from the lowest launch height: a ground
        velocity u of that speed reaches the target, and the air-relative launch velocity ``u - w`` then has a
        speed of at most ``speed_max``; a target reachable at some speed is reachable at every higher one.
        """
        return float(
            projectile.max_range(
                self.speed_max - self.wind_speed_max, self.launch_height_min - self.radius, self.physics
            )
        )

    @property
    def wind_scale(self) -> float:
        """Normaliser of the observed wind (m/s)."""
        return self.wind_speed_max if self.wind_speed_max > 0 else 1.0

    @property
    def height_scale(self) -> float:
        """Normaliser of the observed launch height (m)."""
        return max(self.launch_height_max, 1.0)


STEP_CONSTANTS = (
    "launch_height_min",
    "launch_height_max",
    "target_distance_min",
    "target_distance_max",
    "wind_speed_max",
    "speed_min",
    "speed_max",
    "hit_radius",
    "hit_bonus",
    "gravity",
    "radius",
    "height_scale",
    "wind_scale",
)
"""Parameters the kernels read, in the order of their constants array (SI units, radians; see the fields)."""


SHOT_COLUMNS = ("velocity_x", "velocity_y", "velocity_z", "flight_time", "miss_distance", "miss_term", "hit_term")
"""Columns of the step's ``shot`` output: the air-relative launch velocity (m/s), the flight time (s), the horizontal
miss (m) and the reward terms ``miss`` and ``hit``."""


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _start(
    keys: np.ndarray,
    rows: np.ndarray,
    c: np.ndarray,
    offset: np.uint64,
    launch: np.ndarray,
    target: np.ndarray,
    wind: np.ndarray,
    bearing: np.ndarray,
    landing: np.ndarray,
) -> None:
    """Fresh episodes of ``keys`` written in place into the rows ``rows`` of the state arrays ``launch`` to
    ``landing`` ((n, 3), m and m/s, and ``bearing`` (n,), rad; ``landing`` NaN: no shot yet), from 5 uniform lanes
    of each key's setup draw: launch height, target distance and bearing, wind speed and direction. ``c`` holds
    the parameters named in ``STEP_CONSTANTS``.

    Written as a pass over the keys that the compiler turns into SIMD code (the draws, into scratch arrays:
    separate allocations, which the compiler knows apart) and a pass that stores them into the state's rows
    (strided, and scattered)."""
    m = len(keys)
    height, target_x, target_z = scratch(m), scratch(m), scratch(m)
    direction, wind_x, wind_z = scratch(m), scratch(m), scratch(m)
    for j in range(m):
        base = rng.stream_base(keys[j], offset, np.uint64(0))
        height[j] = c[0] + (c[1] - c[0]) * rng.lane(base, 0)
        distance = c[2] + (c[3] - c[2]) * rng.lane(base, 1)
        direction[j] = np.pi * (2.0 * rng.lane(base, 2) - 1.0)
        wind_speed = c[4] * rng.lane(base, 3)
        sin_b, cos_b = vmath.sincos(direction[j])
        sin_w, cos_w = vmath.sincos(np.pi * (2.0 * rng.lane(base, 4) - 1.0))
        target_x[j], target_z[j] = distance * cos_b, distance * sin_b
        wind_x[j], wind_z[j] = wind_speed * cos_w, wind_speed * sin_w
    for j in range(m):
        i = rows[j]
        launch[i, 0], launch[i, 1], launch[i, 2] = 0.0, height[j], 0.0
        target[i, 0], target[i, 1], target[i, 2] = target_x[j], 0.0, target_z[j]
        bearing[i] = direction[j]
        wind[i, 0], wind[i, 1], wind[i, 2] = wind_x[j], 0.0, wind_z[j]
        landing[i, 0], landing[i, 1], landing[i, 2] = np.nan, np.nan, np.nan


@njit(cache=True, nogil=True, error_model="numpy")
def _restart_kernel(
    keys: np.ndarray,
    rows: np.ndarray,
    c: np.ndarray,
    offset: np.uint64,
    launch: np.ndarray,
    target: np.ndarray,
    wind: np.ndarray,
    bearing: np.ndarray,
    landing: np.ndarray,
    obs: np.ndarray,
) -> None:
    """Every episode's next one (:meth:`~vegym.envs.base.Task.restart` of all rows, ``rows`` in any order): their
    ``keys`` advanced in place, the episodes started (:func:`_start`) and observed into ``obs`` (:func:`_observe`)."""
    next_keys = rng.advance_rows(keys, rows)
    _start(next_keys, rows, c, offset, launch, target, wind, bearing, landing)
    _observe(launch, target, wind, bearing, c, obs)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _shoot(
    action: np.ndarray,
    launch: np.ndarray,
    target: np.ndarray,
    wind: np.ndarray,
    bearing: np.ndarray,
    landing: np.ndarray,
    c: np.ndarray,
    shot: np.ndarray,
    success: np.ndarray,
    reward: np.ndarray,
) -> None:
    """Every episode's shot: its landing point (m, centre at y = radius) into the state's ``landing``, the
    ``SHOT_COLUMNS`` into the first columns of ``shot``, the hit flags into ``success`` and the rewards into
    ``reward``. ``bearing`` is the target's (rad); ``c`` holds the parameters named in ``STEP_CONSTANTS``.

    Written as a pass over the batch that the compiler turns into SIMD code (the shot, into 1-d scratch arrays:
    separate allocations, since the compiler must check each written array against each read one; 2-d arrays
    through flat views, whose constant row widths keep the SIMD path) and a pass for the reward terms and the
    strided stores."""
    target_distance_max, speed_min, speed_max, hit_radius, hit_bonus, gravity, radius = (
        c[3], c[5], c[6], c[7], c[8], c[9], c[10]
    )  # fmt: skip
    n, width = len(action), shot.shape[1]
    a, p, t, w = action.reshape(-1), launch.reshape(-1), target.reshape(-1), wind.reshape(-1)
    vx, vy, vz, flight_time = scratch(n), scratch(n), scratch(n), scratch(n)
    x, z, miss = scratch(n), scratch(n), scratch(n)
    for i in range(n):
        speed = speed_min + 0.5 * (a[3 * i + 2] + 1.0) * (speed_max - speed_min)
        d = projectile.direction_one(ELEVATION_LIMIT * a[3 * i], bearing[i] + AZIMUTH_LIMIT * a[3 * i + 1])
        vx[i], vy[i], vz[i] = speed * d[0], speed * d[1], speed * d[2]
        x[i], z[i], flight_time[i] = projectile.landing_one(
            (p[3 * i], p[3 * i + 1], p[3 * i + 2]), (vx[i], vy[i], vz[i]), (w[3 * i], w[3 * i + 1], w[3 * i + 2]),
            gravity, radius,
        )  # fmt: skip
        mx, mz = x[i] - t[3 * i], z[i] - t[3 * i + 2]
        miss[i] = math.sqrt(mx * mx + mz * mz)
    landed, columns = landing.reshape(-1), shot.reshape(-1)
    for i in range(n):
        hit = miss[i] <= hit_radius
        miss_term = -miss[i] / target_distance_max
        hit_term = hit_bonus * (1.0 - (miss[i] / hit_radius) ** 2) if hit else 0.0
        success[i], reward[i] = hit, miss_term + hit_term
        landed[3 * i], landed[3 * i + 1], landed[3 * i + 2] = x[i], radius, z[i]
        row = width * i
        columns[row], columns[row + 1], columns[row + 2], columns[row + 3] = vx[i], vy[i], vz[i], flight_time[i]
        columns[row + 4], columns[row + 5], columns[row + 6] = miss[i], miss_term, hit_term


@njit(cache=True, nogil=True, error_model="numpy")
def _step_kernel(
    action: np.ndarray,
    launch: np.ndarray,
    target: np.ndarray,
    wind: np.ndarray,
    bearing: np.ndarray,
    landing: np.ndarray,
    c: np.ndarray,
    shot: np.ndarray,
    success: np.ndarray,
    reward: np.ndarray,
    terminated: np.ndarray,
    obs: np.ndarray,
) -> None:
    """One shot per episode (:func:`_shoot`) and the next observation, in place on the state's ``landing`` and
    into the outputs (``shot`` to ``obs``); every episode terminates. ``c`` holds the parameters named in
    ``STEP_CONSTANTS``."""
    _shoot(action, launch, target, wind, bearing, landing, c, shot, success, reward)
    terminated[:] = True
    _observe(launch, target, wind, bearing, c, obs)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe(
    launch: np.ndarray, target: np.ndarray, wind: np.ndarray, bearing: np.ndarray, c: np.ndarray, obs: np.ndarray
) -> None:
    """Observations (n, 4) into ``obs``, in the target frame (:meth:`ProjectileTask.target_frame`) of the
    target's ``bearing`` (rad); ``c`` holds the parameters named in ``STEP_CONSTANTS``. Written as a pass over
    the batch that the compiler turns into SIMD code, through flat views."""
    target_distance_max, height_scale, wind_scale = c[3], c[11], c[12]
    p, t, w, out = launch.reshape(-1), target.reshape(-1), wind.reshape(-1), obs.reshape(-1)
    for i in range(len(bearing)):
        dx, dz = t[3 * i] - p[3 * i], t[3 * i + 2] - p[3 * i + 2]
        sin_b, cos_b = vmath.sincos(bearing[i])
        out[4 * i] = math.sqrt(dx * dx + dz * dz) / target_distance_max
        out[4 * i + 1] = p[3 * i + 1] / height_scale
        # the wind is horizontal; held to the box against rounding: a subnormal wind_speed_max (5e-324, allowed)
        # rounds the wind's components to its multiples, and their turn into the target frame observed 2.0
        out[4 * i + 2] = min(max((w[3 * i] * cos_b + w[3 * i + 2] * sin_b) / wind_scale, -1.0), 1.0)
        out[4 * i + 3] = min(max((w[3 * i] * -sin_b + w[3 * i + 2] * cos_b) / wind_scale, -1.0), 1.0)


@njit(cache=True, nogil=True, error_model="numpy")
def _observe_kernel(
    launch: np.ndarray, target: np.ndarray, wind: np.ndarray, bearing: np.ndarray, c: np.ndarray, obs: np.ndarray
) -> None:
    """Observations (n, 4) into ``obs`` (:func:`_observe`)."""
    _observe(launch, target, wind, bearing, c, obs)


class ProjectileTask(Task[ProjectileEnvParams]):
    """Batched logic of Projectile-v0 (see :class:`ProjectileEnv`)."""

    params_cls = ProjectileEnvParams
    renderer = "vegym.render.projectile:ProjectileRenderer"
    episode_constants = ("launch_position", "target", "wind")

    def __init__(self, params: ProjectileEnvParams) -> None:
        super().__init__(params)
        self.observation_space = spaces.Box(
            np.array([0, 0, -1, -1], np.float32), np.array([1, 1, 1, 1], np.float32), dtype=np.float32
        )
        self.action_space = spaces.Box(-1.0, 1.0, (3,), np.float32)
        self._constants = np.array([getattr(params, name) for name in STEP_CONSTANTS], dtype=np.float64)
        self._offset = rng.stream_offset(_SETUP_STREAM)

    @property
    def control_rate(self) -> float:
        return 1.0

    def initial_state(self, keys: np.ndarray) -> State:
        n = len(keys)
        state = {name: np.empty((n, 3)) for name in ("launch_position", "target", "wind", "landing_point")}
        state["bearing"] = np.empty(n)
        self.start(state, np.ascontiguousarray(keys, dtype=np.uint64), np.arange(n))
        return state

    def start(self, state: State, keys: np.ndarray, rows: np.ndarray) -> None:
        _start(
            keys, rows, self._constants, self._offset, state["launch_position"], state["target"], state["wind"],
            state["bearing"], state["landing_point"],
        )  # fmt: skip

    def restart_call(self, state: State, rows: np.ndarray, obs: np.ndarray) -> KernelCall | None:
        if len(rows) < len(obs):  # some rows (sub-envs that ended while others go on): observed by rows
            return None
        return _restart_kernel, (
            state["key"], rows, self._constants, self._offset, state["launch_position"], state["target"],
            state["wind"], state["bearing"], state["landing_point"], obs,
        )  # fmt: skip

    @staticmethod
    def target_bearing(launch_position: np.ndarray, target: np.ndarray) -> np.ndarray:
        """Book azimuth (rad, from +x toward +z) of each target (n, 3) seen from its launcher (n, 3), by numpy's
        ``arctan2``: within an ulp or so of the state's ``bearing``, the drawn one at which the target was placed."""
        return np.arctan2(target[:, 2] - launch_position[:, 2], target[:, 0] - launch_position[:, 0])

    @staticmethod
    def target_frame(state: State) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Horizontal distance (n,), bearing (n,) and unit vectors (n, 3) along and across the line of fire.

        The bearing is the book azimuth of the target (from +x toward +z); "across" is the direction of
        increasing azimuth, so a relative azimuth ``delta`` fires along ``cos(delta) along + sin(delta) across``.
        """
        offset = state["target"] - state["launch_position"]
        distance = np.hypot(offset[:, 0], offset[:, 2])
        bearing = ProjectileTask.target_bearing(state["launch_position"], state["target"])
        cos_b, sin_b = np.cos(bearing), np.sin(bearing)
        frame = np.zeros((2, *bearing.shape, 3))
        frame[0, ..., 0], frame[0, ..., 2] = cos_b, sin_b
        frame[1, ..., 0], frame[1, ..., 2] = -sin_b, cos_b
        return distance, bearing, frame

    def output_shapes(self) -> dict[str, tuple[tuple[int, ...], type]]:
        return {"shot": ((len(SHOT_COLUMNS),), np.float64), "success": ((), np.bool_)}

    def step_call(self, state: State, action: np.ndarray, out: State) -> KernelCall:
        return _step_kernel, (
            action, state["launch_position"], state["target"], state["wind"], state["bearing"],
            state["landing_point"], self._constants, out["shot"], out["success"], out["reward"], out["terminated"],
            out["obs"],
        )  # fmt: skip

    def info(self, state: State, out: State) -> Info:
        shot = out["shot"]
        return {
            "launch_position": state["launch_position"],
            "launch_velocity": shot[:, 0:3],
            "wind": state["wind"],
            "gravity": self.params.gravity,
            "landing_point": state["landing_point"],
            "flight_time": shot[:, 3],
            "target": state["target"],
            "miss_distance": shot[:, 4],
            "reward_terms": {"miss": shot[:, 5], "hit": shot[:, 6]},
            "is_success": out["success"],
        }

    def observe(self, state: State, obs: np.ndarray) -> None:
        _observe_kernel(
            state["launch_position"], state["target"], state["wind"], state["bearing"], self._constants, obs
        )


class ProjectileEnv(VegymEnv[ProjectileEnvParams]):
    """Aiming: fire a projectile from a raised launcher so that it lands on a ground target, in a wind.

    ## Description
    The projectile of the chapter (8.63-8.71) with the cross-wind remark completed (PHYSICS.md section 6):
    a constant horizontal wind w drifts the projectile, ``p(t) = p0 + (v0 d + w) t + 1/2 g_vec t^2``, and the
    shot ends at the exact time its centre reaches ``y = radius``. The launcher stands at ``(0, h, 0)``; the
    target lies on the ground at a random bearing and distance; the wind is random and observed. One step
    is one shot.

    ## Action Space
    ``Box(-1, 1, (3,), float32)``: elevation ``a0 * pi/2`` above the horizon, azimuth ``a1 * pi/2`` relative
    to the bearing of the target (positive toward increasing book azimuth, i.e. from +x toward +z), and
    launch speed ``speed_min + (a2 + 1)/2 * (speed_max - speed_min)`` relative to the air.

    ## Observation Space
    ``Box([0, 0, -1, -1], [1, 1, 1, 1], float32)``, in the target's frame: horizontal distance to the target
    over ``target_distance_max``, launch height over ``max(launch_height_max, 1 m)``, and the wind components
    along and across the line of fire over ``wind_speed_max`` (or 1 m/s without wind).

    ## Rewards
    ``-miss / target_distance_max`` (term ``miss``) plus, for a landing within ``hit_radius`` of the target,
    ``hit_bonus * (1 - (miss / hit_radius)^2)`` (term ``hit``: full at the centre, zero at the rim, so the
    reward is continuous and sharpest near the target); ``miss`` is the horizontal distance.

    ## Starting State
    Launch height, target distance, target bearing, wind speed and wind direction uniform in their ranges.
    Reachable envelope: every target is reachable at ``speed_max``, since ``target_distance_max`` must not
    exceed ``reachable_distance``, the wind-free maximum range at ``speed_max - wind_speed_max`` from the
    lowest launch height (with the defaults 64.7 m >= 60 m).

    ## Episode End
    Terminated after the shot (one step). The registered time limit of one step reports ``truncated`` on that
    step too (Gymnasium's TimeLimit, as the native vector env); ``terminated`` is the end that counts: no state
    follows the shot to bootstrap from (SB3 reads it so). ``info["is_success"]``: the shot is a hit.

    ## Arguments
    ``gymnasium.make("vegym/Projectile-v0", render_mode=None, **params)`` with the fields of
    :class:`ProjectileEnvParams`. ``info``: ``launch_position``, ``launch_velocity`` (air-relative),
    ``wind``, ``gravity``, ``landing_point`` (centre at contact, y = radius), ``flight_time``, ``target``,
    ``miss_distance`` (all SI, y up), ``reward_terms``, ``is_success``. Reference controller: the
    quartic firing solution at ``speed_max``, low-angle (direct fire) root (``agents.analytic``).

    ## Version History
    * v0: initial version.
    """

    task_cls = ProjectileTask


class ProjectileVectorEnv(VegymVectorEnv[ProjectileEnvParams]):
    """Native vector twin of :class:`ProjectileEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = ProjectileTask
