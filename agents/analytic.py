"""The chapter's analytic controllers, with the ``predict`` contract of a stable-baselines3 policy.

Each controller reads the env's fixed parameters once, at construction, and then acts from the
observation alone: ``predict(obs, state=None, episode_start=None, deterministic=False) -> (action, state)``
accepts one observation (obs_dim,) or a batch (n, obs_dim) and returns float32 actions in [-1, 1] of the
matching shape. :func:`controller_for` builds the reference controller of any vegym env (single, wrapped
or native vector).
"""

from __future__ import annotations

import abc
import functools
import math
from collections.abc import Callable
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from vegym.envs.aircraft import AircraftEnvParams, AircraftTask
from vegym.envs.base import Task, VegymEnv, VegymVectorEnv
from vegym.envs.billiards import BilliardsParams, BilliardsTask, ghost_ball_shot
from vegym.envs.bouncing_ball import BouncingBallParams, BouncingBallTask, optimal_apexes
from vegym.envs.gear_train import GearTrainParams, GearTrainTask
from vegym.envs.pendulum_pump import PendulumPumpParams, PendulumPumpTask
from vegym.envs.projectile import AZIMUTH_LIMIT, ELEVATION_LIMIT, ProjectileEnvParams, ProjectileTask
from vegym.envs.projectile_adjust import (
    ProjectileAdjustParams,
    ProjectileAdjustTask,
    observed_miss,
    wind_from_shot,
)
from vegym.envs.steerable_wheel import SteerableWheelParams, SteerableWheelTask
from vegym.envs.suspension import SuspensionParams, SuspensionTask
from vegym.envs.thread import ThreadEnvParams, ThreadTask
from vegym.physics import aircraft, pendulum, projectile, suspension, thread


def observation_batch(observation: Any, shape: tuple[int, ...], agent: str) -> tuple[np.ndarray, bool]:
    """``observation`` as a float64 batch ``(n, *shape)`` and whether it was a single observation ``shape``.

    ValueError, as SB3's ``predict`` raises it, for the ``(obs, info)`` pair that ``reset`` returns, for another
    shape, and (where an SB3 policy would act on garbage or fail inside torch) for a NaN or inf entry.
    """
    if isinstance(observation, tuple) and len(observation) == 2 and isinstance(observation[1], dict):
        raise ValueError(
            f"{agent}.predict got a tuple (observation, info), the output of reset() or step(); pass only the "
            "observation, e.g. obs, info = env.reset(); action, _ = agent.predict(obs)"
        )
    obs = np.asarray(observation, dtype=np.float64)
    single = obs.shape == shape
    if not single and obs.shape[1:] != shape:
        raise ValueError(f"{agent}.predict: unexpected observation shape {obs.shape}; use {shape} or (n_env, *{shape})")
    if not np.isfinite(obs).all():
        raise ValueError(f"{agent}.predict: the observation has NaN or inf entries: {observation!r}")
    return (obs[None] if single else obs), single


class AnalyticController(abc.ABC):
    """Base: batching, the checks and the SB3 ``predict`` signature around :meth:`act`."""

    task_cls: ClassVar[type[Task]]
    """The task whose observations the controller reads; :attr:`params` are its parameters."""
    params: Any

    @abc.abstractmethod
    def act(self, obs: np.ndarray) -> np.ndarray:
        """Actions (n, action_dim) in [-1, 1] for observations (n, obs_dim)."""

    @functools.cached_property
    def spaces(self) -> tuple[gym.spaces.Box, gym.spaces.Box]:
        """The single-env observation and action spaces of :attr:`task_cls` with :attr:`params`."""
        task = self.task_cls(self.params)
        return task.observation_space, task.action_space

    def predict(
        self,
        observation: np.ndarray,
        state: Any = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = False,
    ) -> tuple[np.ndarray, Any]:
        observation_space, action_space = self.spaces
        obs, single = observation_batch(observation, observation_space.shape, type(self).__name__)
        if len(obs) == 0:
            return np.empty((0, *action_space.shape), np.float32), state
        action = np.clip(self.act(obs), -1.0, 1.0).astype(np.float32)
        return (action[0] if single else action), state


