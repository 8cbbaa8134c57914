"""Suspension-v0: a semi-active quarter-car damper over seeded undulating terrain, for ride comfort."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs.base import Info, KernelCall, State, Task, VegymEnv, VegymVectorEnv
from vegym.params import Params, param
from vegym.physics import suspension
from vegym.physics.particle import STANDARD_GRAVITY
from vegym.physics.suspension import SpringParams

_TERRAIN_STREAM = 1


@dataclass(frozen=True)
class SuspensionParams(Params):
    """Parameters of Suspension-v0 (SI units, y up; the travel is the spring length minus its static length)."""

    mass: float = param(300.0, "m, sprung mass: a quarter of the car body (kg)", low=0.0, low_open=True)
    modulus: float = param(8000.0, "lambda, spring modulus (N); stiffness k = lambda / l", low=0.0, low_open=True)
    natural_length: float = param(0.4, "l, natural length of the spring (m)", low=0.0, low_open=True)
    gravity: float = param(STANDARD_GRAVITY, "gravitational acceleration magnitude (m/s^2)", low=0.0)
    damping_min: float = param(300.0, "c_min, softest damper setting (N s/m)", low=0.0)
    damping_max: float = param(4000.0, "c_max, stiffest damper setting (N s/m)", low=0.0, low_open=True)
    speed: float = param(10.0, "forward speed of the wheel over the terrain (m/s)", low=0.0, low_open=True)
    n_waves: int = param(3, "sinusoids summed into the terrain profile", low=1, high=16)
    wavelength_min: float = param(1.5, "shortest terrain wavelength (m)", low=0.0, low_open=True)
    wavelength_max: float = param(30.0, "longest terrain wavelength (m)", low=0.0, low_open=True)
    slope_min: float = param(0.005, "smallest slope amplitude A kappa of one sinusoid (A: its amplitude, m)", low=0.0)
    slope_max: float = param(0.01, "largest slope amplitude A kappa of one sinusoid", low=0.0)
    travel_limit: float = param(
        0.04,
        "bump stops: largest |spring length - static length| (m); beyond it the episode ends",
        low=0.0,
        low_open=True,
    )
    dt: float = param(0.01, "control and integration step (s)", low=0.0, low_open=True)
    episode_steps: int = param(1000, "planned episode length (steps): the registered max_episode_steps", low=1)
    accel_scale: float = param(
        3.0, "body acceleration of a full unit of observation and comfort cost (m/s^2)", low=0.0, low_open=True
    )
    velocity_scale: float = param(
        0.4,
        "velocity of a full unit of observation (m/s); a little over travel_limit sqrt(k/m), 0.33 m/s by default",
        low=0.0,
        low_open=True,
    )
    comfort_rms: float = param(0.8, "is_success: largest RMS body acceleration so far (m/s^2)", low=0.0)
    bottom_out_penalty: float = param(1.0, "cost of hitting a bump stop, besides the rest of the episode's", low=0.0)

    def validate(self) -> None:
        if self.static_length <= 0.0:
            weight = f"mass * gravity = {self.mass:g} * {self.gravity:g} = {self.mass * self.gravity:g}"
            raise self.between(
                "modulus", (weight, self.mass * self.gravity), low_open=True, reason=": the spring bottoms out"
            )
        if self.damping_min > self.damping_max:
            raise self.between("damping_min", high="damping_max")
        if self.slope_min > self.slope_max:
            raise self.between("slope_min", high="slope_max")
        if self.wavelength_min > self.wavelength_max:
            raise self.between("wavelength_min", high="wavelength_max")
        stable = self.spring.max_stable_step(self.damping_max)
        if self.dt >= stable:
            reason = (
                f": semi-implicit Euler is unstable beyond it, for damping_max={self.damping_max:g}, "
                f"mass={self.mass:g}, modulus={self.modulus:g} and natural_length={self.natural_length:g}"
            )
            raise self.between("dt", high=(f"{stable:.4g}", stable), high_open=True, reason=reason)

    @property
    def spring(self) -> SpringParams:
        """The spring-mass physics parameters."""
        return self.subset(SpringParams)

    @property
    def static_length(self) -> float:
        """Spring length at rest on a level road, ``l - m g / k`` (m)."""
        return self.spring.static_length


STEP_CONSTANTS = (
    "damping_min",
    "damping_max",
    "dt",
    "speed",
    "static_length",
    "travel_limit",
    "episode_steps",
    "accel_scale",
    "bottom_out_penalty",
    "comfort_rms",
    "velocity_scale",
)
"""Parameters the kernels read, in the order of their constants array (SI units, see the fields); the spring's
``(k, l, m, g)`` of ``suspension.body_step`` follow them."""
REWARD_TERMS = ("comfort", "bump_stop")
"""Names of ``info["reward_terms"]``, in the order of the step kernel's ``terms`` columns."""
MEASURES = ("travel", "damping", "rms_acceleration")
"""The info entries in the step kernel's ``measures`` columns: suspension travel (m), damper coefficient (N s/m),
RMS body acceleration since the start (m/s^2)."""


