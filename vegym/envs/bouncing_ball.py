"""BouncingBall-v0: choose the coefficient of restitution at each impact to reach target apex heights."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs.base import Task, Transition, VegymEnv, VegymVectorEnv
from vegym.params import Params, invalid, param
from vegym.physics import particle
from vegym.physics.columns import pairwise_sum
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
        10, "planned episode length (bounces), the registered max_episode_steps: resting earlier is charged", low=1
    )
    success_error: float = param(
        0.05, "is_success: mean apex error over the episode, in units of drop_height - radius, at most this", low=0.0
    )

    def validate(self) -> None:
        if not self.radius < self.target_min:
            raise invalid("target_min", self.target_min, f"(radius={self.radius}, target_max={self.target_max}]")
        if not self.target_min <= self.target_max <= self.drop_height:
            raise invalid(
                "target_max", self.target_max, f"[target_min={self.target_min}, drop_height={self.drop_height}]"
            )
        if self.target_ratio_min > self.target_ratio_max:
            raise invalid("target_ratio_min", self.target_ratio_min, f"(0, target_ratio_max={self.target_ratio_max}]")

    @property
    def particle(self) -> ParticleParams:
        """The falling-particle physics parameters."""
        return ParticleParams(gravity=self.gravity, radius=self.radius)

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
"""Parameters the kernels read, in the order of their constants array (SI units, see the fields)."""


@njit(cache=True)
def _target(key: np.uint64, index: int, previous: float, c: np.ndarray, offsets: np.ndarray) -> float:
    """Target apex number ``index`` (m) of the episode ``key``, from target ``index - 1`` (``previous``, unused for
    the first). Targets follow a random walk, ``t_k = clip(t_{k-1} U(target_ratio_min, target_ratio_max),
    target_min, target_max)`` from ``t_0 = U(target_min, target_max)``, drawn from the episode key alone (never
    from the actions); ``offsets`` are the rng stream offsets of the first target and of the ratios."""
    target_min, target_max, ratio_min, ratio_max = c[6], c[7], c[8], c[9]
    if index == 0:
        return target_min + (target_max - target_min) * rng.lane(rng.stream_base(key, offsets[0], np.uint64(0)), 0)
    u = rng.lane(rng.stream_base(key, offsets[1], np.uint64(index)), 0)
    return min(max(previous * (ratio_min + (ratio_max - ratio_min) * u), target_min), target_max)


@njit(cache=True)
def _fill_targets(key: np.uint64, out: np.ndarray, c: np.ndarray, offsets: np.ndarray) -> None:
    """The first ``len(out)`` targets (m) of the episode ``key``, written into ``out``."""
    previous = 0.0
    for k in range(len(out)):
        previous = out[k] = _target(key, k, previous, c, offsets)


@njit(cache=True)
def _targets_kernel(keys: np.ndarray, count: int, c: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    out = np.empty((len(keys), count))
    for i in range(len(keys)):
        _fill_targets(keys[i], out[i], c, offsets)
    return out


@njit(cache=True)
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
) -> tuple[np.ndarray, ...]:
    """One impact per episode, fused; ``c`` holds the parameters named in ``STEP_CONSTANTS``."""
    radius, gravity, rest_speed, height_scale, bounces_planned, success_error = c[0], c[1], c[2], c[3], c[4], c[5]
    n, lookahead = len(action), targets.shape[1] - 1
    out = np.empty((6, n))  # next speed, time, error sum, restitution, apex, target
    new_targets, terms, reward = np.empty_like(targets), np.empty((2, n)), np.empty(n)
    at_rest, success = np.empty(n, np.bool_), np.empty(n, np.bool_)
    skipped = np.empty(int(bounces_planned))
    for i in range(n):
        e = 0.5 * (action[i, 0] + 1.0)
        rebound = -speed[i] - particle.normal_impulse_one(-speed[i], e)
        at_rest[i] = rebound < rest_speed
        if at_rest[i]:
            rebound = 0.0
        apex = particle.apex_height_one(radius, rebound, gravity)
        flight = particle.ground_time_one(radius, rebound, radius, gravity)
        error = abs(apex - targets[i, 0]) / height_scale
        bounces = step[i] + 1
        rest_cost = 0.0
        if at_rest[i]:  # charge every planned bounce skipped, as if at h = radius
            _fill_targets(keys[i], skipped, c, offsets)
            for k in range(len(skipped)):
                skipped[k] = skipped[k] - radius if k >= bounces else 0.0
            rest_cost = pairwise_sum(skipped) / height_scale
        errors = error_sum[i] + error + rest_cost
        counted = max(bounces, bounces_planned) if at_rest[i] else bounces
        success[i] = errors / counted <= success_error
        new_targets[i, :lookahead] = targets[i, 1:]
        new_targets[i, lookahead] = _target(keys[i], step[i] + lookahead + 1, targets[i, lookahead], c, offsets)
        out[0, i] = -particle.impact_velocity_one(radius, rebound, radius, gravity)
        out[1, i] = time[i] + (0.0 if at_rest[i] else flight)
        out[2, i], out[3, i], out[4, i], out[5, i] = errors, e, apex, targets[i, 0]
        terms[0, i], terms[1, i] = -error, -rest_cost
        reward[i] = -error - rest_cost
    return out, new_targets, terms, reward, at_rest, success


@njit(cache=True)
def _observe_kernel(speed: np.ndarray, targets: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Observations (n, 3 + lookahead); ``c`` holds the parameters named in ``STEP_CONSTANTS``."""
    radius, height_scale, drop_speed = c[0], c[3], c[10]
    n, m = targets.shape
    obs = np.empty((n, 2 + m), np.float32)
    for i in range(n):
        v = speed[i] / drop_speed
        obs[i, 0], obs[i, 1] = v, v * v
        for k in range(m):
            obs[i, 2 + k] = (targets[i, k] - radius) / height_scale
    return obs