def restitution_action(speed: np.ndarray, apex: np.ndarray) -> np.ndarray:
    """Actions (n, 1) of the restitution law that sends a ball at impact ``speed`` to ``apex``, both in
    BouncingBall's observation units: ``e = sqrt(apex) / speed`` in [0, 1] (0 for a ball at rest)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(speed > 0, np.sqrt(apex) / speed, 0.0)
    return (2.0 * np.clip(e, 0.0, 1.0) - 1.0)[:, None]


class BouncingBallLaw(AnalyticController):
    """Base of the restitution laws acting from BouncingBall's observation."""

    task_cls = BouncingBallTask

    def __init__(self, params: BouncingBallParams) -> None:
        self.params = params


class BouncingBallMyopic(BouncingBallLaw):
    """The chapter's restitution law aimed at the current target: ``e = sqrt(2 g (h* - r)) / v``, in [0, 1].

    In the observation's units (``v / v_drop`` and ``(h* - r) / (drop_height - r)``) this is
    ``e = sqrt(target) / speed``, since ``v_drop^2 = 2 g (drop_height - r)``.
    """

    def act(self, obs: np.ndarray) -> np.ndarray:
        return restitution_action(obs[:, 0], obs[:, 2])


class BouncingBallPlanner(BouncingBallLaw):
    """Receding-horizon planning over the observed targets: a stronger reference on BouncingBall-v0.

    At each impact it plans the apexes of the shown targets (the current one and the ``lookahead`` next ones) as
    the oracle plans the episode's (:func:`~vegym.envs.bouncing_ball.optimal_apexes`, from the highest apex still
    reachable) and aims at the plan's first apex with the restitution law. It acts from the observation alone; it
    sees neither the targets past the lookahead nor where the episode ends.
    """

    def act(self, obs: np.ndarray) -> np.ndarray:
        reachable, targets = obs[:, 1], obs[:, 2:]
        first = np.array([optimal_apexes(t, r, 0.0)[0] for t, r in zip(targets, reachable, strict=True)])
        return restitution_action(obs[:, 0], first)


class BouncingBallOracle:
    """The exact optimum of BouncingBall: knows the whole target sequence of the episode (privileged).

    Not an observation-only controller: it reads the episode key of a single env at each episode start,
    derives the episode's targets (they do not depend on the actions) and follows
    :func:`~vegym.envs.bouncing_ball.optimal_apexes`. It is the upper bound agents are measured against. Its plan
    spans the episode's planned bounces (``episode_bounces``, or the env's shorter time limit); past them it aims at
    the current target, as :class:`BouncingBallMyopic`.
    """

    def __init__(self, env: Any, episode_length: int | None = None) -> None:
        """``episode_length``: the bounces to plan (default the episode's)."""
        if not isinstance(env.unwrapped, VegymEnv):
            raise ValueError(f"BouncingBallOracle reads one episode's targets: it needs a single env, not {env!r}")
        self.env = env.unwrapped
        self.params: BouncingBallParams = self.env.params
        limit = env.spec.max_episode_steps if env.spec is not None else None
        self.episode_length = int(episode_length or min(self.params.episode_bounces, limit or math.inf))
        self._plan = np.zeros(0)

    def predict(
        self,
        observation: np.ndarray,
        state: Any = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = False,
    ) -> tuple[np.ndarray, Any]:
        p = self.params
        obs, single = observation_batch(observation, self.env.observation_space.shape, type(self).__name__)
        if len(obs) != 1:
            raise ValueError(f"BouncingBallOracle acts for its one env; got a batch of {len(obs)} observations")
        step = int(self.env.state["step"][0])
        if step == 0:
            targets = self.env.task.targets(self.env.state["key"], self.episode_length)[0]
            self._plan = optimal_apexes(targets, p.drop_height, p.radius)
        if step < len(self._plan):
            action = restitution_action(obs[:, 0], np.array([(self._plan[step] - p.radius) / p.height_scale]))
        else:  # an episode that outlives its plan (the env warns): the current target, as the myopic law
            action = restitution_action(obs[:, 0], obs[:, 2])
        action = action.astype(np.float32)
        return (action[0] if single else action), state


