"""ProjectileAdjust-v0: Projectile-v0 with the wind hidden; up to ``max_shots`` shots, correcting from the misses."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs.base import Info, KernelCall, State, Task, VegymEnv, VegymVectorEnv
from vegym.envs.projectile import AZIMUTH_LIMIT, ELEVATION_LIMIT, ProjectileEnvParams, ProjectileTask, _shoot, _start
from vegym.envs.projectile import SHOT_COLUMNS as PROJECTILE_SHOT_COLUMNS
from vegym.params import param
from vegym.physics import projectile, vmath
from vegym.physics.columns import prefer_wide_vectors, scratch

SHOT_FIELDS = 6
"""Observation entries per remembered shot: fired flag, miss along and across, and the shot's three actions."""
SHOT_COLUMNS = (*PROJECTILE_SHOT_COLUMNS, "miss_along", "miss_across")
"""Columns of the step's ``shot`` output: Projectile-v0's, then the miss (landing minus target, m) along and across
the line of fire."""


@dataclass(frozen=True)
class ProjectileAdjustParams(ProjectileEnvParams):
    """Parameters of ProjectileAdjust-v0: those of Projectile-v0 and the number of shots."""

    wind_speed_max: float = param(
        5.0, "largest horizontal wind speed (m/s); direction uniform; the wind to find", low=0.0, low_open=True
    )
    max_shots: int = param(
        3, "shots per episode at the same target (the episode ends earlier on a hit)", low=2, high=16
    )

    def validate(self) -> None:
        if self.wind_speed_max >= self.speed_max:  # before Projectile-v0's check, whose range includes 0
            raise self.between("wind_speed_max", high="speed_max", high_open=True)
        super().validate()

    @property
    def memory(self) -> int:
        """Shots shown in the observation: ``max_shots - 1``, the most recent first."""
        return self.max_shots - 1

    @property
    def longest_flight(self) -> float:
        """Longest flight time (s) of any shot: straight up at ``speed_max`` from ``launch_height_max``."""
        g = self.gravity
        return float(
            (self.speed_max + np.sqrt(self.speed_max**2 + 2.0 * g * (self.launch_height_max - self.radius))) / g
        )

    @property
    def miss_scale(self) -> float:
        """Scale of the observed misses (m): ``wind_speed_max * longest_flight``, the largest miss of a shot aimed by
        a wind-free solution that would hit (its miss is ``w T``). A miss ``m`` shows as ``x / (1 + |x|)`` of
        ``x = m / miss_scale``: linear for small misses, 1/2 at this one, and any larger miss still told apart
        (:func:`observed_miss` inverts it).
        """
        return self.wind_speed_max * self.longest_flight


def observed_miss(entry: np.ndarray, params: ProjectileAdjustParams) -> np.ndarray:
    """The misses (m) that observation entries in (-1, 1) show: ``miss_scale y / (1 - |y|)``, the inverse of
    ``y = x / (1 + |x|)``, ``x = miss / miss_scale``."""
    y = np.asarray(entry, dtype=np.float64)
    return params.miss_scale * y / (1.0 - np.abs(y))


