"""GearTrain-v0: drive the input gear of a chain of external gears so the output gear holds a target angle."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs.base import Info, KernelCall, State, Task, VegymEnv, VegymVectorEnv
from vegym.params import Params, param
from vegym.physics import vmath, wheel
from vegym.physics.columns import scratch

_SETUP_STREAM = 1
_TARGET_STREAM = 2


@dataclass(frozen=True)
class GearTrainParams(Params):
    """Parameters of GearTrain-v0 (SI units, radians; angles anticlockwise, seen from the front of the train)."""

    dt: float = param(0.05, "control step (s); the motor speed is held over it", low=0.0, low_open=True, high=1.0)
    gears_min: int = param(2, "fewest gears in the chain (input and output included)", low=2, high=8)
    gears_max: int = param(5, "most gears in the chain", low=2, high=8)
    radius_min: float = param(0.02, "smallest pitch radius (m)", low=0.0, low_open=True)
    radius_max: float = param(0.08, "largest pitch radius (m)", low=0.0, low_open=True)
    max_speed: float = param(10.0, "top speed of the motor driving the input gear (rad/s)", low=0.0, low_open=True)
    max_acceleration: float = param(
        40.0, "largest change of the motor speed per second, toward the command (rad/s^2)", low=0.0, low_open=True
    )
    target_interval: float = param(5.0, "a new target angle every this many seconds (s)", low=0.0, low_open=True)
    tolerance: float = param(0.02, "is_success: the output within this angle of the target (rad)", low=0.0)
    tracking_weight: float = param(1.0, "cost per second of an output error of pi rad (linear in the error)", low=0.0)
    effort_weight: float = param(0.01, "cost per second of a full-speed motor command (quadratic)", low=0.0)

    def validate(self) -> None:
        if self.gears_min > self.gears_max:
            raise self.between("gears_min", high="gears_max")
        if self.radius_min > self.radius_max:
            raise self.between("radius_min", high="radius_max")
        if self.target_interval < self.dt:
            raise self.between("target_interval", "dt")
        if not self.ratio_max * self.max_speed * self.dt < np.pi:
            fastest = np.pi / (self.dt * self.ratio_max)
            formula = f"pi / (dt * radius_max / radius_min) = pi / ({self.dt} * {self.radius_max} / {self.radius_min})"
            raise self.between("max_speed", high=(f"{formula} = {fastest:.4g}", fastest), high_open=True)

    @property
    def ratio_max(self) -> float:
        """Largest ``|omega_out / omega_in| = r_1 / r_n`` of a drawn train: ``radius_max / radius_min``."""
        return self.radius_max / self.radius_min

    @property
    def interval_steps(self) -> int:
        """Steps between target changes: ``round(target_interval / dt)``, at least 1."""
        return max(1, round(self.target_interval / self.dt))


REWARD_TERMS = ("tracking", "effort")
"""Names of ``info["reward_terms"]``, in the order of the step kernel's ``terms`` columns."""
STEP_CONSTANTS = ("max_speed", "max_acceleration", "dt", "tracking_weight", "effort_weight", "tolerance", "ratio_max")
"""Parameters the kernels read, in the order of their constants array (SI units, see the fields)."""


@njit(cache=True, nogil=True, error_model="numpy")
def _target_one(key: np.uint64, step: int, interval_steps: int, target_offset: np.uint64) -> float:
    """Target output angle (rad) in force during step ``step`` of the episode of ``key`` (as
    :meth:`GearTrainTask.target`)."""
    # step // interval_steps through a float quotient, which SIMD-compiles (there is no vector integer division):
    # exact, as the quotient of non-negative integers whose sum is below 2^52 never rounds up to the next integer
    counter = np.uint64(np.floor(step / interval_steps))
    base = rng.stream_base(key, target_offset, counter)
    return np.pi * (2.0 * rng.lane(base, 0) - 1.0)