class ProjectileFiringSolution(AnalyticController):
    """Direct fire at full speed: the low-angle root of the wind quartic (PHYSICS.md section 6).

    From the observation (target distance, launch height, wind along and across the line of fire) it
    rebuilds the target offset in the target's frame, ``delta = (D, r - h, 0)``, and fires at ``speed_max``
    with the smallest positive flight time (direct fire, not the lob). The azimuth it returns is already
    relative to the target's bearing.
    """

    task_cls = ProjectileTask

    def __init__(self, params: ProjectileEnvParams) -> None:
        self.params = params
        self.physics = params.physics

    def act(self, obs: np.ndarray) -> np.ndarray:
        p = self.params
        n = len(obs)
        zeros = np.zeros(n)
        delta = np.stack([obs[:, 0] * p.target_distance_max, p.radius - obs[:, 1] * p.height_scale, zeros], axis=-1)
        wind = np.stack([obs[:, 2] * p.wind_scale, zeros, obs[:, 3] * p.wind_scale], axis=-1)
        elevation, azimuth, _, _ = projectile.firing_solution(delta, wind, p.speed_max, self.physics)
        return np.stack([elevation / ELEVATION_LIMIT, azimuth / AZIMUTH_LIMIT, np.ones(n)], axis=-1)


class SteerableWheelPurePursuit(AnalyticController):
    """Pure pursuit toward the current waypoint (PHYSICS.md section 3), from the observation alone.

    With the relative bearing eta (``obs[1:3]`` = sin, cos) and the distance D, the curvature of the arc through
    a point ``L_d = clip(D, min_lookahead, max_lookahead)`` ahead along the bearing is ``kappa = 2 sin(eta) / L_d``;
    a waypoint behind (``cos eta < 0``) gets the full ``2 sign(eta) / L_d`` (a left turn for one dead behind).
    Capping L_d turns the wheel onto the bearing early instead of along one wide arc that can leave the arena.
    The speed command is the fastest at which that curvature is within the yaw-rate limit, ``min(max_speed,
    max_yaw_rate / |kappa|)``, and the yaw rate ``kappa v`` uses the speed the step will apply (the observed
    speed moved toward the command by at most ``max_acceleration dt``), clipped to ``max_yaw_rate``.
    """

    task_cls = SteerableWheelTask

    def __init__(self, params: SteerableWheelParams, min_lookahead: float = 1.0, max_lookahead: float = 2.0) -> None:
        self.params = params
        self.min_lookahead = min_lookahead
        self.max_lookahead = max_lookahead

    def act(self, obs: np.ndarray) -> np.ndarray:
        p = self.params
        distance, sin_eta, cos_eta = obs[:, 0] * p.diagonal, obs[:, 1], obs[:, 2]
        lateral = np.where(cos_eta >= 0.0, sin_eta, np.where(sin_eta >= 0.0, 1.0, -1.0))
        curvature = 2.0 * lateral / np.clip(distance, self.min_lookahead, self.max_lookahead)
        command = p.max_speed / np.maximum(1.0, np.abs(curvature) * p.max_speed / p.max_yaw_rate)
        current = obs[:, 6] * p.max_speed
        dv = p.max_acceleration * p.dt
        speed = np.clip(command, current - dv, current + dv)
        yaw_rate = np.clip(curvature * speed, -p.max_yaw_rate, p.max_yaw_rate)
        return np.stack([2.0 * command / p.max_speed - 1.0, yaw_rate / p.max_yaw_rate], axis=-1)