@njit(cache=True, nogil=True, error_model="numpy")
def _step_kernel(
    action: np.ndarray,
    launch: np.ndarray,
    target: np.ndarray,
    wind: np.ndarray,
    bearing: np.ndarray,
    landing: np.ndarray,
    misses: np.ndarray,
    actions: np.ndarray,
    shots: np.ndarray,
    shot_c: np.ndarray,
    c: np.ndarray,
    shot: np.ndarray,
    success: np.ndarray,
    reward: np.ndarray,
    terminated: np.ndarray,
    obs: np.ndarray,
) -> None:
    """One shot per episode (Projectile-v0's, :func:`~vegym.envs.projectile._shoot`, with ``shot_c`` its
    constants) pushed onto the episode's memory (most recent first), and the next observation; in place on the
    state arrays (``landing`` to ``shots``) and into the outputs (``shot`` to ``obs``; ``shot`` holds the
    ``SHOT_COLUMNS``). The memory keeps the shot's miss (landing minus target, m) along and across the line of
    fire of ``bearing`` (rad) and its action. ``c`` is as in :func:`_observe`.

    Written as passes over the batch: the shot, the miss in the target frame (SIMD code), the memory's shift
    (the batch loop innermost), the newest entry and the observation."""
    prefer_wide_vectors()
    max_shots, memory, n = c[2], misses.shape[1], len(action)
    _shoot(action, launch, target, wind, bearing, landing, shot_c, shot, success, reward)
    along, across = scratch(n), scratch(n)
    landed, t = landing.reshape(-1), target.reshape(-1)  # flat views: constant row widths keep the SIMD path
    for i in range(n):
        sin_b, cos_b = vmath.sincos(bearing[i])
        dx, dy, dz = landed[3 * i] - t[3 * i], landed[3 * i + 1] - t[3 * i + 1], landed[3 * i + 2] - t[3 * i + 2]
        along[i] = dx * cos_b + dy * 0.0 + dz * sin_b  # the frame's unit vectors are horizontal
        across[i] = dx * -sin_b + dy * 0.0 + dz * cos_b
        shots[i] += 1
        terminated[i] = success[i] | (shots[i] >= max_shots)
    for k in range(memory - 1, 0, -1):
        for i in range(n):
            misses[i, k, 0], misses[i, k, 1] = misses[i, k - 1, 0], misses[i, k - 1, 1]
            actions[i, k, 0], actions[i, k, 1], actions[i, k, 2] = (
                actions[i, k - 1, 0], actions[i, k - 1, 1], actions[i, k - 1, 2]
            )  # fmt: skip
    for i in range(n):
        misses[i, 0, 0], misses[i, 0, 1] = along[i], across[i]
        shot[i, -2], shot[i, -1] = along[i], across[i]
        actions[i, 0, 0], actions[i, 0, 1], actions[i, 0, 2] = action[i, 0], action[i, 1], action[i, 2]
    _observe(launch, target, misses, actions, shots, c, obs)


@njit(cache=True, nogil=True, inline="always")
def _clear(rows: np.ndarray, misses: np.ndarray, actions: np.ndarray, shots: np.ndarray) -> None:
    """Empty the shot memory of the rows ``rows``, in place."""
    for k in range(misses.shape[1]):
        for j in range(len(rows)):
            i = rows[j]
            misses[i, k, 0], misses[i, k, 1] = 0.0, 0.0
            actions[i, k, 0], actions[i, k, 1], actions[i, k, 2] = 0.0, 0.0, 0.0
    for j in range(len(rows)):
        shots[rows[j]] = 0


