"""Billiards-v0: strike ball A into ball B at rest so that B slides to rest on a target (oblique impact, 8.3)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs.base import Info, KernelCall, State, Task, VegymEnv, VegymVectorEnv
from vegym.params import Params, param
from vegym.physics import collision, vmath
from vegym.physics.columns import scratch

_SETUP_STREAM = 1


@dataclass(frozen=True)
class BilliardsParams(Params):
    """Parameters of Billiards-v0 (SI units, radians; positions on the table plane as (x, z))."""

    mass_a: float = param(0.17, "mass of ball A, the one struck by the agent (kg)", low=0.0, low_open=True)
    mass_b: float = param(0.17, "mass of ball B, the object ball, at rest (kg)", low=0.0, low_open=True)
    radius_a: float = param(0.028575, "radius of ball A (m)", low=0.0, low_open=True)
    radius_b: float = param(0.028575, "radius of ball B (m)", low=0.0, low_open=True)
    restitution: float = param(0.95, "coefficient of restitution e of the impact", low=0.0, high=1.0)
    deceleration: float = param(
        0.3, "rolling resistance of the cloth: constant deceleration of a moving ball (m/s^2)", low=0.0, low_open=True
    )
    ball_distance_min: float = param(0.3, "nearest start of B from A, centre to centre (m)", low=0.0, low_open=True)
    ball_distance_max: float = param(1.2, "farthest start of B from A, centre to centre (m)", low=0.0, low_open=True)
    target_distance_min: float = param(0.3, "nearest target from B's centre (m)", low=0.0, low_open=True)
    target_distance_max: float = param(1.2, "farthest target from B's centre (m)", low=0.0, low_open=True)
    bearing_max: float = param(
        1.0, "largest angle between the line A-B and the direction from B to the target (rad)", low=0.0, high=1.5
    )
    target_radius: float = param(0.08, "B resting within this distance of the target's centre is a hit (m)", low=0.0)
    speed_max: float = param(3.0, "fastest strike of A (m/s)", low=0.0, low_open=True)
    hit_bonus: float = param(1.0, "reward added for a hit", low=0.0)

    def validate(self) -> None:
        if not self.ball_distance_min > self.contact_distance:
            contact = (f"radius_a + radius_b = {self.contact_distance:g}", self.contact_distance)
            raise self.between("ball_distance_min", contact, "ball_distance_max", low_open=True)
        if self.ball_distance_min > self.ball_distance_max:
            raise self.between("ball_distance_min", high="ball_distance_max")
        if self.target_distance_min > self.target_distance_max:
            raise self.between("target_distance_min", high="target_distance_max")
        if not self.bearing_max < self.largest_bearing:
            largest = f"acos((radius_a + radius_b) / ball_distance_min) = {self.largest_bearing:.6g}"
            raise self.between("bearing_max", high=(largest, self.largest_bearing), high_open=True)
        if not self.required_speed <= self.speed_max:
            depends = (
                "restitution", "mass_a", "mass_b", "radius_a", "radius_b", "deceleration",
                "ball_distance_min", "ball_distance_max", "target_distance_max", "bearing_max",
            )  # fmt: skip
            raise self.between(
                "speed_max",
                (f"required_speed = {self.required_speed:.4g}", self.required_speed),
                reason=f": the strike the farthest target at bearing_max needs (with {self.named(*depends)}); raise "
                "speed_max or ease those",
            )

    @property
    def contact_distance(self) -> float:
        """``R = r_a + r_b`` (m): the balls touch when their centres are this far apart."""
        return self.radius_a + self.radius_b

    @property
    def largest_bearing(self) -> float:
        """Bound (rad) on ``bearing_max``: B sent at this angle off the line A-B needs a 90-degree cut when B starts
        nearest, at ``ball_distance_min``. (The ghost point ``G = (D - R cos b, -R sin b)`` makes the cut's cosine
        ``(D cos b - R) / |G|``, positive while ``D cos b > R``.)"""
        return math.acos(self.contact_distance / self.ball_distance_min)

    @property
    def required_speed(self) -> float:
        """Fastest strike (m/s) the ghost-ball shot of any episode needs (finite below :attr:`largest_bearing`).

        The squared speed grows with the bearing and the target distance and is convex in the ball distance (it
        is ``1 / cos^2`` of a cut angle convex in it, plus the path length, also convex), so the worst case is at
        the largest bearing and target distance and at one end of the ball-distance range.
        """
        distances = np.array([self.ball_distance_min, self.ball_distance_max])
        bearing = np.full(2, self.bearing_max)
        _, speed = ghost_ball_shot(distances, np.full(2, self.target_distance_max), bearing, self)
        return float(np.max(speed))


def ghost_ball_shot(
    ball_distance: np.ndarray, target_distance: np.ndarray, bearing: np.ndarray, params: BilliardsParams
) -> tuple[np.ndarray, np.ndarray]:
    """The ghost-ball strike (PHYSICS.md section 5): cut sine (n,) and strike speed (m/s, (n,)).

    In the frame of the line A-B (A at the origin, B at ``(D_ab, 0)``) the target lies ``target_distance`` from B
    at ``bearing``, so B must leave along ``d* = (cos, sin)(bearing)`` at the speed ``u_b = sqrt(2 a D)`` that
    slides it exactly there. A aims at the ghost point ``G = c_b - R d*``, a path of length ``|G|``, and meets B
    at the cut angle ``phi`` between its path and ``d*``; the line-of-centres part of the impact (8.60) then asks
    for ``v_impact = u_b (m_a + m_b) / ((1 + e) m_a cos(phi))``, and the cloth for the strike speed
    ``sqrt(v_impact^2 + 2 a |G|)``. Non-finite speed where ``phi`` reaches 90 degrees.
    """
    p = params
    d = np.asarray(ball_distance, dtype=np.float64)
    direction = np.stack([np.cos(bearing), np.sin(bearing)], axis=-1)
    ghost = collision.ghost_point(np.stack([d, np.zeros_like(d)], axis=-1), direction, p.contact_distance)
    path = np.linalg.norm(ghost, axis=-1)
    aim = ghost / path[:, None]
    cos_cut = np.einsum("ij,ij->i", aim, direction)
    sin_cut = aim[:, 0] * direction[:, 1] - aim[:, 1] * direction[:, 0]
    rebound = np.sqrt(2.0 * p.deceleration * np.asarray(target_distance, dtype=np.float64))
    with np.errstate(divide="ignore"):
        impact = rebound * (p.mass_a + p.mass_b) / ((1.0 + p.restitution) * p.mass_a * cos_cut)
    speed = np.where(cos_cut > 0.0, collision.launch_speed(impact, path, p.deceleration), np.inf)
    return sin_cut, speed


STEP_CONSTANTS = (
    "contact_distance",
    "speed_max",
    "deceleration",
    "mass_a",
    "mass_b",
    "restitution",
    "target_radius",
    "target_distance_min",
    "target_distance_max",
    "hit_bonus",
    "ball_distance_min",
    "ball_distance_max",
    "bearing_max",
)
"""Parameters the kernels read, in the order of their constants array (SI units, radians; see the fields)."""


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _start(
    keys: np.ndarray,
    rows: np.ndarray,
    c: np.ndarray,
    offset: np.uint64,
    ball_a: np.ndarray,
    ball_b: np.ndarray,
    target: np.ndarray,
) -> None:
    """Fresh episodes of ``keys`` written in place into the rows ``rows`` of ``ball_a`` (the origin), ``ball_b``
    and ``target`` ((n, 2), m), from 4 uniform lanes of each key's setup draw: distance A-B, bearing of B,
    distance of the target from B and its bearing off the line A-B. ``c`` holds the parameters named in
    ``STEP_CONSTANTS``. Written as a pass over the keys that the compiler turns into SIMD code (the draws, into
    scratch arrays: separate allocations, which the compiler knows apart) and a pass that stores them into the
    state's rows (strided, and scattered)."""
    target_distance_min, target_distance_max, ball_distance_min, ball_distance_max, bearing_max = (
        c[7], c[8], c[10], c[11], c[12]
    )  # fmt: skip
    m = len(keys)
    b_x, b_z, target_x, target_z = scratch(m), scratch(m), scratch(m), scratch(m)
    for j in range(m):
        base = rng.stream_base(keys[j], offset, np.uint64(0))
        distance = ball_distance_min + (ball_distance_max - ball_distance_min) * rng.lane(base, 0)
        line = np.pi * (2.0 * rng.lane(base, 1) - 1.0)
        target_distance = target_distance_min + (target_distance_max - target_distance_min) * rng.lane(base, 2)
        leave = line + bearing_max * (2.0 * rng.lane(base, 3) - 1.0)
        sin_line, cos_line = vmath.sincos(line)
        sin_leave, cos_leave = vmath.sincos(leave)
        bx, bz = distance * cos_line, distance * sin_line
        b_x[j], b_z[j] = bx, bz
        target_x[j], target_z[j] = bx + target_distance * cos_leave, bz + target_distance * sin_leave
    for j in range(m):
        i = rows[j]
        ball_a[i, 0], ball_a[i, 1] = 0.0, 0.0
        ball_b[i, 0], ball_b[i, 1] = b_x[j], b_z[j]
        target[i, 0], target[i, 1] = target_x[j], target_z[j]