class AircraftAutopilot(AnalyticController):
    """The chapter's autopilot (PHYSICS.md section 10), from the observation: three decoupled saturated P loops.

    The errors are rebuilt from the observation: altitude and airspeed errors times their scales (exact inside
    them, which covers the unsaturated bands ``V / k_v`` and ``A / k_a`` at the default scales) and the heading
    error ``atan2(sin, cos)``; the commands of :func:`vegym.physics.aircraft.autopilot` are then mapped back onto
    the action box.
    """

    task_cls = AircraftTask

    def __init__(self, params: AircraftEnvParams, gains: aircraft.AutopilotGains | None = None) -> None:
        self.params = params
        self.physics = params.physics
        self.gains = gains if gains is not None else aircraft.AutopilotGains()

    def act(self, obs: np.ndarray) -> np.ndarray:
        p = self.params
        errors = np.stack(
            [obs[:, 0] * p.altitude_scale, obs[:, 1] * p.speed_scale, np.arctan2(obs[:, 2], obs[:, 3])], axis=-1
        )
        return aircraft.action_from_command(aircraft.autopilot(errors, self.physics, self.gains), self.physics)


class ProjectileAdjustFire(AnalyticController):
    """Adjust-fire (PHYSICS.md section 6): the firing solution for the wind estimated from the newest miss.

    Before any shot the wind estimate is zero, so the first shot is the wind-free direct fire at ``speed_max``;
    after a shot, :func:`~vegym.envs.projectile_adjust.wind_from_shot` turns its miss and its action into the
    wind (exact: the miss of the wind-free solution is the wind times the flight time), and the next shot is the
    quartic firing solution for that wind, which hits. A miss that gives no finite wind (a shot that never came
    down to the target's level, possible only in observations no episode makes) counts as no shot.
    """

    task_cls = ProjectileAdjustTask

    def __init__(self, params: ProjectileAdjustParams) -> None:
        self.params = params
        self.physics = params.physics

    def act(self, obs: np.ndarray) -> np.ndarray:
        p = self.params
        n = len(obs)
        zeros = np.zeros(n)
        distance, height = obs[:, 0] * p.target_distance_max, obs[:, 1] * p.height_scale
        fired = obs[:, 3] > 0.5
        wind = np.zeros((n, 3))
        with np.errstate(divide="ignore", invalid="ignore"):
            wind[fired] = wind_from_shot(
                distance[fired], height[fired], observed_miss(obs[fired, 4:6], p), obs[fired, 6:9], p
            )
        wind[~np.isfinite(wind).all(axis=-1)] = 0.0
        delta = np.stack([distance, p.radius - height, zeros], axis=-1)
        elevation, azimuth, _, _ = projectile.firing_solution(delta, wind, p.speed_max, self.physics)
        return np.stack([elevation / ELEVATION_LIMIT, azimuth / AZIMUTH_LIMIT, np.ones(n)], axis=-1)


class BilliardsGhostBall(AnalyticController):
    """The ghost-ball aim (PHYSICS.md section 5) with the strike speed that rests B on the target.

    From the observation (distance A-B, distance and bearing of the target from B in the frame of the line A-B)
    :func:`~vegym.envs.billiards.ghost_ball_shot` gives the cut sine (A's path through the ghost point
    ``c_b - (r_a + r_b) d*``) and the speed: B leaves at ``u_b = sqrt(2 a D)`` along ``d*``, which the impact
    (8.60) and the cloth's deceleration turn into the strike speed.
    """

    task_cls = BilliardsTask

    def __init__(self, params: BilliardsParams) -> None:
        self.params = params

    def act(self, obs: np.ndarray) -> np.ndarray:
        p = self.params
        bearing = np.arctan2(obs[:, 2], obs[:, 3])
        sin_cut, speed = ghost_ball_shot(obs[:, 0] * p.ball_distance_max, obs[:, 1] * p.target_distance_max, bearing, p)
        return np.stack([sin_cut, 2.0 * speed / p.speed_max - 1.0], axis=-1)