@njit(cache=True, nogil=True, error_model="numpy")
def _restart_kernel(
    keys: np.ndarray,
    rows: np.ndarray,
    shot_c: np.ndarray,
    offset: np.uint64,
    launch: np.ndarray,
    target: np.ndarray,
    wind: np.ndarray,
    bearing: np.ndarray,
    landing: np.ndarray,
    misses: np.ndarray,
    actions: np.ndarray,
    shots: np.ndarray,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """The next episode of the episodes ``rows`` (:meth:`~vegym.envs.base.Task.restart`): their ``keys`` advanced
    in place, the episodes started (Projectile-v0's :func:`~vegym.envs.projectile._start` with its constants
    ``shot_c``), their memory emptied and observed (:func:`_observe_started`, ``c`` its constants) into those rows
    of ``obs``."""
    next_keys = rng.advance_rows(keys, rows)
    _start(next_keys, rows, shot_c, offset, launch, target, wind, bearing, landing)
    _clear(rows, misses, actions, shots)
    _observe_started(rows, launch, target, c, obs)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe_started(rows: np.ndarray, launch: np.ndarray, target: np.ndarray, c: np.ndarray, obs: np.ndarray) -> None:
    """:func:`_observe` of the rows ``rows``, episodes with no shot fired (an empty memory), into those rows of
    ``obs``: the target's distance and the launch height, then zeros (0 / max_shots and the empty slots). In place
    on the rows, without gathering copies of them (a gather of 2,048 rows of 8,192 cost 50 us, their restart's
    start 57 us)."""
    target_distance_max, height_scale = c[0], c[1]
    for j in range(len(rows)):
        i = rows[j]
        dx, dz = target[i, 0] - launch[i, 0], target[i, 2] - launch[i, 2]
        obs[i, 0] = math.sqrt(dx * dx + dz * dz) / target_distance_max
        obs[i, 1] = launch[i, 1] / height_scale
        for k in range(2, obs.shape[1]):
            obs[i, k] = 0.0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe(
    launch: np.ndarray,
    target: np.ndarray,
    misses: np.ndarray,
    actions: np.ndarray,
    shots: np.ndarray,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """Observations (n, 3 + memory * SHOT_FIELDS) into ``obs``; ``c = (target_distance_max, height_scale,
    max_shots, miss_scale)``. Written as passes over the batch: the first three entries (SIMD code, into scratch
    arrays), their strided stores, and one pass per remembered shot."""
    target_distance_max, height_scale, max_shots, miss_scale = c[0], c[1], c[2], c[3]
    n = len(shots)
    distance, height, fired = scratch(n), scratch(n), scratch(n)
    p, t = launch.reshape(-1), target.reshape(-1)  # flat views: constant row widths keep the SIMD path
    for i in range(n):
        dx, dz = t[3 * i] - p[3 * i], t[3 * i + 2] - p[3 * i + 2]
        distance[i] = math.sqrt(dx * dx + dz * dz) / target_distance_max
        height[i] = p[3 * i + 1] / height_scale
        fired[i] = min(shots[i], max_shots) / max_shots  # steps past the end without a reset: still 1
    for i in range(n):
        obs[i, 0], obs[i, 1], obs[i, 2] = distance[i], height[i], fired[i]
    for k in range(misses.shape[1]):
        j = 3 + k * SHOT_FIELDS
        for i in range(n):
            obs[i, j] = 1.0 if k < shots[i] else 0.0
            along, across = misses[i, k, 0], misses[i, k, 1]  # x / (1 + |x|) of x = m / s is m / (s + |m|)
            obs[i, j + 1], obs[i, j + 2] = along / (miss_scale + abs(along)), across / (miss_scale + abs(across))
            obs[i, j + 3], obs[i, j + 4], obs[i, j + 5] = actions[i, k, 0], actions[i, k, 1], actions[i, k, 2]


@njit(cache=True, nogil=True, error_model="numpy")
def _observe_kernel(
    launch: np.ndarray,
    target: np.ndarray,
    misses: np.ndarray,
    actions: np.ndarray,
    shots: np.ndarray,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """Observations (n, 3 + memory * SHOT_FIELDS) into ``obs`` (:func:`_observe`)."""
    _observe(launch, target, misses, actions, shots, c, obs)


class ProjectileAdjustTask(Task[ProjectileAdjustParams]):
    """Batched logic of ProjectileAdjust-v0 (see :class:`ProjectileAdjustEnv`); each shot is a Projectile-v0 step."""

    params_cls = ProjectileAdjustParams
    renderer = "vegym.render.projectile_adjust:ProjectileAdjustRenderer"
    # Projectile's episode constants (launch_position, target, wind) are plain state here. Episodes end within
    # max_shots steps, so a vector env restarts some rows at nearly every step (about a quarter at the defaults) and
    # would copy them as episode constants anyway (the calling thread did, before a second split call restarted
    # those rows); as state, each chunk of a split step copies its rows for the info and then restarts its own ended
    # episodes (``Task.restart_call``).

    def __init__(self, params: ProjectileAdjustParams) -> None:
        super().__init__(params)
        self.shot = ProjectileTask(params)
        slot_low = [0.0] + [-1.0] * (SHOT_FIELDS - 1)
        low = np.array([0.0, 0.0, 0.0, *slot_low * params.memory], np.float32)
        self.observation_space = spaces.Box(low, np.ones_like(low), dtype=np.float32)
        self.action_space = self.shot.action_space
        self._shot_constants = self.shot._constants
        self._constants = np.array(
            [params.target_distance_max, params.height_scale, params.max_shots, params.miss_scale], dtype=np.float64
        )

    @property
    def control_rate(self) -> float:
        return 1.0

    def initial_state(self, keys: np.ndarray) -> State:
        n, memory = len(keys), self.params.memory
        return {
            **self.shot.initial_state(keys),
            "misses": np.zeros((n, memory, 2)),
            "actions": np.zeros((n, memory, 3)),
            "shots": np.zeros(n, dtype=np.int64),
        }

    def start(self, state: State, keys: np.ndarray, rows: np.ndarray) -> None:
        self.shot.start(state, keys, rows)
        _clear(rows, state["misses"], state["actions"], state["shots"])

    def restart_call(self, state: State, rows: np.ndarray, obs: np.ndarray) -> KernelCall | None:
        return _restart_kernel, (
            state["key"], rows, self._shot_constants, self.shot._offset, state["launch_position"], state["target"],
            state["wind"], state["bearing"], state["landing_point"], state["misses"], state["actions"], state["shots"],
            self._constants, obs,
        )  # fmt: skip

    def output_shapes(self) -> dict[str, tuple[tuple[int, ...], type]]:
        return {"shot": ((len(SHOT_COLUMNS),), np.float64), "success": ((), np.bool_)}

    def step_call(self, state: State, action: np.ndarray, out: State) -> KernelCall:
        return _step_kernel, (
            action, state["launch_position"], state["target"], state["wind"], state["bearing"],
            state["landing_point"], state["misses"], state["actions"], state["shots"], self._shot_constants,
            self._constants, out["shot"], out["success"], out["reward"], out["terminated"], out["obs"],
        )  # fmt: skip

    def info(self, state: State, out: State) -> Info:
        shot = out["shot"]
        return {
            **self.shot.info(state, out),
            "miss_along": shot[:, -2],
            "miss_across": shot[:, -1],
            "shots": state["shots"],
        }

    def observe(self, state: State, obs: np.ndarray) -> None:
        _observe_kernel(
            state["launch_position"], state["target"], state["misses"], state["actions"], state["shots"],
            self._constants, obs,
        )  # fmt: skip


def wind_from_shot(
    distance: np.ndarray, height: np.ndarray, miss: np.ndarray, action: np.ndarray, params: ProjectileAdjustParams
) -> np.ndarray:
    """The horizontal wind (n, 3) in the target frame (along, 0, across) that explains a shot's miss exactly.

    The wind is a drift, ``p(t) = p0 + (v0 + w) t + 1/2 g_vec t^2``, and with ``w_y = 0`` the flight time T does
    not depend on it; so the landing point is the wind-free one plus ``w T``, and
    ``w = (target + miss - p0 - v0_h T) / T``. For a shot aimed by a wind-free solution that would hit, this
    is the chapter's adjust-fire rule: the miss is the wind times the flight time. ``distance`` and ``height``
    (m) place the target at ``(distance, radius - height, 0)`` from the launcher; ``miss`` (n, 2) is the
    landing point minus the target (along, across); ``action`` (n, 3) is the shot's action.
    """
    p = params
    elevation = ELEVATION_LIMIT * action[:, 0]
    azimuth = AZIMUTH_LIMIT * action[:, 1]
    speed = p.speed_min + 0.5 * (action[:, 2] + 1.0) * (p.speed_max - p.speed_min)
    velocity = projectile.launch_velocity(elevation, azimuth, speed)
    zeros = np.zeros(len(distance))
    launch = np.stack([zeros, height, zeros], axis=-1)
    flight_time = projectile.impact_time(launch, velocity, np.zeros(3), p.physics)
    drift = np.stack([distance + miss[:, 0], zeros, miss[:, 1]], axis=-1) - velocity * flight_time[:, None]
    drift[:, 1] = 0.0
    return drift / flight_time[:, None]


class ProjectileAdjustEnv(VegymEnv[ProjectileAdjustParams]):
    """Adjust-fire: hit a ground target in a hidden wind, correcting each shot from where the previous ones landed.

    ## Description
    The projectile of Projectile-v0 (8.63-8.71 with the wind drift completed, PHYSICS.md section 6), with the
    same launcher, target, wind and shot physics (each step runs :class:`~vegym.envs.projectile.ProjectileTask`),
    but the wind is not observed. The agent fires up to ``max_shots`` shots at the same target and sees where
    each landed. Since ``w_y = 0`` the wind does not change the flight time T, and it moves every landing point
    by exactly ``w T``: one miss of a known shot reveals the wind.

    ## Action Space
    As Projectile-v0: ``Box(-1, 1, (3,), float32)``, elevation ``a0 * pi/2``, azimuth ``a1 * pi/2`` relative to
    the target's bearing, speed ``speed_min + (a2 + 1)/2 * (speed_max - speed_min)`` relative to the air.

    ## Observation Space
    ``Box(low, 1, (3 + 6 (max_shots - 1),), float32)``: the target distance over ``target_distance_max`` and
    the launch height over ``max(launch_height_max, 1 m)`` (as Projectile-v0), the shots fired over
    ``max_shots``; then, for the ``max_shots - 1`` most recent shots, newest first: a fired flag (0 for an empty
    slot, whose other entries are 0), the landing point minus the target along and across the line of fire
    (``x / (1 + |x|)`` of ``x`` = the miss over ``miss_scale = wind_speed_max * longest_flight``: in (-1, 1),
    linear near 0, 1/2 at a miss of ``miss_scale``, and far misses still told apart), and the shot's three
    actions. ``low`` is 0 for the first three entries and the flags, -1 elsewhere.

    ## Rewards
    Per shot as Projectile-v0: ``-miss / target_distance_max`` (term ``miss``) plus, for a landing within
    ``hit_radius`` of the target, ``hit_bonus * (1 - (miss / hit_radius)^2)`` (term ``hit``); a hit ends the
    episode, so early hits pay.

    ## Starting State
    As Projectile-v0 (the same draws: the same seed gives the same launcher, target and wind), with no shot
    fired. ``wind_speed_max`` must be positive.

    ## Episode End
    Terminated on a hit (``info["is_success"]``) or after ``max_shots`` shots. Registered with
    ``max_episode_steps = 16``, the largest allowed ``max_shots``, so the time limit never cuts an episode short.
    Steps past the end without the reset Gymnasium asks for fire further shots, each terminated, and observe the
    shots fired as ``max_shots`` (1.0).

    ## Arguments
    ``gymnasium.make("vegym/ProjectileAdjust-v0", render_mode=None, **params)`` with the fields of
    :class:`ProjectileAdjustParams`. ``info``: that of Projectile-v0 (``launch_position``, ``launch_velocity``,
    ``wind`` (the hidden wind, for analysis only), ``gravity``, ``landing_point``, ``flight_time``, ``target``,
    ``miss_distance``, ``reward_terms``, ``is_success``), plus ``miss_along``, ``miss_across`` (m, target frame)
    and ``shots`` (fired so far). Reference controller: fire the wind-free firing solution, estimate the wind
    from the miss (:func:`wind_from_shot`), fire the firing solution for that wind (``agents.analytic``).

    ## Version History
    * v0: initial version.
    """

    task_cls = ProjectileAdjustTask


class ProjectileAdjustVectorEnv(VegymVectorEnv[ProjectileAdjustParams]):
    """Native vector twin of :class:`ProjectileAdjustEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = ProjectileAdjustTask