@njit(cache=True)
def _targets_kernel(keys: np.ndarray, steps: np.ndarray, interval_steps: int, target_offset: np.uint64) -> np.ndarray:
    out = np.empty(len(keys))
    for i in range(len(keys)):
        out[i] = _target_one(keys[i], steps[i], interval_steps, target_offset)
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _step_kernel(
    action: np.ndarray,
    key: np.ndarray,
    step: np.ndarray,
    speed: np.ndarray,
    radii: np.ndarray,
    angles: np.ndarray,
    gears: np.ndarray,
    ratio: np.ndarray,
    c: np.ndarray,
    interval_steps: int,
    target_offset: np.uint64,
    target: np.ndarray,
    output_speed: np.ndarray,
    output: np.ndarray,
    error: np.ndarray,
    terms: np.ndarray,
    reward: np.ndarray,
    success: np.ndarray,
    terminated: np.ndarray,
    obs: np.ndarray,
) -> None:
    """The whole step and the next observation, in place on the state arrays (``speed``, ``angles``) and into the
    outputs (``target``, the target of the step, to ``obs``); ``c`` holds the parameters named in
    ``STEP_CONSTANTS``, in that order. The targets are drawn from the key's stream ``target_offset``, a fresh one
    every ``interval_steps`` steps.

    Written as passes over the batch that the compiler turns into SIMD code: the motor, each gear in turn (on
    scratch copies of the radii and angles with the batch axis last, copied in and the angles back out in passes
    of their own), the targets and terms, the observation."""
    max_speed, max_acceleration, dt, tracking_weight, effort_weight, tolerance = c[0], c[1], c[2], c[3], c[4], c[5]
    n, g = len(action), radii.shape[1]
    gear_speed, next_target, tracking, effort = scratch(n), scratch(n), scratch(n), scratch(n)
    dv = max_acceleration * dt
    for i in range(n):
        v = min(max(max_speed * action[i, 0], speed[i] - dv), speed[i] + dv)
        speed[i], gear_speed[i] = v, v
    radius, angle = np.empty((g, n)), np.empty((g, n))  # radii and angles, batch axis last
    for i in range(n):
        for k in range(g):
            radius[k, i], angle[k, i] = radii[i, k], angles[i, k]
    for k in range(g):
        for i in range(n):
            # each mesh turns the next gear at -r_{k-1} / r_k times the speed (wheel.train_speeds); unused at k = 0
            s = gear_speed[i] * -(radius[k - 1, i] / radius[k, i]) if k > 0 else gear_speed[i]
            a = vmath.wrap_angle(angle[k, i] + s * dt)
            angle[k, i] = a
            gear_speed[i] = s
            is_output = k == gears[i] - 1
            output_speed[i] = s if is_output else output_speed[i]
            output[i] = a if is_output else output[i]
    for i in range(n):  # the angles back
        for k in range(g):
            angles[i, k] = angle[k, i]
    for i in range(n):
        target[i] = _target_one(key[i], step[i], interval_steps, target_offset)
        next_target[i] = _target_one(key[i], step[i] + 1, interval_steps, target_offset)
        error[i] = vmath.wrap_angle(target[i] - output[i])
        tracking[i] = -tracking_weight * dt * abs(error[i]) / np.pi
        effort[i] = -effort_weight * dt * action[i, 0] ** 2
        reward[i] = tracking[i] + effort[i]
        success[i], terminated[i] = abs(error[i]) <= tolerance, False
    for i in range(n):  # strided stores
        terms[i, 0], terms[i, 1] = tracking[i], effort[i]
    _observe_rows(next_target, output, speed, ratio, c, obs)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe_rows(
    target: np.ndarray, output: np.ndarray, speed: np.ndarray, ratio: np.ndarray, c: np.ndarray, obs: np.ndarray
) -> None:
    """Observations (n, 4) into ``obs`` from the target angle ``target`` and output angle ``output`` (rad) of each
    episode; ``c`` holds the parameters named in ``STEP_CONSTANTS``. The sines and cosines in a SIMD pass, the
    strided stores in another."""
    n = len(obs)
    sine, cosine = scratch(n), scratch(n)
    for i in range(n):
        sine[i], cosine[i] = vmath.sincos(target[i] - output[i])
    for i in range(n):
        obs[i, 0], obs[i, 1] = sine[i], cosine[i]
        obs[i, 2], obs[i, 3] = speed[i] / c[0], ratio[i] / c[6]