class GearTrainProportional(AnalyticController):
    """Saturated proportional control through the ratio (PHYSICS.md section 2), from the observation.

    With the wrapped output error ``e = atan2(sin, cos)`` and the ratio ``rho = omega_out / omega_in`` (observed),
    the output speed demand is ``k e`` and the motor command ``omega_in = clip(k e / rho, +-max_speed)``. The
    default gain ``k = 1 / (2 dt)`` would halve the error each step with a motor that took its command at once;
    the motor's acceleration limit lags it (a reversal from full speed takes 10 steps at the defaults), so the
    output overshoots before it settles: by 5.7 degrees on average after a new target, 31 at most, over the first
    episodes of seeds 0-49. A law that brakes within the acceleration limit, an output speed demand
    ``sign(e) min(k |e|, sqrt(2 a |e|))`` with half the output's largest deceleration, ``a = max_acceleration
    |rho| / 2``, does not overshoot, and its return is about the same (-0.189 against -0.188).
    """

    task_cls = GearTrainTask

    def __init__(self, params: GearTrainParams, gain: float | None = None) -> None:
        self.params = params
        self.gain = gain if gain is not None else 0.5 / params.dt

    def act(self, obs: np.ndarray) -> np.ndarray:
        p = self.params
        error = np.arctan2(obs[:, 0], obs[:, 1])
        ratio = obs[:, 3] * p.ratio_max
        # 0 for a ratio of 0, which the observation space holds and no episode shows
        demand = np.divide(self.gain * error, ratio, out=np.zeros_like(error), where=ratio != 0.0)
        return (np.clip(demand, -p.max_speed, p.max_speed) / p.max_speed)[:, None]


class SuspensionDamperLaw(AnalyticController):
    """Base of the semi-active damper laws: a damper coefficient (N s/m) mapped onto the action."""

    task_cls = SuspensionTask

    def __init__(self, params: SuspensionParams) -> None:
        self.params = params

    def action(self, damping: np.ndarray) -> np.ndarray:
        """Actions (n, 1) that set the dampers to ``damping`` (n,) (N s/m), in ``[damping_min, damping_max]`` (0 where
        the two are equal)."""
        p = self.params
        span = p.damping_max - p.damping_min
        if span == 0.0:  # one damping: every action sets it
            return np.zeros((len(damping), 1))
        return (2.0 * (damping - p.damping_min) / span - 1.0)[:, None]


class SuspensionSkyhook(SuspensionDamperLaw):
    """On-off skyhook (PHYSICS.md section 8): the stiffest damper when ``v (v - v_b) > 0``, else the softest.

    The damper force ``-c (v - v_b)`` then opposes the body's absolute velocity v whenever it can, as a damper to
    a fixed "sky" would. Only the signs of the observed body and relative velocities matter, and clipping keeps
    them.
    """

    def act(self, obs: np.ndarray) -> np.ndarray:
        p = self.params
        return self.action(suspension.skyhook_damping(obs[:, 1], obs[:, 2], p.damping_min, p.damping_max))


class SuspensionContinuousSkyhook(SuspensionDamperLaw):
    """Continuous (clipped) skyhook: the stronger reference on Suspension-v0.

    Where the on-off law is stiff, the damper takes the coefficient whose force ``-c (v - v_b)`` equals the sky
    damper's ``-c_sky v``, clipped to ``[c_min, c_max]``, with ``c_sky = c_max``
    (:func:`~vegym.physics.suspension.continuous_skyhook_damping`); it follows the sky force instead of switching
    between the extremes. It needs the ratio of the observed velocities, exact unless one of them is clipped.
    """

    def act(self, obs: np.ndarray) -> np.ndarray:
        p = self.params
        c_max, c_min = p.damping_max, p.damping_min
        return self.action(suspension.continuous_skyhook_damping(obs[:, 1], obs[:, 2], c_max, c_min, c_max))


