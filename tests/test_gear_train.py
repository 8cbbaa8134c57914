"""GearTrain-v0: the ratio law and sign alternation in the env, the targets, and the proportional baseline."""

from __future__ import annotations

import re
from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest

import vegym  # noqa: F401
from agents.analytic import GearTrainProportional, controller_for
from vegym.envs import gear_train
from vegym.envs.base import owned
from vegym.envs.gear_train import GearTrainParams, GearTrainTask
from vegym.physics import wheel

ENV_ID = "vegym/GearTrain-v0"


def episodes(policy: str, n: int = 100, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return, final success and final |error| (rad) of one full episode of each of n sub-envs."""
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    controller = controller_for(env)
    env.action_space.seed(seed)
    obs, _ = env.reset(seed=seed)
    returns = np.zeros(n)
    for _ in range(env.unwrapped.max_episode_steps):
        action = controller.predict(obs)[0] if policy == "proportional" else env.action_space.sample()
        obs, reward, terminated, truncated, info = env.step(action)
        returns += reward
    assert truncated.all() and not terminated.any()
    return returns, info["is_success"], np.abs(info["error"])


def test_proportional_control_through_the_ratio_holds_every_target_and_beats_random_by_far() -> None:
    returns, success, error = episodes("proportional")
    random_returns, random_success, _ = episodes("random")
    assert success.all() and error.max() < 1e-6
    assert random_success.mean() < 0.05
    assert returns.mean() > random_returns.mean() + 3.0
    assert isinstance(controller_for(gym.make(ENV_ID)), GearTrainProportional)


def test_every_gear_turns_by_the_ratio_law_with_alternating_signs_and_equal_rim_speeds() -> None:
    task = GearTrainTask(GearTrainParams())
    n = 64
    keys = vegym.rng.seed_keys(np.arange(n))
    state = owned({**task.initial_state(keys), "key": keys, "step": np.zeros(n, np.int64)})
    rows = np.arange(n)
    assert set(state["gears"]) == {2, 3, 4, 5}
    last = state["gears"] - 1
    ratio = task.ratio(state)
    first, final = state["radii"][:, 0], state["radii"][rows, last]
    np.testing.assert_allclose(ratio, (-1.0) ** last * first / final, rtol=1e-15)
    for count in (2, 3, 4, 5):
        chains = state["gears"] == count
        np.testing.assert_allclose(ratio[chains], wheel.train_ratio(state["radii"][chains, :count]), rtol=1e-15)
    actions = np.random.default_rng(1).uniform(-1, 1, (40, n, 1))
    out = task.outputs(n)
    for action in actions:
        angles = state["angles"].copy()
        task.step(state, action, out)
        info = task.info(state, out)
        turned = wheel.wrap_angle(state["angles"] - angles) / task.params.dt
        np.testing.assert_allclose(turned[:, 0], info["input_speed"], atol=1e-12)
        np.testing.assert_allclose(turned[:, 1:] * state["radii"][:, 1:], -turned[:, :-1] * state["radii"][:, :-1])
        np.testing.assert_allclose(turned[rows, last], ratio * info["input_speed"], atol=1e-12)
        moving = np.abs(info["input_speed"]) > 1e-9
        np.testing.assert_array_equal(np.sign(turned[moving]), np.sign(turned[moving, :1]) * (-1.0) ** np.arange(5))
        state["step"] += 1


def test_the_motor_follows_its_command_within_the_acceleration_limit() -> None:
    p = GearTrainParams()
    task = GearTrainTask(p)
    keys = vegym.rng.seed_keys(np.arange(3))
    state = owned({**task.initial_state(keys), "key": keys, "step": np.zeros(3, np.int64)})
    out, speeds = task.outputs(3), []
    for _ in range(8):
        task.step(state, np.array([[1.0], [-1.0], [0.05]]), out)
        speeds.append(task.info(state, out)["input_speed"].copy())
        state["step"] += 1
    dv = p.max_acceleration * p.dt
    np.testing.assert_allclose(np.array(speeds)[:, 0], np.minimum(dv * np.arange(1, 9), p.max_speed))
    np.testing.assert_allclose(np.array(speeds)[:, 1], -np.minimum(dv * np.arange(1, 9), p.max_speed))
    np.testing.assert_allclose(np.array(speeds)[:, 2], 0.05 * p.max_speed)


def test_targets_change_every_interval_from_the_key_alone_and_the_observation_wraps_the_error() -> None:
    p = GearTrainParams(target_interval=0.5)
    task = GearTrainTask(p)
    keys = vegym.rng.seed_keys(np.arange(4))
    steps = np.arange(40)
    targets = np.array([task.target(keys, np.full(4, k)) for k in steps])
    changes = np.flatnonzero(np.any(np.diff(targets, axis=0) != 0, axis=1)) + 1
    np.testing.assert_array_equal(changes, [10, 20, 30])
    assert np.abs(targets).max() <= np.pi
    period_2 = vegym.rng.uniform(keys, gear_train._TARGET_STREAM, 1, counter=2)[:, 0]  # the episode's stream
    np.testing.assert_array_equal(targets[25], np.pi * (2.0 * period_2 - 1.0))
    state = owned({**task.initial_state(keys), "key": keys, "step": np.zeros(4, np.int64)})
    output = task.output_angle(state)
    obs = np.empty((4, 4), np.float32)
    task.observe(state, obs)
    np.testing.assert_allclose(np.arctan2(obs[:, 0], obs[:, 1]), wheel.wrap_angle(targets[0] - output), atol=1e-6)
    out = task.outputs(4)
    task.step(state, np.zeros((4, 1)), out)
    assert task.info(state, out)["error"] == pytest.approx(wheel.wrap_angle(targets[0] - output))
    np.testing.assert_array_equal(out["target"], targets[0])


def test_the_step_writes_the_observation_of_its_state_bit_for_bit_across_target_changes_and_resets() -> None:
    n = 64
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    task, rng = env.unwrapped.task, np.random.default_rng(5)
    env.reset(seed=2)
    assert len(np.unique(env.unwrapped.state["gears"])) == 4  # every chain length, 2 to 5 gears
    for _ in range(250):  # targets change at steps 100 and 200, episodes end after 200
        obs, *_ = env.step(rng.uniform(-1.0, 1.0, (n, 1)).astype(np.float32))
        np.testing.assert_array_equal(obs, task.observation(env.unwrapped.state))


def test_parameters_that_could_turn_the_output_half_a_turn_per_step_are_rejected() -> None:
    with pytest.raises(ValueError, match="max_speed"):
        GearTrainParams(max_speed=20.0)
    bound = re.escape("[1e-09, pi / (dt * radius_max / radius_min) = pi / (0.5 * 0.08 / 0.02) = 1.571)")
    with pytest.raises(ValueError, match=f"max_speed=10.0 is outside the allowed range {bound}"):  # dt's choice
        GearTrainParams(dt=0.5)
    with pytest.raises(ValueError, match="gears_min"):
        GearTrainParams(gears_min=6)
    with pytest.raises(ValueError, match="target_interval"):
        GearTrainParams(target_interval=0.01)


def test_is_success_is_the_wrapped_output_error_within_the_tolerance_on_every_step() -> None:
    """``is_success == (|wrap(target - output)| <= tolerance)``, on episodes whose error crosses the tolerance."""
    n, tolerance = 32, 0.05
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", tolerance=tolerance)
    controller = controller_for(env)
    obs, _ = env.reset(seed=7)
    near = 0
    for _ in range(150):
        obs, _, _, _, info = env.step(controller.predict(obs)[0])
        error = np.abs(np.angle(np.exp(1j * (info["target_angle"] - info["output_angle"]))))
        np.testing.assert_allclose(error, np.abs(info["error"]), atol=1e-12)
        np.testing.assert_array_equal(info["is_success"], error <= tolerance)
        near += np.count_nonzero((error > tolerance) & (error <= 2.0 * tolerance))
    assert near >= n // 2


def test_the_observed_motor_speed_is_the_rate_limited_command_over_max_speed() -> None:
    """obs[2] = v / max_speed with ``v_k = clip(a max_speed, v_{k-1} - max_acceleration dt, v_{k-1} + ...)``."""
    n, max_speed, max_acceleration, dt = 16, 6.0, 30.0, 0.04
    env = gym.make_vec(
        ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", max_speed=max_speed,
        max_acceleration=max_acceleration, dt=dt,
    )  # fmt: skip
    rng = np.random.default_rng(3)
    obs, _ = env.reset(seed=3)
    np.testing.assert_array_equal(obs[:, 2], 0.0)
    speed = np.zeros(n)
    for _ in range(120):
        action = rng.uniform(-1.0, 1.0, (n, 1)).astype(np.float32)
        obs, _, _, truncated, info = env.step(action)
        assert not truncated.any()
        step = max_acceleration * dt
        speed = np.clip(max_speed * action[:, 0].astype(np.float64), speed - step, speed + step)
        np.testing.assert_allclose(info["input_speed"], speed, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(obs[:, 2], speed / max_speed, rtol=1e-6, atol=1e-7)
    assert np.abs(obs[:, 2]).max() > 0.5


def test_the_proportional_controller_s_default_gain_halves_the_error_per_step() -> None:
    """Default ``k = 1 / (2 dt)``: ``a = clip(k atan2(sin, cos) / rho, +-max_speed) / max_speed``."""
    p = GearTrainParams(dt=0.04)
    controller = GearTrainProportional(p)
    assert controller.gain == pytest.approx(0.5 / p.dt, rel=1e-15)
    error = np.array([0.01, -0.02, 0.05, -0.003, 2.5])
    ratio = np.array([0.5, -1.5, 3.0, -0.7, 0.4])  # omega_out / omega_in
    obs = np.stack([np.sin(error), np.cos(error), np.zeros(5), ratio / p.ratio_max], axis=-1).astype(np.float32)
    sin, cos, rho = (obs[:, k].astype(np.float64) for k in (0, 1, 3))
    demand = 0.5 / p.dt * np.arctan2(sin, cos) / (rho * p.ratio_max)
    expected = np.clip(demand, -p.max_speed, p.max_speed) / p.max_speed
    assert np.abs(expected[:4]).max() < 0.9 and expected[4] == 1.0  # the small errors unsaturated
    np.testing.assert_allclose(controller.act(obs)[:, 0], expected, rtol=1e-6)


def test_reward_terms_are_the_documented_tracking_and_effort_costs_and_the_output_turns_at_the_ratio() -> None:
    """Rewards: ``tracking = -tracking_weight * dt * |error| / pi`` and ``effort = -effort_weight * dt * a^2``;
    the output gear turns at ``ratio`` times the input speed."""
    env = gym.make(ENV_ID, tracking_weight=2.0, effort_weight=0.03)
    env.reset(seed=0)
    p = env.unwrapped.params
    for a in (0.5, 1.0, 0.2, -0.3):
        info = env.step(np.array([a], np.float32))[4]
        assert info["reward_terms"]["tracking"] == pytest.approx(-2.0 * p.dt * abs(info["error"]) / np.pi, rel=1e-12)
        assert info["reward_terms"]["effort"] == pytest.approx(-0.03 * p.dt * float(np.float32(a)) ** 2, rel=1e-12)
        assert info["output_speed"] == pytest.approx(info["ratio"] * info["input_speed"], rel=1e-12)
        assert info["output_speed"] != 0.0


def test_trains_fill_their_documented_ranges_with_independent_draws(assert_independent_draws_fill: Callable) -> None:
    p = GearTrainParams()
    state = GearTrainTask(p).initial_state(vegym.rng.seed_keys(np.arange(4000)))
    gears = state["gears"]
    assert set(np.unique(gears)) == set(range(p.gears_min, p.gears_max + 1))
    assert_independent_draws_fill(
        {
            "gears": (gears.astype(float), p.gears_min, p.gears_max),
            "first radius": (state["radii"][:, 0], p.radius_min, p.radius_max),
            "last radius": (state["radii"][:, -1], p.radius_min, p.radius_max),
            "first angle": (state["angles"][:, 0], -np.pi, np.pi),
            "last angle": (state["angles"][:, -1], -np.pi, np.pi),
        }
    )


def test_the_range_checks_admit_their_closed_ends_and_the_target_interval_rounds_to_steps() -> None:
    fixed = gym.make(ENV_ID, gears_min=3, gears_max=3)
    fixed.reset(seed=0)
    assert fixed.step(np.zeros(1, np.float32))[4]["gears"] == 3
    GearTrainParams(target_interval=0.05, dt=0.05)
    assert GearTrainParams(target_interval=0.3, dt=0.1, max_speed=5.0).interval_steps == 3  # 2.9999999999999996


@pytest.mark.parametrize("kwargs", [{"dt": 5e-324}, {"dt": 1e-300}, {"dt": 1e-9, "target_interval": 1e11}])
def test_a_target_interval_of_more_steps_than_an_int64_holds_is_refused_by_the_ranges(kwargs: dict) -> None:
    """round(target_interval / dt) steps between target changes: dt=5e-324 (allowed once: (0, 1]) raised
    OverflowError (the round of inf) at make, and dt=1e-300, or dt=1e-9 with target_interval=1e11, numba's
    TypingError at the first reset (an integer beyond uint64 for the kernels; a helper's fuzzing). Within the ranges
    dt >= 1e-9 and target_interval <= 1e9 there are at most 1e18 steps."""
    with pytest.raises(ValueError, match=r"(dt|target_interval)=.* is outside the allowed range \[1e-09, 1(e\+09)?\]"):
        gym.make(ENV_ID, **kwargs)