@njit(cache=True, nogil=True, error_model="numpy")
def _restart_kernel(
    keys: np.ndarray,
    rows: np.ndarray,
    c: np.ndarray,
    offset: np.uint64,
    ball_a: np.ndarray,
    ball_b: np.ndarray,
    target: np.ndarray,
    obs: np.ndarray,
) -> None:
    """Every episode's next one (:meth:`~vegym.envs.base.Task.restart` of all rows, ``rows`` in any order): their
    ``keys`` advanced in place, the episodes started (:func:`_start`) and observed into ``obs`` (:func:`_observe`)."""
    next_keys = rng.advance_rows(keys, rows)
    _start(next_keys, rows, c, offset, ball_a, ball_b, target)
    _observe(ball_a, ball_b, target, c, obs)


SHOT_COLUMNS = (
    "strike_velocity_x",
    "strike_velocity_z",
    "contact_point_x",
    "contact_point_z",
    "velocity_a_x",
    "velocity_a_z",
    "velocity_b_x",
    "velocity_b_z",
    "rest_a_x",
    "rest_a_z",
    "rest_b_x",
    "rest_b_z",
    "closing_speed",
    "energy_lost",
    "duration",
    "miss_distance",
    "miss_term",
    "hit_term",
)
"""Columns of the step's ``shot`` output (SI units, vectors (x, z); see ``info`` in :class:`BilliardsEnv`)."""
FLAG_COLUMNS = ("contact", "success")
"""Columns of the step's ``flags`` output: A reached B, B rests on the target."""


