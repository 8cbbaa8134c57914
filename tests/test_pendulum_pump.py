"""PendulumPump-v0: energy pumping against random, the target schedule, info in SI, step independence."""

from __future__ import annotations

import math
import re
from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest

import vegym  # noqa: F401
from agents.analytic import PendulumEnergyPumping, controller_for
from vegym import rng
from vegym.envs.pendulum_pump import PendulumPumpParams, PendulumPumpTask
from vegym.physics import pendulum

ENV_ID = "vegym/PendulumPump-v0"
EPISODES = 50


def episodes(policy: str, n: int = EPISODES, seed: int = 0) -> dict[str, np.ndarray]:
    """Return, success at the last step and the fraction of successful steps of one full episode per sub-env."""
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    controller, rng = controller_for(env), np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    returns, on_target = np.zeros(n), np.zeros(n)
    truncated = np.zeros(n, dtype=bool)
    while not truncated.any():
        if policy == "pumping":
            action = controller.predict(obs)[0]
        else:
            action = rng.uniform(-1.0, 1.0, (n, 1)).astype(np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        assert not terminated.any()
        returns += reward
        on_target += info["is_success"]
    assert truncated.all()
    return {"return": returns, "success": info["is_success"], "on_target": on_target / 800}


def test_energy_pumping_holds_every_final_target_and_beats_random_by_far() -> None:
    pump, chance = episodes("pumping"), episodes("random")
    print(
        f"\nPendulumPump-v0 over {EPISODES} episodes: pumping return {pump['return'].mean():.2f}, final success "
        f"{pump['success'].mean():.0%}, on target {pump['on_target'].mean():.0%} of the time; random return "
        f"{chance['return'].mean():.2f}, final success {chance['success'].mean():.0%}, on target "
        f"{chance['on_target'].mean():.0%}"
    )
    assert pump["success"].mean() >= 0.95 and chance["success"].mean() <= 0.1
    assert pump["on_target"].mean() > 0.7 > 0.1 > chance["on_target"].mean()
    assert pump["return"].mean() > 0.25 * chance["return"].mean()  # returns are negative: 4x less error
    assert np.all(pump["return"] > chance["return"])
    assert isinstance(controller_for(gym.make(ENV_ID)), PendulumEnergyPumping)


def test_controller_from_the_observation_is_energy_pumping_on_the_true_state() -> None:
    env = gym.make_vec(ENV_ID, num_envs=64, vectorization_mode="vector_entry_point")
    p: PendulumPumpParams = env.unwrapped.params
    controller = controller_for(env)
    obs, _ = env.reset(seed=2)
    for _ in range(400):
        s = env.unwrapped.state
        torque = pendulum.pump_torque(s["theta"], s["omega"], s["target"], controller.gain, p.max_torque, p.physics)
        action = controller.predict(obs)[0]
        np.testing.assert_allclose(action[:, 0], torque / p.max_torque, atol=1e-4)  # float32 observations
        obs, *_ = env.step(action)


def test_targets_change_at_random_times_from_the_seed_alone_and_never_near_the_end() -> None:
    p = PendulumPumpParams()
    schedules = []
    for seed in (1, 2):
        env = gym.make_vec(ENV_ID, num_envs=200, vectorization_mode="vector_entry_point")
        rng = np.random.default_rng(seed)
        obs, _ = env.reset(seed=9)
        targets = [env.unwrapped.state["target"].copy()]
        for _ in range(p.episode_steps):
            obs, *_ = env.step(rng.uniform(-1.0, 1.0, (200, 1)).astype(np.float32))
            targets.append(env.unwrapped.state["target"].copy())
            np.testing.assert_allclose(obs[:, 3], targets[-1] / np.pi, rtol=1e-6)
        schedules.append(np.array(targets))
    targets = schedules[0]
    np.testing.assert_array_equal(targets, schedules[1])
    assert np.all((targets >= p.target_min) & (targets < p.target_max))
    steps, envs = np.nonzero(targets[1:] != targets[:-1])
    steps = steps + 1
    assert steps.max() <= p.episode_steps - p.final_hold / p.dt
    for i in range(200):
        at = np.concatenate([[0], steps[envs == i]])
        gaps = np.diff(at) * p.dt
        assert len(at) >= 2 and np.all(gaps >= p.change_interval_min - 1e-9) and np.all(gaps <= p.change_interval_max)


def test_info_is_the_pendulum_step_in_si_units() -> None:
    env = gym.make(ENV_ID)
    env.reset(seed=4)
    p: PendulumPumpParams = env.unwrapped.params
    theta, omega = env.unwrapped.state["theta"].copy(), env.unwrapped.state["omega"].copy()
    for a in np.linspace(-1.0, 1.0, 30, dtype=np.float32):
        torque = p.max_torque * float(a)
        for _ in range(p.substeps):
            theta, omega = pendulum.step(theta, omega, torque, p.dt / p.substeps, p.physics)
        _, reward, terminated, truncated, info = env.step(np.array([a]))
        assert set(info) == {
            "angle",
            "angular_velocity",
            "torque",
            "energy",
            "amplitude",
            "target_amplitude",
            "target_energy",
            "dt",
            "reward_terms",
            "is_success",
        }
        assert -math.pi <= info["angle"] < math.pi
        assert math.sin(info["angle"]) == pytest.approx(math.sin(theta[0]), abs=1e-12)
        assert math.cos(info["angle"]) == pytest.approx(math.cos(theta[0]), abs=1e-12)
        assert info["angular_velocity"] == pytest.approx(omega[0], rel=1e-12, abs=1e-12)
        assert (info["torque"], info["dt"]) == (torque, p.dt)
        mgl = p.mass * p.gravity * p.length
        energy = 0.5 * p.mass * p.length**2 * omega[0] ** 2 + mgl * (1 - math.cos(theta[0]))
        assert info["energy"] == pytest.approx(energy, rel=1e-12)
        assert info["amplitude"] == pytest.approx(math.acos(min(1.0, max(-1.0, 1.0 - energy / mgl))), rel=1e-9)
        target = info["target_amplitude"]
        assert info["target_energy"] == pytest.approx(mgl * (1.0 - math.cos(target)), rel=1e-12)
        error = info["amplitude"] - target
        assert info["reward_terms"] == {
            "amplitude": pytest.approx(-p.dt * abs(error) / math.pi, rel=1e-12),
            "effort": pytest.approx(-p.effort_weight * p.dt * float(a) ** 2, rel=1e-6),
        }
        assert reward == sum(info["reward_terms"].values())
        assert info["is_success"] == (abs(error) <= p.success_tolerance)
        assert not terminated and not truncated


def test_the_swing_does_not_depend_on_the_step_only_on_the_time() -> None:
    """A free swing (no torque) over 10 s with control steps of 0.05 s (5 substeps) and 0.01 s (1 substep), the same
    integration step: the same motion, since every parameter is a rate."""
    runs = []
    for dt, substeps in ((0.05, 5), (0.01, 1)):
        env = gym.make(ENV_ID, dt=dt, substeps=substeps, episode_steps=round(40 / dt), max_episode_steps=round(10 / dt))
        env.reset(seed=3)
        for _ in range(round(10 / dt)):
            _, _, _, truncated, info = env.step(np.zeros(1, np.float32))
        assert truncated
        runs.append((info["angle"], info["angular_velocity"], info["energy"]))
    np.testing.assert_allclose(runs[0], runs[1], rtol=1e-9)


def test_the_step_writes_the_observation_of_its_state_bit_for_bit_target_changes_included() -> None:
    """The step kernel reuses the energy and amplitude it computed for its observations; they must be exactly
    those the observe kernel computes from the state (which the vector env uses after resets)."""
    n = 64
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    task, rng = env.unwrapped.task, np.random.default_rng(5)
    env.reset(seed=2)
    changed = 0
    for _ in range(450):
        target = env.unwrapped.state["target"].copy()
        obs, *_ = env.step(rng.uniform(-1.0, 1.0, (n, 1)).astype(np.float32))
        np.testing.assert_array_equal(obs, task.observation(env.unwrapped.state))
        changed += np.count_nonzero(env.unwrapped.state["target"] != target)
    assert changed >= n


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"target_min": 2.5}, "target_min"),
        ({"change_interval_min": 30.0}, "change_interval_min"),
        ({"final_hold": 50.0}, "final_hold"),
        ({"dt": 4.0, "change_interval_min": 20.0, "final_hold": 4.0}, r"substeps=5 is outside .* \[7, 1000\]"),
        ({"length": 1e-4}, r"dt=0.05 is outside .* length=0.0001,"),  # no substeps count is stable: dt is to blame
        ({"length": 1e-7}, r"dt=0.05 is outside"),  # the stable step's formula used to cancel to 0 here
        ({"damping": 1e9}, r"dt=0.05 is outside"),
        ({"damping": 1e200}, r"damping=1e\+200 is outside the allowed range \[0, 1e\+09\]"),  # its square overflowed
        ({"mass": 1e-9}, r"dt=0.05 is outside"),
        ({"target_max": 4.0}, "target_max"),
        ({"length": 0.03, "dt": 4.0, "change_interval_min": 20.0, "final_hold": 4.0}, r"substeps=5 .* \[122, 1000\]"),
        ({"max_torque": 1e9}, r"substeps=5 is outside .* \[791, 1000\] .* \(torque step 6.325e-05 s.*below 4e\+04 N m"),
        ({"length": 1e-3, "mass": 1e-3, "max_torque": 1e9, "substeps": 1000}, r"dt=0.05 is outside .* torque step"),
    ],
)
def test_bad_parameters_raise_value_error_naming_them(kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        gym.make(ENV_ID, **kwargs)


def test_the_energy_and_amplitude_errors_are_observed_from_the_state_in_si_units() -> None:
    """obs[4] = ``clip((E - E*) / (2 m g L), +-1)``, obs[5] = ``(theta_E - theta*) / pi`` with
    ``E = m L^2 omega^2 / 2 + m g L (1 - cos theta)``, ``E* = m g L (1 - cos theta*)`` and
    ``theta_E = arccos(1 - E / (m g L))``, from the state (a heavy long pendulum: m L^2 differs from m g L)."""
    n, m, length, g = 32, 2.0, 1.5, 9.81
    env = gym.make_vec(
        ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", mass=m, length=length, max_torque=6.0
    )
    rng = np.random.default_rng(1)
    env.reset(seed=1)
    signs = np.zeros(2)
    for _ in range(300):
        obs, *_ = env.step(rng.uniform(-1.0, 1.0, (n, 1)).astype(np.float32))
        state = env.unwrapped.state
        theta, omega, target = state["theta"], state["omega"], state["target"]
        energy = 0.5 * m * length**2 * omega**2 + m * g * length * (1.0 - np.cos(theta))
        target_energy = m * g * length * (1.0 - np.cos(target))
        amplitude = np.arccos(np.clip(1.0 - energy / (m * g * length), -1.0, 1.0))
        energy_error = np.clip((energy - target_energy) / (2.0 * m * g * length), -1.0, 1.0)
        np.testing.assert_allclose(obs[:, 4], energy_error, atol=1e-6)
        np.testing.assert_allclose(obs[:, 5], (amplitude - target) / np.pi, atol=1e-6)
        signs += np.count_nonzero(obs[:, 5] > 0.01), np.count_nonzero(obs[:, 5] < -0.01)
    assert signs.min() > n


def test_energy_pumping_s_default_gain_is_2_and_its_torque_the_saturated_pumping_law() -> None:
    """Default ``k_E = 2`` N m per (J rad/s): ``tau = clip(k_E (E* - E) omega, +-tau_max)`` from the observation."""
    p = PendulumPumpParams(mass=0.5, length=0.8)
    controller = PendulumEnergyPumping(p)
    assert controller.gain == 2.0
    theta = np.array([0.1, -0.3, 0.5, 1.2, -0.05])
    omega = np.array([0.2, -0.15, 0.05, 0.3, -2.0])
    target = np.array([0.4, 0.2, 1.0, 0.9, 1.5])
    scale = 2.0 * np.sqrt(p.gravity / p.length)
    obs = np.stack([np.sin(theta), np.cos(theta), omega / scale, target / np.pi, 0 * theta, 0 * theta], axis=-1)
    obs = obs.astype(np.float32)
    th, om, tg = np.arctan2(obs[:, 0], obs[:, 1]), obs[:, 2] * scale, obs[:, 3] * np.pi
    mgl, inertia = p.mass * p.gravity * p.length, p.mass * p.length**2
    energy = 0.5 * inertia * om**2 + mgl * (1.0 - np.cos(th))
    torque = np.clip(2.0 * (mgl * (1.0 - np.cos(tg)) - energy) * om, -p.max_torque, p.max_torque)
    assert np.abs(torque[:4]).max() < 0.9 * p.max_torque and abs(torque[4]) == p.max_torque
    np.testing.assert_allclose(controller.act(obs)[:, 0], torque / p.max_torque, rtol=1e-6, atol=1e-7)


def test_starts_fill_their_symmetric_ranges_with_independent_draws(assert_independent_draws_fill: Callable) -> None:
    p = PendulumPumpParams()
    state = PendulumPumpTask(p).initial_state(rng.seed_keys(np.arange(4000)))
    assert_independent_draws_fill(
        {
            "angle": (state["theta"], -p.start_angle_max, p.start_angle_max),
            "rate": (state["omega"], -p.start_rate_max, p.start_rate_max),
            "target": (state["target"], p.target_min, p.target_max),
        }
    )


def test_the_observation_space_is_the_documented_box_and_its_rate_clips_at_one() -> None:
    env = gym.make(ENV_ID)
    np.testing.assert_array_equal(env.observation_space.low, [-1, -1, -1, 0, -1, -1])
    np.testing.assert_array_equal(env.observation_space.high, [1, 1, 1, 1, 1, 1])
    env.reset(seed=0)
    task, state = env.unwrapped.task, {k: v.copy() for k, v in env.unwrapped.state.items()}
    state["omega"][0] = 10.0
    assert task.observation(state)[0, 2] == 1.0
    state["omega"][0] = -10.0
    assert task.observation(state)[0, 2] == -1.0


def test_a_single_env_changes_its_target_after_the_planned_step_and_equal_target_bounds_fix_it() -> None:
    env = gym.make(ENV_ID)
    env.reset(seed=9)
    state = env.unwrapped.state
    planned, target = int(state["next_change"][0]), float(state["target"][0])
    for step in range(1, planned + 1):
        info = env.step(np.zeros(1, np.float32))[4]
        assert info["target_amplitude"] == target  # the step's target
        assert (state["target"][0] != target) == (step == planned), step  # the next step's
    fixed = gym.make(ENV_ID, target_min=1.0, target_max=1.0)
    fixed.reset(seed=9)
    assert all(fixed.step(np.zeros(1, np.float32))[4]["target_amplitude"] == 1.0 for _ in range(planned + 50))


def test_is_success_is_the_amplitude_error_within_the_tolerance() -> None:
    env = gym.make_vec(ENV_ID, num_envs=32, vectorization_mode="vector_entry_point")
    tolerance = env.unwrapped.params.success_tolerance
    controller = controller_for(env)
    obs, _ = env.reset(seed=3)
    near = 0
    for _ in range(300):
        obs, _, _, _, info = env.step(controller.predict(obs)[0])
        error = np.abs(info["amplitude"] - info["target_amplitude"])
        np.testing.assert_array_equal(info["is_success"], error <= tolerance)
        near += np.count_nonzero((error > tolerance) & (error <= 2.0 * tolerance))
    assert near >= 16


def test_the_strongest_torque_allowed_keeps_an_undamped_pendulum_finite() -> None:
    """Full torque on an undamped pendulum just inside ``max_torque h^2 / (m L^2) < 4`` (1,000 substeps) spins it
    ever faster, and its observations stay finite and in the box over the planned episode; at 1e8 instead of 4
    (allowed before the torque step) the angle reached NaN after 4,141 steps; just above 4 is refused."""
    length, mass, dt, substeps = 1e-3, 1e-3, 0.05, 1000
    max_torque = 3.99 * mass * length**2 / (dt / substeps) ** 2
    env = gym.make(ENV_ID, length=length, mass=mass, damping=0.0, max_torque=max_torque, substeps=substeps)
    assert env.unwrapped.params.step_length < env.unwrapped.params.max_torque_step
    stronger = 4.01 * mass * length**2 / (dt / substeps) ** 2
    with pytest.raises(ValueError, match=r"dt=0.05 is outside .* torque step"):
        gym.make(ENV_ID, length=length, mass=mass, damping=0.0, max_torque=stronger, substeps=substeps)
    env.reset(seed=0)
    for _ in range(800):
        obs, reward, *_ = env.step(np.ones(1, np.float32))
        assert env.observation_space.contains(obs) and np.isfinite(reward)
    assert abs(env.unwrapped.state["omega"][0]) > 1e10  # spun up, not refused


@pytest.mark.parametrize("length", [5e-324, 1e-300, 1e300])
def test_a_length_whose_inertia_is_no_positive_finite_float_is_refused_by_its_range(length: float) -> None:
    """m L^2 underflowed to 0 at length=1e-300 (allowed once: (0, inf)): the stable-step check divided by it and
    raised ZeroDivisionError; at length=1e300 it overflowed to inf and the first observation held NaN (a helper's
    fuzzing). Lengths and masses lie in [1e-9, 1e9] now."""
    with pytest.raises(
        ValueError, match=rf"length={re.escape(repr(length))} is outside the allowed range \[1e-09, 1e\+09\]"
    ):
        gym.make(ENV_ID, length=length)
    with pytest.raises(ValueError, match=rf"length={re.escape(repr(length))}"):
        gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", length=length)
