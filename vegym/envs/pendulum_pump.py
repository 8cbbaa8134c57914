"""PendulumPump-v0: swing a pendulum with a bounded pivot torque at a target amplitude that changes at random times."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs import schedule
from vegym.envs.base import Info, KernelCall, State, Task, VegymEnv, VegymVectorEnv
from vegym.envs.schedule import ScheduledParams
from vegym.params import Params, invalid, param
from vegym.physics import pendulum, vmath
from vegym.physics.columns import scratch
from vegym.physics.particle import STANDARD_GRAVITY
from vegym.physics.pendulum import PendulumParams

_START_STREAM = 1
_TARGET_STREAM = 2


@dataclass(frozen=True)
class PendulumPumpParams(ScheduledParams, Params):
    """Parameters of PendulumPump-v0 (SI units, radians; angles from the downward vertical)."""

    length: float = param(1.0, "L, rod length (m)", low=0.0, low_open=True)
    mass: float = param(1.0, "m, bob mass (kg)", low=0.0, low_open=True)
    gravity: float = param(STANDARD_GRAVITY, "gravitational acceleration magnitude (m/s^2)", low=0.0, low_open=True)
    damping: float = param(0.05, "b, viscous pivot damping (N m s/rad)", low=0.0)
    max_torque: float = param(1.0, "tau_max, largest pivot torque (N m)", low=0.0, low_open=True)
    dt: float = param(0.05, "control step (s); the torque is held over it", low=0.0, low_open=True)
    substeps: int = param(5, "semi-implicit Euler steps per control step", low=1, high=1000)
    start_angle_max: float = param(math.radians(30.0), "start angle uniform in +-this (rad)", low=0.0, high=math.pi)
    start_rate_max: float = param(0.5, "start angular velocity uniform in +-this (rad/s)", low=0.0)
    target_min: float = param(math.radians(15.0), "smallest target amplitude (rad)", low=0.0, high=math.pi)
    target_max: float = param(math.radians(120.0), "largest target amplitude (rad)", low=0.0, high=math.pi)
    change_interval_min: float = param(10.0, "shortest time between target changes (s)", low=0.0, low_open=True)
    change_interval_max: float = param(20.0, "longest time between target changes (s)", low=0.0, low_open=True)
    final_hold: float = param(15.0, "no target change within this time of the planned episode end (s)", low=0.0)
    episode_steps: int = param(800, "planned episode length (steps): the registered max_episode_steps", low=1)
    success_tolerance: float = param(math.radians(5.0), "is_success: largest amplitude error (rad)", low=0.0)
    effort_weight: float = param(0.02, "cost per second of full torque (quadratic in the action)", low=0.0)

    def validate(self) -> None:
        if self.target_min > self.target_max:
            raise self.between("target_min", high="target_max")
        _ = self.schedule  # raises ValueError if change_interval_min or final_hold is out of range
        stable, resolved = self.physics.max_stable_step(), self.max_torque_step
        if self.step_length >= min(stable, resolved):
            if stable <= resolved:  # semi-implicit Euler is unstable at steps of ``stable`` and longer
                longest, what, weaker = stable, "stable step", ""
                why = f"the pendulum of {self.named('length', 'mass', 'gravity', 'damping')}"
            else:
                longest, what = resolved, "torque step"
                why = f"max_torque={self.max_torque:g} on {self.named('length', 'mass')}: 2 sqrt(m L^2 / max_torque)"
                strongest = 4.0 * self.physics.inertia / self.step_length**2
                weaker = f"; or max_torque below {strongest:.4g} N m for this dt and substeps"
            if self.dt >= 1000 * longest:
                limit = (f"1000 substeps x {longest:.4g} s", 1000 * longest)
                raise self.between("dt", high=limit, high_open=True, reason=f", the {what} of {why}{weaker}")
            fewest = math.floor(self.dt / longest) + 1
            allowed = f"[{fewest}, 1000] for dt={self.dt} ({what} {longest:.4g} s, for {why}){weaker}"
            raise invalid("substeps", self.substeps, allowed)

    @property
    def physics(self) -> PendulumParams:
        """The pendulum physics parameters."""
        return self.subset(PendulumParams)

    @property
    def max_torque_step(self) -> float:
        """Longest integration step (s) for the torque: ``2 sqrt(m L^2 / max_torque)``, the step ``h`` at which
        ``max_torque h^2 / (m L^2)`` reaches 4 (the bound that ``(g/L) h^2`` has for stability), where the full torque
        alone would turn the resting pendulum by 2 rad in one step (one semi-implicit Euler step turns it by 4).
        Longer steps are refused: at ``max_torque h^2 / (m L^2) = 1e8`` the torque spun the angle by 1e17 rad within
        a control step after 4,141 steps, and its sine to NaN."""
        return 2.0 * math.sqrt(self.physics.inertia / self.max_torque)

    @property
    def step_length(self) -> float:
        """Integration step ``dt / substeps`` (s)."""
        return self.dt / self.substeps

    @property
    def rate_scale(self) -> float:
        """Angular velocity of a full unit of observation: ``2 sqrt(g / L)`` (rad/s), the speed at the bottom of a
        swing that just reaches the top."""
        return 2.0 * math.sqrt(self.gravity / self.length)


REWARD_TERMS = ("amplitude", "effort")
"""Names of ``info["reward_terms"]``, in the order of the step kernel's ``terms`` columns."""