@njit(cache=True, nogil=True, error_model="numpy")
def _step_kernel(
    action: np.ndarray,
    height: np.ndarray,
    velocity: np.ndarray,
    base: np.ndarray,
    base_velocity: np.ndarray,
    distance: np.ndarray,
    acceleration: np.ndarray,
    squared_acceleration: np.ndarray,
    step: np.ndarray,
    amplitude: np.ndarray,
    wavenumber: np.ndarray,
    phase: np.ndarray,
    offset: np.ndarray,
    c: np.ndarray,
    measures: np.ndarray,
    terms: np.ndarray,
    reward: np.ndarray,
    success: np.ndarray,
    terminated: np.ndarray,
    obs: np.ndarray,
) -> None:
    """The whole step and the next observation, in place on the state arrays (``height`` to
    ``squared_acceleration``; ``step``, the steps taken before this one, and the terrain ``amplitude`` to
    ``offset`` are read only) and into the outputs (``measures`` to ``obs``): the columns of ``MEASURES``
    (suspension travel (m), damper coefficient (N s/m), RMS body acceleration since the start (m/s^2)), the
    reward terms (comfort, bump stop), reward, is_success and terminated (bump stop hit); ``c`` holds the
    parameters named in ``STEP_CONSTANTS``, then the spring's ``(k, l, m, g)``.

    Written as passes over the batch, each a loop without calls or exits that the compiler turns into SIMD code:
    the terrain under the wheel's new position, the quarter-car step, its measures and reward (a pass of their
    own: one loop over all these arrays exceeds the compiler's budget of run-time alias checks and stays scalar),
    the measures' and terms' columns, the observation."""
    damping_min, damping_max, dt, speed, static_length, travel_limit = c[0], c[1], c[2], c[3], c[4], c[5]
    episode_steps, accel_scale, bottom_out_penalty, comfort_rms = c[6], c[7], c[8], c[9]
    spring = (c[11], c[12], c[13], c[14])
    n = len(action)
    for i in range(n):
        distance[i] = distance[i] + speed * dt
    ground, slope = np.empty(n), np.empty(n)
    suspension.terrain_into(distance, amplitude, wavenumber, phase, ground, slope)
    damping = np.empty(n)
    for i in range(n):  # the quarter-car
        damping[i] = damping_min + 0.5 * (action[i, 0] + 1.0) * (damping_max - damping_min)
        y, v, a = suspension.body_step(height[i], velocity[i], base[i], base_velocity[i], damping[i], dt, 0.0, spring)
        height[i], velocity[i], base[i], base_velocity[i] = y, v, ground[i] - offset[i], slope[i] * speed
        acceleration[i], squared_acceleration[i] = a, squared_acceleration[i] + dt * a * a
    travel, rms, comfort, bump = ground, slope, np.empty(n), np.empty(n)  # the terrain's scratch reused
    for i in range(n):  # its measures and reward
        travel[i] = height[i] - base[i] - static_length
        bottomed = abs(travel[i]) > travel_limit
        rms[i] = math.sqrt(squared_acceleration[i] / ((step[i] + 1) * dt))
        remaining = max(episode_steps - step[i] - 1, 0.0) * dt
        comfort[i] = -dt * min((acceleration[i] / accel_scale) ** 2, 1.0)
        bump[i] = -(bottom_out_penalty + remaining) if bottomed else 0.0
        reward[i] = comfort[i] + bump[i]
        success[i], terminated[i] = (not bottomed) & (rms[i] <= comfort_rms), bottomed
    for i in range(n):  # a pass of its own: strided stores would keep the step's pass from SIMD code
        measures[i, 0], measures[i, 1], measures[i, 2] = travel[i], damping[i], rms[i]
        terms[i, 0], terms[i, 1] = comfort[i], bump[i]
    _observe_kernel(height, velocity, base, base_velocity, acceleration, c, obs)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe_kernel(
    height: np.ndarray, velocity: np.ndarray, base: np.ndarray, base_velocity: np.ndarray, acceleration: np.ndarray,
    c: np.ndarray, obs: np.ndarray,
) -> None:  # fmt: skip
    """Observations (n, 4) written into ``obs``; ``c`` holds the parameters named in ``STEP_CONSTANTS``."""
    static_length, travel_limit, accel_scale, velocity_scale = c[4], c[5], c[7], c[10]
    flat = obs.reshape(-1)  # rows of 4 at a constant stride: interleaved vector stores
    for i in range(len(height)):
        flat[4 * i] = min(max((height[i] - base[i] - static_length) / travel_limit, -1.0), 1.0)
        flat[4 * i + 1] = min(max(velocity[i] / velocity_scale, -1.0), 1.0)
        flat[4 * i + 2] = min(max((velocity[i] - base_velocity[i]) / velocity_scale, -1.0), 1.0)
        flat[4 * i + 3] = min(max(acceleration[i] / accel_scale, -1.0), 1.0)


