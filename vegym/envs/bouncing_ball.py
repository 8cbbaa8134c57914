"""BouncingBall-v0: choose the coefficient of restitution at each impact to reach target apex heights."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs.base import Info, KernelCall, State, Task, VegymEnv, VegymVectorEnv
from vegym.params import Params, param
from vegym.physics import particle
from vegym.physics.columns import pairwise_sum, scratch
from vegym.physics.particle import STANDARD_GRAVITY, ParticleParams

_FIRST_TARGET_STREAM = 1
_TARGET_RATIO_STREAM = 2


@dataclass(frozen=True)
class BouncingBallParams(Params):
    """Parameters of BouncingBall-v0 (SI units; heights are of the ball's centre above the floor)."""

    gravity: float = param(STANDARD_GRAVITY, "gravitational acceleration magnitude (m/s^2)", low=0.0, low_open=True)
    radius: float = param(0.1, "ball radius (m)", low=0.0)
    drop_height: float = param(3.0, "height the ball is released from at rest (m); the highest apex", low=0.0)
    target_min: float = param(0.5, "lowest target apex (m)", low=0.0)
    target_max: float = param(2.5, "highest target apex (m)", low=0.0)
    target_ratio_min: float = param(0.75, "smallest ratio of a target to the previous one", low=0.0, low_open=True)
    target_ratio_max: float = param(1.25, "largest ratio of a target to the previous one", low=0.0, low_open=True)
    lookahead: int = param(3, "number of future targets shown besides the current one", low=0, high=16)
    rest_speed: float = param(0.05, "rebound speed below which the ball is at rest, ending the episode (m/s)", low=0.0)
    episode_bounces: int = param(
        10,
        "planned episode length (bounces), the registered max_episode_steps: resting earlier is charged",
        low=1,
        high=10_000,  # the rest charge draws every planned bounce left (0.2 ms per ball at rest at 10,000)
    )
    success_error: float = param(
        0.05, "is_success: mean apex error over the episode, in units of drop_height - radius, at most this", low=0.0
    )

    def validate(self) -> None:
        if not self.radius < self.target_min:
            raise self.between("target_min", "radius", "target_max", low_open=True)
        if not self.target_min <= self.target_max <= self.drop_height:
            raise self.between("target_max", "target_min", "drop_height")
        if self.target_ratio_min > self.target_ratio_max:
            raise self.between("target_ratio_min", high="target_ratio_max")

    @property
    def particle(self) -> ParticleParams:
        """The falling-particle physics parameters."""
        return self.subset(ParticleParams)

    @property
    def height_scale(self) -> float:
        """``drop_height - radius`` (m): the unit of normalised heights and apex errors."""
        return self.drop_height - self.radius

    @property
    def drop_speed(self) -> float:
        """Speed at the first impact (m/s), the largest impact speed of an episode."""
        return float(-particle.impact_velocity(self.drop_height, 0.0, self.radius, self.gravity))


STEP_CONSTANTS = (
    "radius",
    "gravity",
    "rest_speed",
    "height_scale",
    "episode_bounces",
    "success_error",
    "target_min",
    "target_max",
    "target_ratio_min",
    "target_ratio_max",
    "drop_speed",
)
"""Parameters the kernels read, in the order of their constants array (SI units, see the fields); the time of the
first impact (s) follows them."""
CHARGE_SCRATCH = 1 << 16
"""Skipped heights (float64) the rest charge holds at once: its scratch stays within 512 KiB whatever
``episode_bounces`` and the number of balls at rest."""
REWARD_TERMS = ("apex_error", "rest")
"""Names of ``info["reward_terms"]``, in the order of the step kernel's ``terms`` columns."""


@njit(cache=True, inline="always")
def _first_target(key: np.uint64, c: np.ndarray, offsets: np.ndarray) -> float:
    """The first target apex (m) of the episode ``key``: ``t_0 = U(target_min, target_max)``; ``c`` holds the
    parameters named in ``STEP_CONSTANTS``, ``offsets`` the rng stream offsets of the first target and of the
    ratios (:func:`_next_target`)."""
    target_min, target_max = c[6], c[7]
    return target_min + (target_max - target_min) * rng.lane(rng.stream_base(key, offsets[0], np.uint64(0)), 0)


@njit(cache=True, inline="always")
def _next_target(key: np.uint64, index: int, previous: float, c: np.ndarray, offsets: np.ndarray) -> float:
    """Target apex number ``index >= 1`` (m) of the episode ``key``, from target ``index - 1`` (``previous``): a
    random walk, ``t_k = clip(t_{k-1} U(target_ratio_min, target_ratio_max), target_min, target_max)``, drawn from
    the episode key alone (never from the actions). Branch-free, so that loops over episodes run as SIMD code."""
    target_min, target_max, ratio_min, ratio_max = c[6], c[7], c[8], c[9]
    u = rng.lane(rng.stream_base(key, offsets[1], np.uint64(index)), 0)
    return min(max(previous * (ratio_min + (ratio_max - ratio_min) * u), target_min), target_max)


@njit(cache=True, nogil=True, inline="always")
def _draw_targets(keys: np.ndarray, rows: np.ndarray, targets: np.ndarray, c: np.ndarray, offsets: np.ndarray) -> None:
    """The first ``targets.shape[1]`` targets (m) of the episodes ``keys`` written into the rows ``rows`` of
    ``targets``: a pass over the episodes per target (SIMD code, into scratch) and its scattered store."""
    walk = scratch(len(keys))
    for k in range(targets.shape[1]):
        for j in range(len(keys)):
            walk[j] = _first_target(keys[j], c, offsets) if k == 0 else _next_target(keys[j], k, walk[j], c, offsets)
        for j in range(len(keys)):
            targets[rows[j], k] = walk[j]


@njit(cache=True)
def _targets_kernel(keys: np.ndarray, count: int, c: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    out = np.empty((len(keys), count))
    _draw_targets(keys, np.arange(len(keys)), out, c, offsets)
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _step_kernel(
    action: np.ndarray,
    speed: np.ndarray,
    time: np.ndarray,
    targets: np.ndarray,
    error_sum: np.ndarray,
    keys: np.ndarray,
    step: np.ndarray,
    c: np.ndarray,
    offsets: np.ndarray,
    impact_speed: np.ndarray,
    restitution: np.ndarray,
    apex_height: np.ndarray,
    target_height: np.ndarray,
    terms: np.ndarray,
    reward: np.ndarray,
    success: np.ndarray,
    terminated: np.ndarray,
    obs: np.ndarray,
    row_width: tuple[int, ...],
) -> None:
    """One impact per episode and the next observation, in place on the state arrays (``speed`` to
    ``error_sum``; ``keys`` and ``step``, the steps taken before this one, are read only) and into the outputs
    (``impact_speed`` to ``obs``): the impact speed (m/s), restitution, apex (m) and target (m) of this bounce, the
    reward terms (apex error, rest), reward, is_success and terminated (at rest); ``c`` holds the parameters named
    in ``STEP_CONSTANTS``; ``row_width`` is :attr:`BouncingBallTask.row_width`.

    Written as passes over the batch that the compiler turns into SIMD code: the bounce, the targets' shift, the
    draw of the newest targets and the observation (loops without calls or exits; the targets' rows through a flat
    view, whose compile-time row width gives constant strides), and passes over copies of the balls that came to
    rest (:func:`_charge_rest`).
    """
    radius, gravity, rest_speed, height_scale, success_error = c[0], c[1], c[2], c[3], c[5]
    n, width = len(action), len(row_width)
    lookahead, flat = width - 1, targets.reshape(-1)
    current, newest = scratch(n), scratch(n)  # the targets' first and last columns
    for i in range(n):
        current[i], newest[i] = flat[width * i], flat[width * i + lookahead]
    for i in range(n):
        e = 0.5 * (action[i, 0] + 1.0)
        v = speed[i]
        rebound = -v - particle.normal_impulse_one(-v, e)
        at_rest = rebound < rest_speed
        rebound = 0.0 if at_rest else rebound
        apex = particle.apex_height_one(radius, rebound, gravity)
        flight = particle.ground_time_one(radius, rebound, radius, gravity)
        target = current[i]
        error = abs(apex - target) / height_scale
        errors = error_sum[i] + error
        success[i] = errors / (step[i] + 1) <= success_error
        speed[i] = -particle.impact_velocity_one(radius, rebound, radius, gravity)
        time[i] = time[i] + (0.0 if at_rest else flight)
        error_sum[i] = errors
        impact_speed[i], restitution[i], apex_height[i], target_height[i] = v, e, apex, target
        reward[i] = -error - 0.0
        terminated[i] = at_rest
    for i in range(n):  # a pass of its own: strided stores would keep the bounce's pass from SIMD code
        terms[i, 0], terms[i, 1] = reward[i], -0.0
    _charge_rest(keys, step, targets, c, offsets, terminated, error_sum, terms, reward, success)
    for i in range(n):
        for k in range(lookahead):
            flat[width * i + k] = flat[width * i + k + 1]
    for i in range(n):
        newest[i] = _next_target(keys[i], step[i] + lookahead + 1, newest[i], c, offsets)
    for i in range(n):
        flat[width * i + lookahead] = newest[i]
    _observe(speed, targets, c, obs, width)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _charge_rest(
    keys: np.ndarray,
    step: np.ndarray,
    targets: np.ndarray,
    c: np.ndarray,
    offsets: np.ndarray,
    at_rest: np.ndarray,
    error_sum: np.ndarray,
    terms: np.ndarray,
    reward: np.ndarray,
    success: np.ndarray,
) -> None:
    """Charge the episodes whose ball came to rest at this step (``at_rest``) every planned bounce they skip, as if
    at ``h = radius``: their rest term, reward, error sum and is_success (over all planned bounces). The skipped
    targets are the episode's ``targets`` row (not yet shifted) and, beyond it, the rest of its random walk.

    Written as passes over copies of those episodes, in blocks of at most ``CHARGE_SCRATCH`` skipped heights: per
    planned bounce, its skipped height (zero for the bounces made; SIMD code, the walk drawn for every episode and
    kept where it is needed), then each episode's sum."""
    radius, height_scale, bounces_planned, success_error = c[0], c[3], c[4], c[5]
    lookahead, planned = targets.shape[1] - 1, int(bounces_planned)
    resting = np.flatnonzero(at_rest)
    if len(resting) == 0:
        return
    block = max(1, min(len(resting), CHARGE_SCRATCH // planned))
    key, taken, walk = np.empty(block, np.uint64), np.empty(block, np.int64), scratch(block)
    skipped, column = np.empty((planned, block)), np.empty(planned)
    for first in range(0, len(resting), block):
        rows = resting[first : first + block]
        m = len(rows)
        for j in range(m):
            key[j], taken[j], walk[j] = keys[rows[j]], step[rows[j]], targets[rows[j], lookahead]
        for k in range(planned):
            heights = skipped[k]
            for j in range(m):
                ahead = k - taken[j]  # the bounce's column in the episode's targets row
                if k > lookahead:  # only then can a bounce lie past the row (the loop is compiled once per case)
                    walk[j] = _next_target(key[j], k, walk[j], c, offsets) if ahead > lookahead else walk[j]
                shown = targets[rows[j], min(max(ahead, 0), lookahead)]
                heights[j] = 0.0 if ahead < 1 else (shown if ahead <= lookahead else walk[j]) - radius
        for j in range(m):
            for k in range(planned):
                column[k] = skipped[k, j]
            rest_cost = pairwise_sum(column) / height_scale
            i = rows[j]
            errors = error_sum[i] + rest_cost
            error_sum[i] = errors
            success[i] = errors / max(taken[j] + 1, bounces_planned) <= success_error
            terms[i, 1] = -rest_cost
            reward[i] = terms[i, 0] - rest_cost


@njit(cache=True, nogil=True, inline="always")
def _start(
    keys: np.ndarray,
    rows: np.ndarray,
    speed: np.ndarray,
    time: np.ndarray,
    targets: np.ndarray,
    error_sum: np.ndarray,
    c: np.ndarray,
    offsets: np.ndarray,
) -> None:
    """Fresh episodes of ``keys`` written in place into the rows ``rows`` of the state arrays (``speed`` to
    ``error_sum``), as ``BouncingBallTask.initial_state`` draws them; ``c`` holds the parameters named in
    ``STEP_CONSTANTS``, then the time of the first impact."""
    for j in range(len(rows)):
        speed[rows[j]], time[rows[j]], error_sum[rows[j]] = c[10], c[11], 0.0
    _draw_targets(keys, rows, targets, c, offsets)


@njit(cache=True, nogil=True, error_model="numpy")
def _restart_kernel(
    keys: np.ndarray,
    rows: np.ndarray,
    speed: np.ndarray,
    time: np.ndarray,
    targets: np.ndarray,
    error_sum: np.ndarray,
    c: np.ndarray,
    offsets: np.ndarray,
    obs: np.ndarray,
) -> None:
    """The next episode of the episodes ``rows`` (:meth:`~vegym.envs.base.Task.restart`): their ``keys`` advanced
    in place, the episodes started (:func:`_start`) and observed into those rows of ``obs``."""
    next_keys = rng.advance_rows(keys, rows)
    _start(next_keys, rows, speed, time, targets, error_sum, c, offsets)
    _observe_rows(rows, speed, targets, c, obs)


@njit(cache=True, nogil=True, error_model="numpy")
def _observe_kernel(
    speed: np.ndarray, targets: np.ndarray, c: np.ndarray, obs: np.ndarray, row_width: tuple[int, ...]
) -> None:
    """Observations (n, 3 + lookahead) written into ``obs`` (:func:`_observe`); ``row_width`` is
    :attr:`BouncingBallTask.row_width`."""
    _observe(speed, targets, c, obs, len(row_width))


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe(speed: np.ndarray, targets: np.ndarray, c: np.ndarray, obs: np.ndarray, width: int) -> None:
    """:func:`_observe_row` of every episode, as one pass that the compiler turns into SIMD code when ``width``, the
    targets' row width, is a compile-time constant."""
    flat, out, radius, height_scale, drop_speed = targets.reshape(-1), obs.reshape(-1), c[0], c[3], c[10]
    for i in range(len(speed)):  # the parameters read once: in the loop, each write to ``out`` might change them
        _observe_row(i, speed, flat, out, width, radius, height_scale, drop_speed)


@njit(cache=True, nogil=True, error_model="numpy")
def _observe_rows_kernel(
    rows: np.ndarray, speed: np.ndarray, targets: np.ndarray, c: np.ndarray, obs: np.ndarray
) -> None:
    """:func:`_observe_kernel` of the episodes ``rows`` (int indices) only, into those rows of ``obs``."""
    _observe_rows(rows, speed, targets, c, obs)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe_rows(rows: np.ndarray, speed: np.ndarray, targets: np.ndarray, c: np.ndarray, obs: np.ndarray) -> None:
    """:func:`_observe_row` of the episodes ``rows`` (int indices), into those rows of ``obs``; ``c`` holds the
    parameters named in ``STEP_CONSTANTS``."""
    flat, out, width = targets.reshape(-1), obs.reshape(-1), targets.shape[1]
    for r in rows:
        _observe_row(r, speed, flat, out, width, c[0], c[3], c[10])


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe_row(
    i: int,
    speed: np.ndarray,
    targets: np.ndarray,
    obs: np.ndarray,
    width: int,
    radius: float,
    height_scale: float,
    drop_speed: float,
) -> None:
    """Observation of episode ``i`` into its row of ``obs``, through flat views of ``targets`` and ``obs``
    (``width``: the targets' row width; the observation's is ``width + 2``); SI units, the parameters as in
    :class:`BouncingBallParams`."""
    row = (width + 2) * i
    v = speed[i] / drop_speed
    obs[row], obs[row + 1] = v, v * v
    for k in range(width):
        obs[row + 2 + k] = (targets[width * i + k] - radius) / height_scale


class BouncingBallTask(Task[BouncingBallParams]):
    """Batched logic of BouncingBall-v0 (see :class:`BouncingBallEnv`)."""

    params_cls = BouncingBallParams
    planned_length_param = "episode_bounces"
    renderer = "vegym.render.bouncing_ball:BouncingBallRenderer"

    def __init__(self, params: BouncingBallParams) -> None:
        super().__init__(params)
        n_obs = 2 + params.lookahead + 1
        self.observation_space = spaces.Box(0.0, 1.0, (n_obs,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        first_time = float(particle.time_to_ground(params.drop_height, 0.0, params.radius, params.gravity))
        self._constants = np.array([*(getattr(params, name) for name in STEP_CONSTANTS), first_time], np.float64)
        self._offsets = np.array(
            [rng.stream_offset(_FIRST_TARGET_STREAM), rng.stream_offset(_TARGET_RATIO_STREAM)], dtype=np.uint64
        )
        self.row_width = (0,) * (params.lookahead + 1)
        """The targets' row width, ``lookahead + 1``, as the length of a tuple for the kernels: numba types a tuple
        by its length, so each width gets a kernel of its own in which the width is a constant."""

    @property
    def control_rate(self) -> float:
        """Bounces per simulated second of a ball bouncing to the middle of the target range: one step is one
        bounce, whose flight ``2 sqrt(2 (h - r) / g)`` lasts as long as its apex h asks (0.94 per second with the
        defaults; the reference controller's episodes average about 1)."""
        p = self.params
        middle = 0.5 * (p.target_min + p.target_max)
        return 1.0 / (2.0 * float(particle.time_to_ground(middle, 0.0, p.radius, p.gravity)))

    def targets(self, keys: np.ndarray, count: int) -> np.ndarray:
        """The first ``count`` target apex heights (m) of each episode, shape (n, count)."""
        return _targets_kernel(np.ascontiguousarray(keys, dtype=np.uint64), count, self._constants, self._offsets)

    def initial_state(self, keys: np.ndarray) -> State:
        p = self.params
        n = len(keys)
        return {
            "speed": np.full(n, p.drop_speed),
            "time": np.full(n, self._constants[-1]),
            "targets": self.targets(keys, p.lookahead + 1),
            "error_sum": np.zeros(n),
        }

    def start(self, state: State, keys: np.ndarray, rows: np.ndarray) -> None:
        _start(
            keys, rows, state["speed"], state["time"], state["targets"], state["error_sum"], self._constants,
            self._offsets,
        )  # fmt: skip

    def restart_call(self, state: State, rows: np.ndarray, obs: np.ndarray) -> KernelCall | None:
        return _restart_kernel, (
            state["key"], rows, state["speed"], state["time"], state["targets"], state["error_sum"], self._constants,
            self._offsets, obs,
        )  # fmt: skip

    def output_shapes(self) -> dict[str, tuple[tuple[int, ...], type]]:
        return {
            "impact_speed": ((), np.float64),
            "restitution": ((), np.float64),
            "apex_height": ((), np.float64),
            "target_height": ((), np.float64),
            "terms": ((len(REWARD_TERMS),), np.float64),
            "success": ((), np.bool_),
        }

    def step_call(self, state: State, action: np.ndarray, out: State) -> KernelCall:
        return _step_kernel, (
            action, state["speed"], state["time"], state["targets"], state["error_sum"], state["key"], state["step"],
            self._constants, self._offsets, out["impact_speed"], out["restitution"], out["apex_height"],
            out["target_height"], out["terms"], out["reward"], out["success"], out["terminated"], out["obs"],
            self.row_width,
        )  # fmt: skip

    def info(self, state: State, out: State) -> Info:
        return {
            "impact_speed": out["impact_speed"],
            "restitution": out["restitution"],
            "apex_height": out["apex_height"],
            "target_height": out["target_height"],
            "radius": self.params.radius,
            "gravity": self.params.gravity,
            "reward_terms": dict(zip(REWARD_TERMS, out["terms"].T, strict=True)),
            "is_success": out["success"],
        }

    def observe(self, state: State, obs: np.ndarray) -> None:
        _observe_kernel(state["speed"], state["targets"], self._constants, obs, self.row_width)

    def observe_rows(self, state: State, rows: np.ndarray, obs: np.ndarray) -> None:
        _observe_rows_kernel(rows, state["speed"], state["targets"], self._constants, obs)


def optimal_apexes(targets: np.ndarray, start_apex: float, radius: float) -> np.ndarray:
    """The apex sequence (m) that minimises the summed absolute apex error; exact.

    Restitution ``e <= 1`` can only remove energy, so the achievable apex sequences are exactly the
    non-increasing ones in ``[radius, start_apex]``: the optimum is the L1 antitonic regression of the targets
    under that box. An L1 optimum takes its values among the (clipped) targets, so a dynamic program over
    those candidate levels, ``cost[k, j] = |c_j - t_k| + min_{i >= j} cost[k-1, i]``, is exact (O(N^2)).
    """
    targets = np.asarray(targets, dtype=np.float64)
    levels = np.unique(np.clip(np.append(targets, start_apex), radius, start_apex))
    cost = np.abs(levels[None, :] - targets[:, None])
    total = cost[0].copy()
    best_from = np.zeros((len(targets), len(levels)), dtype=np.int64)
    for k in range(1, len(targets)):
        best = len(levels) - 1
        for j in range(len(levels) - 1, -1, -1):
            if total[j] < total[best]:
                best = j
            best_from[k, j] = best
        total = cost[k] + total[best_from[k]]
    plan = np.empty(len(targets), dtype=np.int64)
    plan[-1] = int(np.argmin(total))
    for k in range(len(targets) - 1, 0, -1):
        plan[k - 1] = best_from[k, plan[k]]
    return levels[plan]


class BouncingBallEnv(VegymEnv[BouncingBallParams]):
    """Restitution tuning: a ball bounces vertically on a flat floor and must reach target apex heights.

    ## Description
    The falling particle of the chapter (8.1-8.18, corrected as in PHYSICS.md section 1), dropped from rest
    at ``drop_height``. One step is one impact: the action chooses the coefficient of restitution e for the
    impact about to happen; the env resolves it exactly (event-driven, no penetration, no time-step error:
    rebound speed ``e * v``, apex ``r + (e v)^2 / 2g``, next impact speed ``e * v``). Each bounce has a target
    apex height; since e <= 1 only removes energy, spending it on a low target can make a later high one
    unreachable, so a good agent plans with the lookahead.

    ## Action Space
    ``Box(-1, 1, (1,), float32)``: ``e = (a + 1) / 2`` in [0, 1].

    ## Observation Space
    ``Box(0, 1, (3 + lookahead,), float32)``: ``[v / v_drop, (v / v_drop)^2, (t_0 - r) / H, ..., (t_K - r)/H]``
    with v the coming impact speed, ``v_drop`` the first impact speed, ``(v / v_drop)^2`` the highest apex
    still reachable (same scale as the targets), ``t_k`` the current (k = 0) and next K = lookahead target
    apex heights and ``H = drop_height - radius``.

    ## Rewards
    ``-|apex - target| / H`` per bounce (``info["reward_terms"]["apex_error"]``). A ball that comes to rest
    before ``episode_bounces`` is also charged the error of every planned bounce it skips, as if it lay at
    ``h = r`` for them (term ``rest``), so ending the episode early never pays.

    ## Starting State
    Ball released at rest from ``drop_height``. The first target is uniform in ``[target_min, target_max]``;
    each next one is the previous times a ratio uniform in ``[target_ratio_min, target_ratio_max]``, clipped
    to that range: a random walk that rises about as often as it falls (at the defaults, 47% and 49% of the
    steps), each rise reachable only with energy saved on earlier bounces. Targets depend on the episode seed
    only, never on the actions.

    ## Episode End
    Terminated when the ball comes to rest (rebound speed below ``rest_speed``, e.g. e = 0); truncated after
    ``max_episode_steps`` bounces (10 when registered, equal to ``episode_bounces``). ``info["is_success"]``: the
    mean apex error so far (over all planned bounces once at rest), in units of H, is at most ``success_error``.

    ## Arguments
    ``gymnasium.make("vegym/BouncingBall-v0", render_mode=None, **params)`` with the fields of
    :class:`BouncingBallParams`. ``info`` per step: ``impact_speed``, ``restitution``, ``apex_height``,
    ``target_height``, ``radius``, ``gravity`` (SI), ``reward_terms``, ``is_success``.
    Reference controllers (in ``agents.analytic``): the myopic ``e = sqrt(2 g (h* - r)) / v`` (the baseline),
    planning with :func:`optimal_apexes` over the shown targets (from the observation alone) and the exact
    optimum, which knows the episode's every target. Over seeds 0-199 their mean returns are -0.59, -0.43 and
    -0.34 (``tests/test_bouncing_ball.py``).
    Another episode length takes both ``episode_bounces=N`` and ``max_episode_steps=N``: the task plans for
    ``episode_bounces``, and ``max_episode_steps`` alone only moves the time limit. A shorter one cuts episodes,
    whose rest charge still counts the planned bounces; a longer one outlives the plan and warns (a vector env when
    made, a single env at the step past the plan).
    ``episode_bounces`` alone keeps the registered time limit, with the same effects: it cuts a longer plan and is
    outlived by a shorter one. A vector env warns when made; a single env cannot see its limit and warns only at a step
    past its plan (``vegym`` train, evaluate and compare make the plan the time limit).

    ## Version History
    * v0: initial version.
    """

    task_cls = BouncingBallTask


class BouncingBallVectorEnv(VegymVectorEnv[BouncingBallParams]):
    """Native vector twin of :class:`BouncingBallEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = BouncingBallTask