@njit(cache=True, nogil=True, error_model="numpy")
def _step_kernel(
    action: np.ndarray,
    ball_a: np.ndarray,
    ball_b: np.ndarray,
    target: np.ndarray,
    c: np.ndarray,
    shot: np.ndarray,
    flags: np.ndarray,
    reward: np.ndarray,
    terminated: np.ndarray,
    obs: np.ndarray,
) -> None:
    """One strike per episode (the scalar kernels of :mod:`vegym.physics.collision`) and the next observation,
    into the outputs: ``shot`` (n, 18) the ``SHOT_COLUMNS``, ``flags`` (n, 2) the ``FLAG_COLUMNS``, ``reward``,
    ``terminated`` (every episode) and ``obs``. The state (the balls' and the target's start) is unchanged; ``c``
    holds the parameters named in ``STEP_CONSTANTS``. A's strike turns clockwise from the line A-B by the angle
    whose sine is the cut offset over the distance A-B, ``s = a0 R / D_ab``: its sine is ``-s`` and its cosine
    ``sqrt(1 - s^2)``.

    Written as passes over the batch that the compiler turns into SIMD code: the strike, the impact, the slides
    (each into a few scratch arrays of its own: more would need too many run-time overlap checks for SIMD code),
    the reward and flags, and the observation; then a scalar pass stores the rows of ``shot`` (strided)."""
    contact_distance, speed_max, deceleration, mass_a, mass_b, restitution = c[0], c[1], c[2], c[3], c[4], c[5]
    target_radius, target_distance_max, hit_bonus = c[6], c[8], c[9]
    n = len(action)
    # The (n, 2) arrays as flat views, read and written at 2 i and 2 i + 1: the compiler's SIMD code for
    # ``x[i, k]`` runs only where the row length, known at run time only, is 1 (it versions the loop on that).
    a, b, t, u = ball_a.reshape(-1), ball_b.reshape(-1), target.reshape(-1), action.reshape(-1)
    aim_x, aim_z, travel, impact, contact = scratch(n), scratch(n), scratch(n), scratch(n), np.empty(n, np.bool_)
    for i in range(n):  # A's strike: its direction, the distance it slides and its speed at the impact
        ax, az, bx, bz = a[2 * i], a[2 * i + 1], b[2 * i], b[2 * i + 1]
        ox, oz = bx - ax, bz - az
        square = ox * ox + oz * oz
        distance = math.sqrt(square)
        along_x, along_z = ox / distance, oz / distance
        cut = u[2 * i] * contact_distance / distance
        sin_t, cos_t = -cut, math.sqrt(max(1.0 - cut * cut, 0.0))  # |cut| <= R / D_ab < 1: max for SIMD (sqrt >= 0)
        dx, dz = cos_t * along_x + sin_t * -along_z, cos_t * along_z + sin_t * along_x
        speed = 0.5 * (u[2 * i + 1] + 1.0) * speed_max
        stop = speed * speed / (2.0 * deceleration)
        along = dx * ox + dz * oz
        offset_x, offset_z = ox - along * dx, oz - along * dz
        reach = collision.contact_one(along, offset_x * offset_x + offset_z * offset_z, contact_distance)
        touch = reach <= stop
        aim_x[i], aim_z[i], contact[i] = dx, dz, touch
        impact[i] = collision.speed_after_one(speed, reach, deceleration) if touch else 0.0
        travel[i] = reach if touch else stop
    after_a_x, after_a_z, after_b_x, after_b_z = scratch(n), scratch(n), scratch(n), scratch(n)
    closing = scratch(n)
    for i in range(n):  # the impact at A's centre ``p``
        bx, bz, dx, dz, v = b[2 * i], b[2 * i + 1], aim_x[i], aim_z[i], impact[i]
        px, pz = a[2 * i] + travel[i] * dx, a[2 * i + 1] + travel[i] * dz
        gap = math.sqrt((bx - px) * (bx - px) + (bz - pz) * (bz - pz))
        # A's centre on B's, in coordinates spaced wider than the balls are small (radii of 1e-9 m a million km
        # out): head-on along the strike, where the line of centres (0 / 0) gave NaN
        nx, nz = ((bx - px) / gap, (bz - pz) / gap) if gap > 0.0 else (dx, dz)
        strike_x, strike_z = v * dx, v * dz
        impulse = collision.impulse_one(strike_x * nx + strike_z * nz, mass_a, mass_b, restitution)  # B at rest
        after_a_x[i], after_a_z[i] = strike_x - impulse / mass_a * nx, strike_z - impulse / mass_a * nz
        after_b_x[i], after_b_z[i] = 0.0 + impulse / mass_b * nx, 0.0 + impulse / mass_b * nz
        closing[i] = v * (dx * ((bx - px) / contact_distance) + dz * ((bz - pz) / contact_distance))
    factor_a, factor_b, duration, miss = scratch(n), scratch(n), scratch(n), scratch(n)
    for i in range(n):  # the balls' slides to rest
        ua_x, ua_z, ub_x, ub_z = after_a_x[i], after_a_z[i], after_b_x[i], after_b_z[i]
        factor_a[i], _, time_a = collision.slide_one(ua_x * ua_x + ua_z * ua_z, deceleration)
        factor_b[i], _, time_b = collision.slide_one(ub_x * ub_x + ub_z * ub_z, deceleration)
        mx, mz = b[2 * i] + ub_x * factor_b[i] - t[2 * i], b[2 * i + 1] + ub_z * factor_b[i] - t[2 * i + 1]
        miss[i] = math.sqrt(mx * mx + mz * mz)
        duration[i] = (0.5 * (u[2 * i + 1] + 1.0) * speed_max - impact[i]) / deceleration + max(time_a, time_b)
    f, miss_term = flags.reshape(-1), scratch(n)
    for i in range(n):  # the reward and flags
        miss_term[i], hit = -miss[i] / target_distance_max, miss[i] <= target_radius
        f[2 * i], f[2 * i + 1] = contact[i], hit
        reward[i] = miss_term[i] + (hit_bonus if hit else 0.0)
        terminated[i] = True
    for i in range(n):  # stores into the rows of ``shot``: strided, by scalar code
        speed, dx, dz = 0.5 * (u[2 * i + 1] + 1.0) * speed_max, aim_x[i], aim_z[i]
        px, pz = a[2 * i] + travel[i] * dx, a[2 * i + 1] + travel[i] * dz
        row = shot[i]
        row[0], row[1], row[2], row[3] = speed * dx, speed * dz, px, pz
        row[4], row[5], row[6], row[7] = after_a_x[i], after_a_z[i], after_b_x[i], after_b_z[i]
        row[8], row[9] = px + after_a_x[i] * factor_a[i], pz + after_a_z[i] * factor_a[i]
        row[10], row[11] = b[2 * i] + after_b_x[i] * factor_b[i], b[2 * i + 1] + after_b_z[i] * factor_b[i]
        row[12] = closing[i]
        row[13] = collision.energy_loss_one(closing[i], mass_a, mass_b, restitution)
        row[14], row[15], row[16], row[17] = duration[i], miss[i], miss_term[i], hit_bonus if f[2 * i + 1] else 0.0
    _observe(ball_a, ball_b, target, c, obs)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe(ball_a: np.ndarray, ball_b: np.ndarray, target: np.ndarray, c: np.ndarray, obs: np.ndarray) -> None:
    """Observations (n, 4) into ``obs``, in the frame of the line A-B; ``c`` holds the parameters named in
    ``STEP_CONSTANTS``. Written as a pass over the batch that the compiler turns into SIMD code."""
    target_distance_max, ball_distance_max = c[8], c[11]
    n = len(ball_a)
    a, b, t, o = ball_a.reshape(-1), ball_b.reshape(-1), target.reshape(-1), obs.reshape(-1)  # see _step_kernel
    for i in range(n):
        ox, oz = b[2 * i] - a[2 * i], b[2 * i + 1] - a[2 * i + 1]
        distance = math.sqrt(ox * ox + oz * oz)
        along_x, along_z = ox / distance, oz / distance
        tx, tz = t[2 * i] - b[2 * i], t[2 * i + 1] - b[2 * i + 1]
        target_distance = math.sqrt(tx * tx + tz * tz)
        # held to the box against rounding: a target nanometres from B is found from coordinates of metres, and
        # one on B in those coordinates (a nanometre from B a million km out) lies straight ahead, not at 0 / 0
        apart = target_distance > 0.0
        o[4 * i] = min(distance / ball_distance_max, 1.0)
        o[4 * i + 1] = min(target_distance / target_distance_max, 1.0)
        o[4 * i + 2] = min(max((tx * -along_z + tz * along_x) / target_distance, -1.0), 1.0) if apart else 0.0
        o[4 * i + 3] = min(max((tx * along_x + tz * along_z) / target_distance, 0.0), 1.0) if apart else 1.0