class SuspensionTask(Task[SuspensionParams]):
    """Batched logic of Suspension-v0 (see :class:`SuspensionEnv`)."""

    params_cls = SuspensionParams
    planned_length_param = "episode_steps"
    renderer = "vegym.render.suspension:SuspensionRenderer"

    def __init__(self, params: SuspensionParams) -> None:
        super().__init__(params)
        self.spring = params.spring
        self.static_length = params.static_length
        self.observation_space = spaces.Box(-1.0, 1.0, (4,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        spring = (self.spring.stiffness, self.spring.natural_length, self.spring.mass, self.spring.gravity)
        self._constants = np.array([*(getattr(params, name) for name in STEP_CONSTANTS), *spring], dtype=np.float64)

    @property
    def control_rate(self) -> float:
        return 1.0 / self.params.dt

    def initial_state(self, keys: np.ndarray) -> State:
        p = self.params
        n, j = len(keys), p.n_waves
        u = rng.uniform(keys, _TERRAIN_STREAM, 3 * j)
        wavelength = p.wavelength_min * (p.wavelength_max / p.wavelength_min) ** u[:, :j]
        wavenumber = 2.0 * np.pi / wavelength
        amplitude = (p.slope_min + (p.slope_max - p.slope_min) * u[:, j : 2 * j]) / wavenumber
        phase = 2.0 * np.pi * u[:, 2 * j :]
        start, slope = suspension.terrain(np.zeros(n), amplitude, wavenumber, phase)
        base_velocity = slope * p.speed
        return {
            "amplitude": amplitude,
            "wavenumber": wavenumber,
            "phase": phase,
            "offset": start,
            "distance": np.zeros(n),
            "height": np.full(n, self.static_length),
            "velocity": base_velocity,
            "base": np.zeros(n),
            "base_velocity": base_velocity.copy(),
            "acceleration": np.zeros(n),
            "squared_acceleration": np.zeros(n),
        }

    def output_shapes(self) -> dict[str, tuple[tuple[int, ...], type]]:
        return {
            "measures": ((len(MEASURES),), np.float64),
            "terms": ((len(REWARD_TERMS),), np.float64),
            "success": ((), np.bool_),
        }

    def step_call(self, state: State, action: np.ndarray, out: State) -> KernelCall:
        return _step_kernel, (
            action, state["height"], state["velocity"], state["base"], state["base_velocity"], state["distance"],
            state["acceleration"], state["squared_acceleration"], state["step"], state["amplitude"],
            state["wavenumber"], state["phase"], state["offset"], self._constants, out["measures"], out["terms"],
            out["reward"], out["success"], out["terminated"], out["obs"],
        )  # fmt: skip

    def info(self, state: State, out: State) -> Info:
        travel, damping, rms = out["measures"].T
        return {
            "body_height": state["height"],
            "body_velocity": state["velocity"],
            "body_acceleration": state["acceleration"],
            "base_height": state["base"],
            "base_velocity": state["base_velocity"],
            "travel": travel,
            "damping": damping,
            "distance": state["distance"],
            "rms_acceleration": rms,
            "dt": self.params.dt,
            "reward_terms": dict(zip(REWARD_TERMS, out["terms"].T, strict=True)),
            "is_success": out["success"],
        }

    def observe(self, state: State, obs: np.ndarray) -> None:
        _observe_kernel(
            state["height"], state["velocity"], state["base"], state["base_velocity"], state["acceleration"],
            self._constants, obs,
        )  # fmt: skip


class SuspensionEnv(VegymEnv[SuspensionParams]):
    """Semi-active suspension: set a quarter-car's damper at each step for ride comfort over undulating terrain.

    ## Description
    The moving spring of the chapter (8.6.2) in the corrected quarter-car form of PHYSICS.md section 8: a body of
    mass m sits on a spring (modulus lambda, natural length l, stiffness ``k = lambda / l``) and a damper whose
    foot is the axle of a wheel rolling at ``speed`` over a terrain of ``n_waves`` sinusoids. The axle height is
    the cumulative base displacement ``y_b = terrain(x) - terrain(x_0)`` (not the book's per-step difference), and
    the body follows ``dv/dt = -(k/m)(y - y_b - l) - (c/m)(v - v_b) - g``, one semi-implicit Euler step per
    control step. The damper is semi-active: the agent sets its coefficient c within ``[c_min, c_max]`` but can
    never push, only resist the relative velocity. A soft damper isolates the body from short bumps but lets it
    resonate (natural frequency ``sqrt(k/m)``, 8.2 rad/s at the defaults) and hit the bump stops on long waves;
    a stiff one transmits the short bumps. Terrain wavelengths span 1.5 to 30 m, so at 10 m/s the road shakes
    the car from 0.26 to 5 times its natural frequency.

    ## Action Space
    ``Box(-1, 1, (1,), float32)``: the damper coefficient ``c = c_min + (a + 1)/2 (c_max - c_min)`` (N s/m),
    held over the step.

    ## Observation Space
    ``Box(-1, 1, (4,), float32)``: suspension travel (spring length minus its static length) over
    ``travel_limit``; body velocity v and relative velocity ``v - v_b`` (body minus axle) over
    ``velocity_scale``; the body acceleration of the last step over ``accel_scale``. All clipped to [-1, 1];
    the travel is inside it until the episode ends. With the defaults, over seeds 0-199 under either skyhook law
    or random actions, the four entries have standard deviations of 0.17-0.29, and the velocities stay below
    0.32 m/s under the laws and 0.38 m/s under random actions, inside ``velocity_scale`` (0.4 m/s): unclipped.

    ## Rewards
    ``comfort``: ``-dt min((a / accel_scale)^2, 1)`` with a the body acceleration over the step (a squared
    acceleration cost, so a return is minus the time integral of the normalised squared acceleration).
    ``bump_stop``: on hitting a bump stop, ``-(bottom_out_penalty + remaining planned time)``, which is at least
    the most the rest of the episode could have cost, so ending the episode early never pays.

    ## Starting State
    The body at its static height above the axle, moving with it (no initial spring deflection or relative
    velocity). The terrain is drawn from the episode seed: wavelengths log-uniform in ``[wavelength_min,
    wavelength_max]``, slope amplitudes ``A kappa`` uniform in ``[slope_min, slope_max]`` (so the amplitude A grows
    with the wavelength, as on real roads), phases uniform.

    ## Episode End
    Terminated when ``|travel| > travel_limit`` (a bump stop is hit); truncated after ``max_episode_steps``
    (1000 steps of 0.01 s when registered). ``info["is_success"]`` at every step: no bump stop hit and the RMS
    body acceleration since the start at most ``comfort_rms`` (0.8 m/s^2, where ISO 2631-1 starts calling a ride
    uncomfortable; unweighted here); at the last step, the verdict on the whole drive. Over the first episodes
    of seeds 0-49 (``tests/test_suspension.py``) the skyhook succeeds on 88% with a mean return of -0.52, random
    actions on 46% with -0.85, and the best constant damper (mid-range) on 54% with -0.75; the softest damper
    hits the bump stops on a third of the roads.

    ## Arguments
    ``gymnasium.make("vegym/Suspension-v0", render_mode=None, **params)`` with the fields of
    :class:`SuspensionParams`. ``info`` per step (SI, y up): ``body_height``, ``body_velocity``,
    ``body_acceleration`` (over the step), ``base_height`` and ``base_velocity`` (axle, relative to its start),
    ``travel``, ``damping`` (c applied), ``distance`` travelled, ``rms_acceleration`` (since the start),
    ``dt``, ``reward_terms``, ``is_success``. Reference controller: on-off skyhook, ``c_max`` when
    ``v (v - v_b) > 0`` else ``c_min`` (``agents.analytic``). A stronger reference, the continuous skyhook
    (``c`` matching the sky damper's force ``c_max v`` within the damper's range), succeeds on 96% of the same
    50 roads with a mean return of -0.42.
    Another episode length takes both ``episode_steps=N`` and ``max_episode_steps=N``: the task plans for
    ``episode_steps``, and ``max_episode_steps`` alone only moves the time limit. A shorter one cuts episodes, whose
    bump-stop charge still counts the planned steps; a longer one outlives the plan and warns (a vector env when
    made, a single env at the step past the plan).
    ``episode_steps`` alone keeps the registered time limit, with the same effects: it cuts a longer plan and is
    outlived by a shorter one. A vector env warns when made; a single env cannot see its limit and warns only at a step
    past its plan (``vegym`` train, evaluate and compare make the plan the time limit).

    ## Version History
    * v0: initial version.
    """

    task_cls = SuspensionTask


class SuspensionVectorEnv(VegymVectorEnv[SuspensionParams]):
    """Native vector twin of :class:`SuspensionEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = SuspensionTask