@njit(cache=True, nogil=True, error_model="numpy")
def _step_kernel(
    action: np.ndarray,
    theta: np.ndarray,
    omega: np.ndarray,
    target: np.ndarray,
    key: np.ndarray,
    step: np.ndarray,
    changes: np.ndarray,
    last_change: np.ndarray,
    next_change: np.ndarray,
    c: np.ndarray,
    timing: schedule.Timing,
    bounds: tuple[float, float],
    target_offset: np.uint64,
    torque: np.ndarray,
    energy: np.ndarray,
    amplitude: np.ndarray,
    target_amplitude: np.ndarray,
    target_energy: np.ndarray,
    terms: np.ndarray,
    reward: np.ndarray,
    success: np.ndarray,
    terminated: np.ndarray,
    obs: np.ndarray,
) -> None:
    """The whole step and the next observation, in place on ``theta`` (rad, wrapped to [-pi, pi)) and ``omega``
    (rad/s) and into the outputs (``torque`` to ``obs``): the torque (N m), energy (J), amplitude (rad), target
    amplitude (rad) and target energy (J) of this step, the reward terms (amplitude, effort), reward, is_success
    and terminated (never); ``step`` counts the steps taken before this one; ``c``: see
    ``PendulumPumpTask._constants``. Where target changes are due at the new step, :func:`_change_targets` hands
    them out last, in place on ``target`` to ``next_change`` and those rows of ``obs`` (``timing``, ``bounds``
    and ``target_offset`` are its).

    Written as passes over the batch that the compiler turns into SIMD code: the substeps (each a pass over the
    state in scratch arrays), the energies, the amplitudes and the terms; the strided stores of the terms and
    observations in a pass of its own."""
    max_torque, dt, h, substeps = c[0], c[1], c[2], int(c[3])
    g_over_l, damping, inertia, weight_moment = c[4], c[5], c[6], c[7]
    effort_weight, success_tolerance = c[8], c[9]
    n = len(action)
    th, om, sine, cosine = scratch(n), scratch(n), scratch(n), scratch(n)
    tracking, effort = scratch(n), scratch(n)
    for i in range(n):
        torque[i] = max_torque * action[i, 0]
        th[i], om[i] = theta[i], omega[i]
    for _ in range(substeps):
        for i in range(n):
            th[i], om[i] = pendulum.swing(th[i], om[i], torque[i], h, g_over_l, damping, inertia)
    changing = False
    for i in range(n):
        angle = vmath.wrap_angle(th[i])
        theta[i], omega[i] = angle, om[i]
        sine[i], cosine[i] = vmath.sincos(angle)
        energy[i] = pendulum.energy_from_cos(cosine[i], om[i], inertia, weight_moment)
        target_amplitude[i] = target[i]
        target_energy[i] = pendulum.energy_of(target[i], 0.0, inertia, weight_moment)
        terminated[i] = False
        changing |= step[i] + 1 >= next_change[i]
    for i in range(n):
        amplitude[i] = pendulum.amplitude_of(energy[i], weight_moment)
        error = amplitude[i] - target[i]
        tracking[i] = -dt * abs(error) / np.pi
        effort[i] = -effort_weight * dt * action[i, 0] ** 2
        reward[i] = tracking[i] + effort[i]
        success[i] = abs(error) <= success_tolerance
    for i in range(n):  # strided stores
        terms[i, 0], terms[i, 1] = tracking[i], effort[i]
        _observe_row(i, sine[i], cosine[i], omega[i], target[i], energy[i], target_energy[i], amplitude[i], c, obs)
    if changing:
        _change_targets(
            key, step, changes, last_change, next_change, timing, bounds, target_offset, target, theta, omega, c, obs
        )


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe_row(
    i: int,
    sine: float,
    cosine: float,
    omega: float,
    target: float,
    energy: float,
    target_energy: float,
    amplitude: float,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """Observation of episode ``i`` into ``obs[i]`` from the sine and cosine of its angle, its angular velocity
    (rad/s), target amplitude (rad), energy and target energy (J) and amplitude (rad); ``c``: see
    ``PendulumPumpTask._constants``."""
    weight_moment, rate_scale = c[7], c[10]
    obs[i, 0] = sine
    obs[i, 1] = cosine
    obs[i, 2] = min(max(omega / rate_scale, -1.0), 1.0)
    obs[i, 3] = target / np.pi
    obs[i, 4] = min(max((energy - target_energy) / (2.0 * weight_moment), -1.0), 1.0)
    obs[i, 5] = (amplitude - target) / np.pi


@njit(cache=True, nogil=True, error_model="numpy")
def _observe_kernel(
    rows: np.ndarray, theta: np.ndarray, omega: np.ndarray, target: np.ndarray, c: np.ndarray, obs: np.ndarray
) -> None:
    """Observations (6,) of the episodes ``rows`` (int indices) written into those rows of ``obs``, as the step
    kernel writes them; ``c``: see ``PendulumPumpTask._constants``."""
    inertia, weight_moment = c[6], c[7]
    for i in rows:
        sine, cosine = vmath.sincos(theta[i])
        energy = pendulum.energy_from_cos(cosine, omega[i], inertia, weight_moment)
        target_energy = pendulum.energy_of(target[i], 0.0, inertia, weight_moment)
        amplitude = pendulum.amplitude_of(energy, weight_moment)
        _observe_row(i, sine, cosine, omega[i], target[i], energy, target_energy, amplitude, c, obs)


@njit(cache=True, nogil=True, inline="always")
def _target(key: np.uint64, index: int, bounds: tuple[float, float], offset: np.uint64) -> float:
    """Target amplitude number ``index`` of the episode ``key`` (rad), uniform in ``bounds = (target_min,
    target_max)``, from the stream ``offset``."""
    low, high = bounds
    return low + (high - low) * rng.lane(rng.stream_base(key, offset, np.uint64(index)), 0)


@njit(cache=True, nogil=True)
def _draw_targets(keys: np.ndarray, index: np.ndarray, bounds: tuple[float, float], offset: np.uint64) -> np.ndarray:
    """:func:`_target` of each key (n,)."""
    out = np.empty(len(keys))
    for i in range(len(keys)):
        out[i] = _target(keys[i], index[i], bounds, offset)
    return out


@njit(cache=True, nogil=True)
def _change_targets(
    key: np.ndarray,
    step: np.ndarray,
    changes: np.ndarray,
    last_change: np.ndarray,
    next_change: np.ndarray,
    timing: schedule.Timing,
    bounds: tuple[float, float],
    target_offset: np.uint64,
    target: np.ndarray,
    theta: np.ndarray,
    omega: np.ndarray,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """The target changes due at the new step (``step`` not yet counted), in place (:func:`schedule.advance_due`
    and :func:`_target`), and the observations of the episodes that changed, into those rows of ``obs``."""
    rows = schedule.advance_due(key, step, changes, last_change, next_change, timing)
    for i in rows:
        target[i] = _target(key[i], changes[i], bounds, target_offset)
    _observe_kernel(rows, theta, omega, target, c, obs)


class PendulumPumpTask(Task[PendulumPumpParams]):
    """Batched logic of PendulumPump-v0 (see :class:`PendulumPumpEnv`)."""

    params_cls = PendulumPumpParams
    planned_length_param = "episode_steps"
    renderer = "vegym.render.pendulum_pump:PendulumPumpRenderer"

    def __init__(self, params: PendulumPumpParams) -> None:
        super().__init__(params)
        self.physics = params.physics
        self.schedule = params.schedule
        self._timing = self.schedule.timing
        self._target_bounds = (params.target_min, params.target_max)
        self._target_offset = rng.stream_offset(_TARGET_STREAM)
        low = np.array([-1, -1, -1, 0, -1, -1], np.float32)
        self.observation_space = spaces.Box(low, np.ones(6, np.float32), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        physics = self.physics
        # kernel constants: max torque (N m), dt, substep (s), substeps, g/L (1/s^2), damping (N m s), m L^2 (kg m^2),
        # m g L (J), effort weight, success tolerance (rad), rate scale (rad/s)
        self._constants = np.array(
            [
                params.max_torque,
                params.dt,
                params.step_length,
                params.substeps,
                physics.gravity / physics.length,
                physics.damping,
                physics.inertia,
                physics.weight_moment,
                params.effort_weight,
                params.success_tolerance,
                params.rate_scale,
            ]
        )

    @property
    def control_rate(self) -> float:
        return 1.0 / self.params.dt

    def draw_target(self, keys: np.ndarray, index: np.ndarray) -> np.ndarray:
        """Target amplitude number ``index`` (n,) of each episode (rad), uniform in ``[target_min, target_max]``."""
        return _draw_targets(*schedule.per_key(keys, index), self._target_bounds, self._target_offset)

    def initial_state(self, keys: np.ndarray) -> State:
        p = self.params
        u = rng.uniform(keys, _START_STREAM, 2)
        zeros = np.zeros(len(keys), dtype=np.int64)
        return {
            "theta": p.start_angle_max * (2.0 * u[:, 0] - 1.0),
            "omega": p.start_rate_max * (2.0 * u[:, 1] - 1.0),
            "target": self.draw_target(keys, zeros),
            **self.schedule.initial(keys),
        }

    def output_shapes(self) -> dict[str, tuple[tuple[int, ...], type]]:
        return {
            "torque": ((), np.float64),
            "energy": ((), np.float64),
            "amplitude": ((), np.float64),
            "target_amplitude": ((), np.float64),
            "target_energy": ((), np.float64),
            "terms": ((len(REWARD_TERMS),), np.float64),
            "success": ((), np.bool_),
        }

    def step_call(self, state: State, action: np.ndarray, out: State) -> KernelCall:
        return _step_kernel, (
            action, state["theta"], state["omega"], state["target"], state["key"], state["step"], state["changes"],
            state["last_change"], state["next_change"], self._constants, self._timing, self._target_bounds,
            self._target_offset, out["torque"], out["energy"], out["amplitude"], out["target_amplitude"],
            out["target_energy"], out["terms"], out["reward"], out["success"], out["terminated"], out["obs"],
        )  # fmt: skip

    def info(self, state: State, out: State) -> Info:
        return {
            "angle": state["theta"],
            "angular_velocity": state["omega"],
            "torque": out["torque"],
            "energy": out["energy"],
            "amplitude": out["amplitude"],
            "target_amplitude": out["target_amplitude"],
            "target_energy": out["target_energy"],
            "dt": self.params.dt,
            "reward_terms": dict(zip(REWARD_TERMS, out["terms"].T, strict=True)),
            "is_success": out["success"],
        }

    def observe(self, state: State, obs: np.ndarray) -> None:
        self.observe_rows(state, np.arange(len(obs)), obs)

    def observe_rows(self, state: State, rows: np.ndarray, obs: np.ndarray) -> None:
        _observe_kernel(rows, state["theta"], state["omega"], state["target"], self._constants, obs)


class PendulumPumpEnv(VegymEnv[PendulumPumpParams]):
    """Energy pumping: swing a damped pendulum at a target amplitude with a weak pivot torque.

    ## Description
    The simple pendulum of the chapter (8.5) with both printed sign errors fixed (PHYSICS.md section 7): a bob of
    mass m on a rod of length L, angle theta from the downward vertical, ``theta'' = -(g/L) sin theta - b
    theta' / (m L^2) + tau / (m L^2)``, integrated with ``substeps`` semi-implicit Euler steps per control step,
    each shorter than the pendulum's stable step and than ``max_torque_step`` (parameters that break either are
    refused, naming ``substeps`` or ``dt``). The torque is weak (``tau_max = 1 N m`` against ``m g L = 9.81 J``: it
    could hold the bob only 6 deg out of the vertical), so it must pump energy in over several swings, in phase with
    the angular velocity, or take it out.
    The target amplitude theta* changes at random times; the swing's amplitude is read from its energy,
    ``theta_E = arccos(1 - E / (m g L))`` (pi once the pendulum can go over the top).

    ## Action Space
    ``Box(-1, 1, (1,), float32)``: the pivot torque ``tau = a tau_max`` (N m, anticlockwise positive), held over
    the step.

    ## Observation Space
    ``Box([-1, -1, -1, 0, -1, -1], 1, (6,), float32)``: ``sin theta``, ``cos theta``; the angular velocity over
    ``2 sqrt(g/L)`` (the speed at the bottom of a swing that just reaches the top), clipped to [-1, 1]; the
    target amplitude over pi; the energy error ``(E - E*) / (2 m g L)`` with ``E* = m g L (1 - cos theta*)``,
    clipped to [-1, 1]; the amplitude error ``(theta_E - theta*) / pi``.

    ## Rewards
    ``amplitude``: ``-dt |theta_E - theta*| / pi`` (per second of amplitude error, in units of pi); ``effort``:
    ``-effort_weight dt a^2``. The terms of ``info["reward_terms"]``.

    ## Starting State
    Angle uniform in ``+-start_angle_max`` (30 deg), angular velocity uniform in ``+-start_rate_max`` (0.5
    rad/s). Target amplitudes are uniform in ``[target_min, target_max]`` (15 to 120 deg) and change every
    ``change_interval_min`` to ``change_interval_max`` seconds (10 to 20 s), but never within ``final_hold``
    (15 s) of the planned end; the schedule comes from the episode seed alone, never from the actions.
    Pumping a 15 deg swing up to 120 deg takes about 8 s (the torque's power is at most ``tau_max |omega|``).

    ## Episode End
    Never terminated; truncated after ``max_episode_steps`` (800 steps of 0.05 s, 40 s, when registered).
    ``info["is_success"]`` at every step: ``|theta_E - theta*| <= success_tolerance`` (5 deg); at the last
    step, for the final target. Over seeds 0-49 (``tests/test_pendulum_pump.py``) energy pumping ends on target
    in every episode and is on target 83% of the time (mean return -1.58); random torques end on target in 2%
    (-12.8).

    ## Arguments
    ``gymnasium.make("vegym/PendulumPump-v0", render_mode=None, **params)`` with the fields of
    :class:`PendulumPumpParams`. ``info`` per step (SI, radians): ``angle`` (wrapped to [-pi, pi)),
    ``angular_velocity``, ``torque`` (applied this step), ``energy`` (J), ``amplitude`` (theta_E),
    ``target_amplitude`` and ``target_energy`` (the target of this step; the observation already shows a change
    made at this step), ``dt``, ``reward_terms``, ``is_success``. Reference controller: energy pumping
    ``tau = sat(k_E (E* - E) omega, +-tau_max)`` (``agents.analytic``).
    Another episode length takes both ``episode_steps=N`` and ``max_episode_steps=N``: the task plans for
    ``episode_steps``, and ``max_episode_steps`` alone only moves the time limit. A shorter one cuts episodes, whose
    target may then change within ``final_hold`` of the cut; a longer one outlives the plan and warns (a vector env
    when made, a single env at the step past the plan).
    ``episode_steps`` alone keeps the registered time limit, with the same effects: it cuts a longer plan and is
    outlived by a shorter one. A vector env warns when made; a single env cannot see its limit and warns only at a step
    past its plan (``vegym`` train, evaluate and compare make the plan the time limit).

    ## Version History
    * v0: initial version.
    """

    task_cls = PendulumPumpTask


class PendulumPumpVectorEnv(VegymVectorEnv[PendulumPumpParams]):
    """Native vector twin of :class:`PendulumPumpEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = PendulumPumpTask