class BouncingBallTask(Task[BouncingBallParams]):
    """Batched logic of BouncingBall-v0 (see :class:`BouncingBallEnv`)."""

    params_cls = BouncingBallParams
    renderer = "vegym.render.bouncing_ball:BouncingBallRenderer"

    def __init__(self, params: BouncingBallParams) -> None:
        super().__init__(params)
        n_obs = 2 + params.lookahead + 1
        self.observation_space = spaces.Box(0.0, 1.0, (n_obs,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        self._constants = np.array([getattr(params, name) for name in STEP_CONSTANTS], dtype=np.float64)
        self._offsets = np.array(
            [rng.stream_offset(_FIRST_TARGET_STREAM), rng.stream_offset(_TARGET_RATIO_STREAM)], dtype=np.uint64
        )
        self._first_time = float(particle.time_to_ground(params.drop_height, 0.0, params.radius, params.gravity))

    @property
    def control_rate(self) -> float:
        return 2.0

    def targets(self, keys: np.ndarray, count: int) -> np.ndarray:
        """The first ``count`` target apex heights (m) of each episode, shape (n, count)."""
        return _targets_kernel(np.ascontiguousarray(keys, dtype=np.uint64), count, self._constants, self._offsets)

    def initial_state(self, keys: np.ndarray) -> dict[str, np.ndarray]:
        p = self.params
        n = len(keys)
        return {
            "speed": np.full(n, p.drop_speed),
            "time": np.full(n, self._first_time),
            "targets": self.targets(keys, p.lookahead + 1),
            "error_sum": np.zeros(n),
        }

    def step(self, state: dict[str, np.ndarray], action: np.ndarray) -> Transition:
        p = self.params
        out, targets, terms, reward, at_rest, success = _step_kernel(
            action, state["speed"], state["time"], state["targets"], state["error_sum"], state["key"], state["step"],
            self._constants, self._offsets,
        )  # fmt: skip
        speed, time, error_sum, e, apex, target = out
        new_state = {"speed": speed, "time": time, "targets": targets, "error_sum": error_sum}
        info = {
            "impact_speed": state["speed"],
            "restitution": e,
            "apex_height": apex,
            "target_height": target,
            "radius": np.full(len(speed), p.radius),
            "gravity": np.full(len(speed), p.gravity),
            "reward_terms": {"apex_error": terms[0], "rest": terms[1]},
            "is_success": success,
        }
        return Transition(new_state, reward, at_rest, info)

    def observe(self, state: dict[str, np.ndarray]) -> np.ndarray:
        return _observe_kernel(state["speed"], state["targets"], self._constants)


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
    to that range: mostly descending, with rises a planner must save energy for. Targets depend on the
    episode seed only, never on the actions.

    ## Episode End
    Terminated when the ball comes to rest (rebound speed below ``rest_speed``, e.g. e = 0); truncated after
    ``max_episode_steps`` bounces (10 when registered, equal to ``episode_bounces``). ``info["is_success"]``: the
    mean apex error so far (over all planned bounces once at rest), in units of H, is at most ``success_error``.

    ## Arguments
    ``gymnasium.make("vegym/BouncingBall-v0", render_mode=None, **params)`` with the fields of
    :class:`BouncingBallParams`. ``info`` per step: ``impact_speed``, ``restitution``, ``apex_height``,
    ``target_height``, ``radius``, ``gravity`` (SI), ``reward_terms``, ``is_success``.
    Reference controllers: the myopic ``e = sqrt(2 g (h* - r)) / v`` and the exact optimum
    :func:`optimal_apexes` (in ``agents.analytic``).

    ## Version History
    * v0: initial version.
    """

    task_cls = BouncingBallTask


class BouncingBallVectorEnv(VegymVectorEnv[BouncingBallParams]):
    """Native vector twin of :class:`BouncingBallEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = BouncingBallTask