@njit(cache=True, nogil=True, error_model="numpy")
def _observe_kernel(ball_a: np.ndarray, ball_b: np.ndarray, target: np.ndarray, c: np.ndarray, obs: np.ndarray) -> None:
    """Observations (n, 4) into ``obs`` (:func:`_observe`)."""
    _observe(ball_a, ball_b, target, c, obs)


class BilliardsTask(Task[BilliardsParams]):
    """Batched logic of Billiards-v0 (see :class:`BilliardsEnv`)."""

    params_cls = BilliardsParams
    renderer = "vegym.render.billiards:BilliardsRenderer"
    episode_constants = ("ball_a", "ball_b", "target")

    def __init__(self, params: BilliardsParams) -> None:
        super().__init__(params)
        self.observation_space = spaces.Box(
            np.array([0, 0, -1, 0], np.float32), np.array([1, 1, 1, 1], np.float32), dtype=np.float32
        )
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self._constants = np.array([getattr(params, name) for name in STEP_CONSTANTS], dtype=np.float64)
        self._offset = rng.stream_offset(_SETUP_STREAM)

    @property
    def control_rate(self) -> float:
        return 1.0

    def initial_state(self, keys: np.ndarray) -> State:
        n = len(keys)
        state = {name: np.empty((n, 2)) for name in ("ball_a", "ball_b", "target")}
        self.start(state, np.ascontiguousarray(keys, dtype=np.uint64), np.arange(n))
        return state

    def start(self, state: State, keys: np.ndarray, rows: np.ndarray) -> None:
        _start(keys, rows, self._constants, self._offset, state["ball_a"], state["ball_b"], state["target"])

    def restart_call(self, state: State, rows: np.ndarray, obs: np.ndarray) -> KernelCall | None:
        if len(rows) < len(obs):  # some rows (sub-envs that ended while others go on): observed by rows
            return None
        return _restart_kernel, (
            state["key"],
            rows,
            self._constants,
            self._offset,
            state["ball_a"],
            state["ball_b"],
            state["target"],
            obs,
        )

    @staticmethod
    def line_frame(state: State) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Distance A-B (n,) and unit vectors (n, 2) along the line A-B and across it (toward increasing bearing).

        Bearings are measured on the table plane (x, z) from +x toward +z, as the projectile's azimuth.
        """
        offset = state["ball_b"] - state["ball_a"]
        distance = np.linalg.norm(offset, axis=-1)
        along = offset / distance[:, None]
        return distance, along, np.stack([-along[:, 1], along[:, 0]], axis=-1)

    def output_shapes(self) -> dict[str, tuple[tuple[int, ...], type]]:
        return {
            "shot": ((len(SHOT_COLUMNS),), np.float64),
            "flags": ((len(FLAG_COLUMNS),), np.bool_),
        }

    def step_call(self, state: State, action: np.ndarray, out: State) -> KernelCall:
        return _step_kernel, (
            action, state["ball_a"], state["ball_b"], state["target"], self._constants, out["shot"], out["flags"],
            out["reward"], out["terminated"], out["obs"],
        )  # fmt: skip

    def info(self, state: State, out: State) -> Info:
        shot, flags = out["shot"], out["flags"]
        return {
            "ball_a": state["ball_a"],
            "ball_b": state["ball_b"],
            "target": state["target"],
            "strike_velocity": shot[:, 0:2],
            "contact": flags[:, 0],
            "contact_point": shot[:, 2:4],
            "closing_speed": shot[:, 12],
            "velocity_a": shot[:, 4:6],
            "velocity_b": shot[:, 6:8],
            "energy_lost": shot[:, 13],
            "rest_a": shot[:, 8:10],
            "rest_b": shot[:, 10:12],
            "duration": shot[:, 14],
            "miss_distance": shot[:, 15],
            "reward_terms": {"miss": shot[:, 16], "hit": shot[:, 17]},
            "is_success": flags[:, 1],
        }

    def observe(self, state: State, obs: np.ndarray) -> None:
        _observe_kernel(state["ball_a"], state["ball_b"], state["target"], self._constants, obs)


class BilliardsEnv(VegymEnv[BilliardsParams]):
    """Oblique impact: strike ball A so that it knocks ball B, at rest, to slide to rest on a target.

    ## Description
    The oblique impact of two spheres of the chapter (8.47-8.62, corrected and in vector form as in PHYSICS.md
    section 5): at contact the line of centres ``n`` carries the impulse ``J = (1 + e) mu w`` (``w`` the closing
    speed, ``mu`` the reduced mass), the tangential components are unchanged, so B, at rest, leaves along ``n``
    at ``u_b = (1 + e) m_a w / (m_a + m_b)`` (8.60) and A is deflected (8.61). The table adds one thing to the
    chapter: each ball slides in a straight line with the constant deceleration ``deceleration`` (the cloth's
    rolling resistance), so a ball at speed v stops ``v^2 / (2 a)`` further on. A starts at the origin and B at
    a random distance and bearing; the target lies at a random distance from B within ``bearing_max`` of the line
    A-B. The cut it needs is larger, since A is aimed off that line (at the defaults up to 67 degrees for a bearing
    of 57; ``largest_bearing`` is where it reaches 90). One step is one strike; the balls meet at most once (a
    second contact after the impact is not modelled) and there are no cushions.

    ## Action Space
    ``Box(-1, 1, (2,), float32)``: ``a0`` is the sine of the cut angle, i.e. the offset of B's centre from A's
    path in units of ``radius_a + radius_b`` (0: full ball, +-1: grazing); B then departs at ``asin(a0)`` from
    A's direction, toward increasing bearing for ``a0 > 0``, and A is aimed ``-asin(a0 R / D_ab)`` off the line
    A-B. ``a1`` is the strike speed ``(a1 + 1)/2 * speed_max``. A strike too slow to reach B leaves B in place.

    ## Observation Space
    ``Box([0, 0, -1, 0], 1, (4,), float32)`` in the frame of the line A-B: the distance A-B over
    ``ball_distance_max``, the distance from B to the target over ``target_distance_max``, and the sine and
    cosine of the target's bearing from B relative to the line A-B (the cosine is at least
    ``cos(bearing_max) >= 0``).

    ## Rewards
    ``-miss / target_distance_max`` (term ``miss``), ``miss`` the distance from B's rest point to the target's
    centre, plus ``hit_bonus`` if ``miss <= target_radius`` (term ``hit``).

    ## Starting State
    Distance A-B uniform in ``[ball_distance_min, ball_distance_max]`` at a uniform bearing; target distance
    from B uniform in ``[target_distance_min, target_distance_max]`` at a bearing uniform within
    ``bearing_max`` of the line A-B. Every target is reachable: ``speed_max`` must be at least
    ``required_speed``, the fastest ghost-ball strike any episode needs (2.30 m/s with the defaults).

    ## Episode End
    Terminated after the strike (one step). The registered time limit of one step reports ``truncated`` on that
    step too (Gymnasium's TimeLimit, as the native vector env); ``terminated`` is the end that counts: no state
    follows the strike to bootstrap from (SB3 reads it so). ``info["is_success"]``: B rests within
    ``target_radius`` of the target.

    ## Arguments
    ``gymnasium.make("vegym/Billiards-v0", render_mode=None, **params)`` with the fields of
    :class:`BilliardsParams`. ``info`` (SI, vectors (x, z) on the table): ``ball_a``, ``ball_b``, ``target``
    (start positions), ``strike_velocity``, ``contact`` (A reached B), ``contact_point`` (A's centre at the
    impact; where it stopped without contact), ``closing_speed`` (``w``, 0 without contact), ``velocity_a``,
    ``velocity_b`` (just after the impact), ``energy_lost`` (``1/2 mu (1 - e^2) w^2``, J), ``rest_a``,
    ``rest_b``, ``duration`` (strike to both balls at rest, s), ``miss_distance``, ``reward_terms``,
    ``is_success``.
    Reference controller: the ghost-ball aim with the strike speed from 8.60 and the cloth
    (:func:`ghost_ball_shot`, ``agents.analytic``).

    ## Version History
    * v0: initial version.
    """

    task_cls = BilliardsTask


class BilliardsVectorEnv(VegymVectorEnv[BilliardsParams]):
    """Native vector twin of :class:`BilliardsEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = BilliardsTask