class PendulumEnergyPumping(AnalyticController):
    """Energy pumping (PHYSICS.md section 7): ``tau = sat(k_E (E* - E) omega, +-tau_max)``, from the observation.

    The angle is ``atan2(sin, cos)``, the angular velocity and the target amplitude are rescaled (exact unless the
    angular velocity is clipped, where the torque saturates anyway); the torque's power ``k_E (E* - E) omega^2``
    moves the energy toward the target's ``E* = m g L (1 - cos theta*)``. ``gain`` k_E is in N m per (J rad/s).
    """

    task_cls = PendulumPumpTask

    def __init__(self, params: PendulumPumpParams, gain: float = 2.0) -> None:
        self.params = params
        self.physics = params.physics
        self.gain = gain

    def act(self, obs: np.ndarray) -> np.ndarray:
        p = self.params
        theta, omega = np.arctan2(obs[:, 0], obs[:, 1]), obs[:, 2] * p.rate_scale
        torque = pendulum.pump_torque(theta, omega, obs[:, 3] * np.pi, self.gain, p.max_torque, self.physics)
        return (torque / p.max_torque)[:, None]


class ThreadVelocityFeedback(AnalyticController):
    """Collocated velocity feedback (PHYSICS.md section 9): ``u_k = -c_fb v_k`` at each actuated node, saturated.

    Each actuator pushes against its own node's observed velocity, so it only ever takes energy out. The default
    gain is near critical damping of the slowest mode, ``c_fb = 2 m omega_1`` (omega_1 from the rest shape's
    stiffness), capped at ``m / (4 dt)`` (``c_fb dt / m = 1/4``, the cap at the defaults), half the gain at which
    the feedback, held over a control step, stops settling the thread: at the defaults that limit lies between
    ``c_fb dt / m = 0.5`` and ``0.55`` (measured, ``tests/test_thread.py``), not at PHYSICS.md's 1, since the fast
    modes turn by up to ``2 sqrt(S/m) dt`` = 2.8 rad in a step. Twice the default gain settles faster (return
    -0.088 against -0.114 on the first 20 plucks) with no margin left.
    """

    task_cls = ThreadTask

    def __init__(self, params: ThreadEnvParams, gain: float | None = None) -> None:
        self.params = params
        self.actuated = params.actuated
        if gain is None:
            slowest = float(thread.mode_frequencies(params.physics)[0])
            gain = min(2.0 * params.node_mass * slowest, params.node_mass / (4.0 * params.dt))
        self.gain = gain

    def act(self, obs: np.ndarray) -> np.ndarray:
        p = self.params
        n, nodes = len(obs), p.n_nodes
        velocities = obs[:, 2 * nodes : 4 * nodes].reshape(n, nodes, 2)[:, self.actuated] * p.velocity_scale
        return (-self.gain * velocities / p.max_force).reshape(n, -1)


class AircraftDraftCompensatingAutopilot(AircraftAutopilot):
    """The autopilot with draft feed-forward: the stronger reference on AircraftGusty-v0.

    The vertical air velocity (steady draft plus the last gust) is inferred from the observation as the
    vertical speed achieved on the last step minus the climb command given for it, and subtracted from the
    altitude loop's command, ``v_y = clip(k_v y_err - w_est, -V_des, V_cli)``. The plain autopilot's steady
    altitude error ``|w| / k_v`` then vanishes up to the gust noise. Speed and heading loops are unchanged.
    """

    def act(self, obs: np.ndarray) -> np.ndarray:
        p = self.params
        action = super().act(obs)
        air = (obs[:, 5] - obs[:, 6]) * p.vertical_speed_scale
        climb = np.clip(
            self.gains.climb_gain * obs[:, 0] * p.altitude_scale - air, -p.max_descent_rate, p.max_climb_rate
        )
        action[:, 1] = np.where(climb >= 0.0, climb / p.max_climb_rate, climb / p.max_descent_rate)
        return action


