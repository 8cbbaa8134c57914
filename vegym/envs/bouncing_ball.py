"""BouncingBall-v0: choose the coefficient of restitution at each impact to reach target apex heights."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from vegym import rng
from vegym.envs.base import Task, Transition, VegymEnv, VegymVectorEnv
from vegym.params import Params, invalid, param
from vegym.physics import particle
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


class BouncingBallTask(Task[BouncingBallParams]):
    """Batched logic of BouncingBall-v0 (see :class:`BouncingBallEnv`)."""

    params_cls = BouncingBallParams
    renderer = "vegym.render.bouncing_ball:BouncingBallRenderer"

    def __init__(self, params: BouncingBallParams) -> None:
        super().__init__(params)
        n_obs = 2 + params.lookahead + 1
        self.observation_space = spaces.Box(0.0, 1.0, (n_obs,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)

    @property
    def control_rate(self) -> float:
        return 2.0

    def next_target(self, keys: np.ndarray, previous: np.ndarray, index: np.ndarray) -> np.ndarray:
        """Target number ``index`` (n,) of each episode, from target ``index - 1`` (``previous``, m).

        Targets follow a random walk, ``t_k = clip(t_{k-1} * U(target_ratio_min, target_ratio_max),
        target_min, target_max)``, drawn from the episode key alone (never from the actions).
        """
        p = self.params
        ratio = rng.uniform_in(keys, _TARGET_RATIO_STREAM, p.target_ratio_min, p.target_ratio_max, counter=index)
        return np.clip(previous * ratio[:, 0], p.target_min, p.target_max)

    def targets(self, keys: np.ndarray, count: int) -> np.ndarray:
        """The first ``count`` target apex heights (m) of each episode, shape (n, count)."""
        p = self.params
        sequence = [rng.uniform_in(keys, _FIRST_TARGET_STREAM, p.target_min, p.target_max)[:, 0]]
        for index in range(1, count):
            sequence.append(self.next_target(keys, sequence[-1], np.full(len(keys), index)))
        return np.stack(sequence, axis=-1)

    def initial_state(self, keys: np.ndarray) -> dict[str, np.ndarray]:
        p = self.params
        n = len(keys)
        return {
            "speed": np.full(n, p.drop_speed),
            "time": np.full(n, float(particle.time_to_ground(p.drop_height, 0.0, p.radius, p.gravity))),
            "targets": self.targets(keys, p.lookahead + 1),
            "error_sum": np.zeros(n),
        }

    def step(self, state: dict[str, np.ndarray], action: np.ndarray) -> Transition:
        p = self.params
        e = 0.5 * (action[:, 0] + 1.0)
        speed = state["speed"]
        incoming = np.stack([np.zeros_like(speed), -speed, np.zeros_like(speed)], axis=-1)
        rebound = particle.restitute(incoming, np.array([0.0, 1.0, 0.0]), e)[:, 1]
        at_rest = rebound < p.rest_speed
        rebound = np.where(at_rest, 0.0, rebound)
        apex = particle.apex_height(p.radius, rebound, p.gravity)
        flight = particle.time_to_ground(np.full_like(rebound, p.radius), rebound, p.radius, p.gravity)
        next_speed = -particle.impact_velocity(p.radius, rebound, p.radius, p.gravity)
        target = state["targets"][:, 0]
        error = np.abs(apex - target) / p.height_scale
        bounces = state["step"] + 1
        rest_cost = self.rest_cost(state["key"], bounces, at_rest)
        error_sum = state["error_sum"] + error + rest_cost
        counted = np.where(at_rest, np.maximum(bounces, p.episode_bounces), bounces)
        new_target = self.next_target(state["key"], state["targets"][:, -1], state["step"] + p.lookahead + 1)
        new_state = {
            "speed": next_speed,
            "time": state["time"] + np.where(at_rest, 0.0, flight),
            "targets": np.concatenate([state["targets"][:, 1:], new_target[:, None]], axis=1),
            "error_sum": error_sum,
        }
        info = {
            "impact_speed": speed,
            "restitution": e,
            "apex_height": apex,
            "target_height": target,
            "radius": np.full_like(speed, p.radius),
            "gravity": np.full_like(speed, p.gravity),
            "reward_terms": {"apex_error": -error, "rest": -rest_cost},
            "is_success": error_sum / counted <= p.success_error,
        }
        return Transition(new_state, -error - rest_cost, at_rest, info)

    def rest_cost(self, keys: np.ndarray, bounces: np.ndarray, at_rest: np.ndarray) -> np.ndarray:
        """Normalised apex error of every planned bounce left after ``bounces`` (n,), for balls coming to rest.

        A ball at rest stays at ``h = radius``: charging the errors of the bounces it skips keeps resting from
        being a way out of the remaining targets (all rewards are negative). Zero where not at rest.
        """
        p = self.params
        cost = np.zeros(len(keys))
        if at_rest.any():
            targets = self.targets(keys[at_rest], p.episode_bounces)
            skipped = np.arange(p.episode_bounces)[None, :] >= bounces[at_rest][:, None]
            cost[at_rest] = np.sum(np.where(skipped, targets - p.radius, 0.0), axis=1) / p.height_scale
        return cost

    def observe(self, state: dict[str, np.ndarray]) -> np.ndarray:
        p = self.params
        speed = state["speed"] / p.drop_speed
        reachable = speed * speed
        targets = (state["targets"] - p.radius) / p.height_scale
        return np.concatenate([speed[:, None], reachable[:, None], targets], axis=1).astype(np.float32)


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