@njit(cache=True, nogil=True, error_model="numpy")
def _observe_kernel(
    key: np.ndarray,
    step: np.ndarray,
    angles: np.ndarray,
    gears: np.ndarray,
    speed: np.ndarray,
    ratio: np.ndarray,
    c: np.ndarray,
    interval_steps: int,
    target_offset: np.uint64,
    obs: np.ndarray,
) -> None:
    """Observations (n, 4) into ``obs``, against the targets in force at ``step``, in passes (see
    :func:`_step_kernel`)."""
    n = len(step)
    target, output = scratch(n), scratch(n)
    for i in range(n):
        target[i] = _target_one(key[i], step[i], interval_steps, target_offset)
        output[i] = angles[i, gears[i] - 1]
    _observe_rows(target, output, speed, ratio, c, obs)


class GearTrainTask(Task[GearTrainParams]):
    """Batched logic of GearTrain-v0 (see :class:`GearTrainEnv`)."""

    params_cls = GearTrainParams
    renderer = "vegym.render.gear_train:GearTrainRenderer"

    def __init__(self, params: GearTrainParams) -> None:
        super().__init__(params)
        self.observation_space = spaces.Box(-1.0, 1.0, (4,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        self._constants = np.array([getattr(params, name) for name in STEP_CONSTANTS], dtype=np.float64)
        self._interval_steps = params.interval_steps
        self._target_offset = rng.stream_offset(_TARGET_STREAM)

    @property
    def control_rate(self) -> float:
        return 1.0 / self.params.dt

    def target(self, keys: np.ndarray, step: np.ndarray | int) -> np.ndarray:
        """Target output angle (n,) in force during step ``step`` (n,): a fresh uniform draw in [-pi, pi) every
        ``interval_steps`` steps, a pure function of the episode key (the kernels' own draw)."""
        keys = np.ascontiguousarray(keys, dtype=np.uint64)
        steps = np.ascontiguousarray(np.broadcast_to(np.asarray(step, dtype=np.int64), keys.shape))
        return _targets_kernel(keys, steps, self._interval_steps, self._target_offset)

    def initial_state(self, keys: np.ndarray) -> State:
        p = self.params
        n, g = len(keys), p.gears_max
        u = rng.uniform(keys, _SETUP_STREAM, 1 + 2 * g)
        gears = np.minimum(p.gears_min + np.floor(u[:, 0] * (p.gears_max - p.gears_min + 1)), p.gears_max)
        state = {
            "gears": gears.astype(np.int64),
            "radii": p.radius_min + (p.radius_max - p.radius_min) * u[:, 1 : 1 + g],
            "angles": np.pi * (2.0 * u[:, 1 + g :] - 1.0),
            "speed": np.zeros(n),
        }
        return {**state, "ratio": self.ratio(state)}  # fixed for the episode

    @staticmethod
    def ratio(state: State) -> np.ndarray:
        """``omega_out / omega_in = (-1)^(n-1) r_1 / r_n`` (n,) of each episode's train of its first ``gears`` gears."""
        speeds = wheel.train_speeds(np.ones(len(state["gears"])), state["radii"])
        return speeds[np.arange(len(speeds)), state["gears"] - 1]

    @staticmethod
    def output_angle(state: State) -> np.ndarray:
        """Angle (n,) of the output (last) gear, in [-pi, pi]."""
        return state["angles"][np.arange(len(state["gears"])), state["gears"] - 1]

    def output_shapes(self) -> dict[str, tuple[tuple[int, ...], type]]:
        return {
            "target": ((), np.float64),
            "output_speed": ((), np.float64),
            "output": ((), np.float64),
            "error": ((), np.float64),
            "terms": ((len(REWARD_TERMS),), np.float64),
            "success": ((), np.bool_),
        }

    def step_call(self, state: State, action: np.ndarray, out: State) -> KernelCall:
        return _step_kernel, (
            action, state["key"], state["step"], state["speed"], state["radii"], state["angles"], state["gears"],
            state["ratio"], self._constants, self._interval_steps, self._target_offset, out["target"],
            out["output_speed"], out["output"], out["error"], out["terms"], out["reward"], out["success"],
            out["terminated"], out["obs"],
        )  # fmt: skip

    def info(self, state: State, out: State) -> Info:
        return {
            "input_speed": state["speed"],
            "output_speed": out["output_speed"],
            "output_angle": out["output"],
            "target_angle": out["target"],
            "error": out["error"],
            "ratio": state["ratio"],
            "gears": state["gears"],
            "dt": self.params.dt,
            "reward_terms": dict(zip(REWARD_TERMS, out["terms"].T, strict=True)),
            "is_success": out["success"],
        }

    def observe(self, state: State, obs: np.ndarray) -> None:
        _observe_kernel(
            state["key"], state["step"], state["angles"], state["gears"], state["speed"], state["ratio"],
            self._constants, self._interval_steps, self._target_offset, obs,
        )  # fmt: skip


class GearTrainEnv(VegymEnv[GearTrainParams]):
    """Gear positioning: drive the input gear of a chain of external gears so that the output gear holds a target.

    ## Description
    The gear train of the chapter (8.19-8.20, corrected as in PHYSICS.md section 2): meshing gears share their rim
    speed, ``omega_a r_a = -omega_b r_b``, so along a chain of n external gears the speeds alternate in sign and
    ``omega_n / omega_1 = (-1)^(n-1) r_1 / r_n`` (the idlers cancel). Each episode draws a chain of ``gears_min``
    to ``gears_max`` gears with pitch radii uniform in ``[radius_min, radius_max]`` and random starting angles. A
    motor drives gear 1: its speed follows the command at up to ``max_acceleration`` and is held over each step
    of ``dt``, and every gear turns by ``omega_i dt``. The output gear must reach and hold a target angle that is
    redrawn every ``target_interval`` seconds.

    ## Action Space
    ``Box(-1, 1, (1,), float32)``: the motor speed command ``a0 * max_speed`` (rad/s, positive anticlockwise).
    The speed a step applies is the previous speed moved toward the command by at most ``max_acceleration * dt``.

    ## Observation Space
    ``Box(-1, 1, (4,), float32)``: the sine and cosine of the output error ``target - output angle`` (no jump
    at +-pi), the motor speed over ``max_speed``, and the train's ratio ``omega_out / omega_in`` (its sign tells
    the direction the output turns) over ``ratio_max = radius_max / radius_min``.

    ## Rewards
    ``tracking``: ``-tracking_weight * dt * |error| / pi`` with the wrapped error after the step (against the
    target in force during it); ``effort``: ``-effort_weight * dt * a0^2``.

    ## Starting State
    Gear count uniform in ``[gears_min, gears_max]``, radii uniform in ``[radius_min, radius_max]``, angles
    uniform in [-pi, pi), motor at rest; the targets are uniform in [-pi, pi). All drawn from the episode seed.

    ## Episode End
    Never terminated; truncated after ``max_episode_steps`` (200, i.e. 10 s at the default dt: two targets, when
    registered). ``info["is_success"]``: the output is within ``tolerance`` of the target at this step.

    ## Arguments
    ``gymnasium.make("vegym/GearTrain-v0", render_mode=None, **params)`` with the fields of
    :class:`GearTrainParams`. ``info`` per step (SI units, radians): ``input_speed`` and ``output_speed`` (rad/s,
    applied this step), ``output_angle`` (in [-pi, pi]), ``target_angle``, ``error`` (wrapped, in [-pi, pi]),
    ``ratio``, ``gears``, ``dt``, ``reward_terms``, ``is_success``. Reference controller: saturated proportional
    control through the ratio, ``omega_in = sat(k error, +-max_speed |ratio|) / ratio`` (``agents.analytic``).
    ``max_speed * dt * ratio_max`` must stay below pi, so that one step never turns the output by half a turn.

    ## Version History
    * v0: initial version.
    """

    task_cls = GearTrainTask


class GearTrainVectorEnv(VegymVectorEnv[GearTrainParams]):
    """Native vector twin of :class:`GearTrainEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = GearTrainTask