CONTROLLERS: dict[type[Task], Callable[[Any], AnalyticController]] = {
    BouncingBallTask: BouncingBallMyopic,
    ProjectileTask: ProjectileFiringSolution,
    AircraftTask: AircraftAutopilot,
    SteerableWheelTask: SteerableWheelPurePursuit,
    SuspensionTask: SuspensionSkyhook,
    PendulumPumpTask: PendulumEnergyPumping,
    ThreadTask: ThreadVelocityFeedback,
    BilliardsTask: BilliardsGhostBall,
    GearTrainTask: GearTrainProportional,
    ProjectileAdjustTask: ProjectileAdjustFire,
}
"""Reference controller of each task, built from the task's parameters."""


CLIPPING_WRAPPERS = (gym.wrappers.ClipAction, gym.wrappers.vector.ClipAction)
"""Wrappers that take any action and clip it into their env's space: a controller's actions pass them unchanged."""


def _observation_space(env: Any) -> gym.Space:
    """The observation space of one env: a vector env's single one."""
    return env.single_observation_space if isinstance(env, gym.vector.VectorEnv) else env.observation_space


def _action_space(env: Any) -> gym.Space:
    """The action space of one env: a vector env's single one."""
    return env.single_action_space if isinstance(env, gym.vector.VectorEnv) else env.action_space


def _changes_actions(env: Any) -> bool:
    """Whether a wrapper of ``env`` changes the action space, other than :data:`CLIPPING_WRAPPERS` (``ClipAction``
    widens it to +-inf only to clip into it)."""
    while isinstance(env, gym.Wrapper | gym.vector.VectorWrapper):
        if not isinstance(env, CLIPPING_WRAPPERS) and _action_space(env) != _action_space(env.env):
            return True
        env = env.env
    return False


def controller_for(env: Any) -> AnalyticController:
    """The analytic reference controller of a vegym env: a single env (from ``gymnasium.make``, wrapped or not) or
    the native vector env. ValueError for another env, and for wrappers that change the spaces the controller
    reads and acts in (``NormalizeObservation``, ``RescaleAction``, ...); ``ClipAction`` passes its actions
    unchanged."""
    unwrapped = getattr(env, "unwrapped", None)
    if not isinstance(unwrapped, VegymEnv | VegymVectorEnv):
        raise ValueError(
            f"controller_for needs a vegym env (gymnasium.make, or make_vec's native vector env); got {env!r}"
        )
    task = unwrapped.task
    for task_cls, factory in CONTROLLERS.items():
        if isinstance(task, task_cls):
            controller = factory(task.params)
            break
    else:
        raise ValueError(f"no analytic controller for {type(task).__name__}")
    spaces = _observation_space(env), _action_space(env)
    if spaces[0] != controller.spaces[0] or _changes_actions(env):  # the env itself acts in controller.spaces[1]
        raise ValueError(
            f"{type(controller).__name__} reads {unwrapped.spec.id if unwrapped.spec else type(unwrapped).__name__}'s "
            f"observations {controller.spaces[0]} and acts in {controller.spaces[1]}, but {env} has {spaces[0]} "
            f"and {spaces[1]}: a wrapper changed them; give it the env without that wrapper"
        )
    return controller


REFERENCE_AGENTS: dict[str, dict[str, Callable[[gym.Env], AnalyticController | BouncingBallOracle]]] = {
    "vegym/BouncingBall-v0": {
        "planner": lambda env: BouncingBallPlanner(env.unwrapped.params),
        "oracle": BouncingBallOracle,
    },
    "vegym/AircraftGusty-v0": {
        "draft-compensating": lambda env: AircraftDraftCompensatingAutopilot(env.unwrapped.params)
    },
    "vegym/Suspension-v0": {"continuous-skyhook": lambda env: SuspensionContinuousSkyhook(env.unwrapped.params)},
}
"""Stronger references than the analytic controller, per env (name -> factory of the agent for an env);
:mod:`agents.evaluation` evaluates them beside it."""
