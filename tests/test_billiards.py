"""Billiards-v0: the ghost-ball strike rests B on the target, info is the impact physics, the envelope is reachable."""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest

import vegym  # noqa: F401
from agents.analytic import BilliardsGhostBall, controller_for
from vegym.envs.billiards import BilliardsParams, BilliardsTask, ghost_ball_shot
from vegym.physics import collision

ENV_ID = "vegym/Billiards-v0"


def strike(policy: str, n: int = 300, seed: int = 0, **params: float) -> tuple[np.ndarray, np.ndarray, dict]:
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **params)
    controller = controller_for(env)
    env.action_space.seed(seed)
    obs, _ = env.reset(seed=seed)
    action = controller.predict(obs)[0] if policy == "ghost_ball" else env.action_space.sample()
    _, reward, terminated, _, info = env.step(action)
    assert terminated.all()
    return reward, info["is_success"], info


@pytest.mark.parametrize(
    "params", [{}, {"mass_a": 0.25, "mass_b": 0.12, "restitution": 0.6}, {"restitution": 0.0, "speed_max": 5.0}]
)
def test_the_ghost_ball_strike_always_hits_and_beats_random_by_far(params: dict) -> None:
    reward, hit, info = strike("ghost_ball", **params)
    random_reward, random_hit, _ = strike("random", **params)
    assert hit.all() and info["miss_distance"].max() < 1e-5
    assert random_hit.mean() < 0.05
    assert reward.mean() > random_reward.mean() + 2.0


def test_info_is_the_impact_and_the_slide_in_si_units() -> None:
    _, _, info = strike("random", n=500, seed=3)
    p = BilliardsParams()
    hit_b = info["contact"]
    assert 0.5 < hit_b.mean() < 1.0  # random strikes both reach B and stop short of it
    incoming = info["strike_velocity"] / np.linalg.norm(info["strike_velocity"], axis=-1, keepdims=True)
    normal = (info["ball_b"] - info["contact_point"]) / p.contact_distance
    with np.errstate(divide="ignore", invalid="ignore"):
        impact_speed = np.where(hit_b, info["closing_speed"] / np.sum(incoming * normal, axis=-1), 0.0)
    impact = incoming * impact_speed[:, None]
    momentum = p.mass_a * info["velocity_a"] + p.mass_b * info["velocity_b"]
    np.testing.assert_allclose(momentum[hit_b], p.mass_a * impact[hit_b], atol=1e-12)
    gap = np.linalg.norm(info["ball_b"] - info["contact_point"], axis=-1)
    np.testing.assert_allclose(gap[hit_b], p.contact_distance, rtol=1e-9)
    kinetic = 0.5 * p.mass_a * np.sum(impact**2, -1) - 0.5 * (
        p.mass_a * np.sum(info["velocity_a"] ** 2, -1) + p.mass_b * np.sum(info["velocity_b"] ** 2, -1)
    )
    np.testing.assert_allclose(kinetic, info["energy_lost"], atol=1e-12)
    speed_b = np.linalg.norm(info["velocity_b"], axis=-1)
    np.testing.assert_allclose(
        info["rest_b"], info["ball_b"] + info["velocity_b"] * (speed_b / (2 * p.deceleration))[:, None], atol=1e-12
    )
    missed = ~hit_b
    np.testing.assert_array_equal(info["rest_b"][missed], info["ball_b"][missed])
    np.testing.assert_array_equal(info["closing_speed"][missed], 0.0)
    strike_speed = np.linalg.norm(info["strike_velocity"], axis=-1)
    np.testing.assert_allclose(info["duration"][missed], strike_speed[missed] / p.deceleration)
    travelled = strike_speed**2 / (2 * p.deceleration)
    stopped = info["ball_a"] + incoming * travelled[:, None]
    np.testing.assert_allclose(info["rest_a"][missed], stopped[missed], atol=1e-12)


def test_the_cut_action_sets_the_angle_at_which_b_departs_from_a_s_path() -> None:
    task = BilliardsTask(BilliardsParams())
    state = {"ball_a": np.zeros((5, 2)), "ball_b": np.tile([[0.8, 0.0]], (5, 1)), "target": np.ones((5, 2))}
    cut = np.array([-0.9, -0.5, 0.0, 0.5, 0.9])
    _, _, info = task.transition(state, np.stack([cut, np.ones(5)], axis=-1))
    aim, leave = info["strike_velocity"], info["velocity_b"]
    sine = (aim[:, 0] * leave[:, 1] - aim[:, 1] * leave[:, 0]) / np.linalg.norm(aim, axis=-1)
    np.testing.assert_allclose(sine / np.linalg.norm(leave, axis=-1), cut, atol=1e-12)
    assert leave[4, 1] > 0  # positive cut: toward increasing bearing (+z here)
    _, _, slow = task.transition(state, np.array([[0.0, -1.0]] * 5))
    assert not slow["contact"].any()
    np.testing.assert_allclose(slow["miss_distance"], np.hypot(0.2, 1.0))


def test_every_episode_is_reachable_and_the_speed_envelope_is_enforced() -> None:
    p = BilliardsParams()
    task = BilliardsTask(p)
    keys = vegym.rng.seed_keys(np.arange(5000))
    obs = task.observation(task.initial_state(keys)).astype(np.float64)
    _, speed = ghost_ball_shot(
        obs[:, 0] * p.ball_distance_max, obs[:, 1] * p.target_distance_max, np.arctan2(obs[:, 2], obs[:, 3]), p
    )
    assert speed.max() <= p.required_speed <= p.speed_max
    grid = np.meshgrid(
        np.linspace(p.ball_distance_min, p.ball_distance_max, 40),
        np.linspace(p.target_distance_min, p.target_distance_max, 5),
        np.linspace(-p.bearing_max, p.bearing_max, 41),
    )
    _, grid_speed = ghost_ball_shot(*(g.ravel() for g in grid), p)
    assert grid_speed.max() == pytest.approx(p.required_speed, rel=1e-12)  # the worst case is at a corner
    assert obs[:, 3].min() >= np.cos(p.bearing_max) - 1e-6
    with pytest.raises(ValueError, match="speed_max"):
        BilliardsParams(speed_max=2.0)
    with pytest.raises(ValueError, match=r"speed_max=3.0 is outside .*restitution=0.3"):  # the parameter passed
        BilliardsParams(restitution=0.3)
    with pytest.raises(ValueError, match=r"speed_max=3.0 is outside .*ball_distance_max=20,"):
        BilliardsParams(ball_distance_max=20.0)
    with pytest.raises(ValueError, match="ball_distance_min"):
        BilliardsParams(ball_distance_min=0.05)
    limit = float(np.arccos(p.contact_distance / p.ball_distance_min))  # 1.379: B nearest, cut at 90 degrees
    assert p.largest_bearing == pytest.approx(limit, abs=1e-15)
    _, at_limit = ghost_ball_shot(np.array([p.ball_distance_min]), np.array([0.5]), np.array([limit]), p)
    _, below = ghost_ball_shot(np.array([p.ball_distance_min]), np.array([0.5]), np.array([limit - 1e-3]), p)
    assert at_limit[0] >= 1e15 and below[0] < 1e3  # the cut sine reaches 1 (rounding: inf or ~1e16; not NaN)
    for bearing_max in (limit, 1.5):  # no speed_max reaches a 90-degree cut: the bearing is to blame
        with pytest.raises(ValueError, match=rf"bearing_max={bearing_max!r} is outside .* = 1\.37"):
            BilliardsParams(bearing_max=bearing_max, speed_max=1e9)
    assert np.isfinite(BilliardsParams(bearing_max=1.37, speed_max=100.0).required_speed)
    assert isinstance(controller_for(gym.make(ENV_ID)), BilliardsGhostBall)


def test_the_ghost_ball_strike_needs_the_8_60_impact_speed() -> None:
    p = BilliardsParams(restitution=0.5, mass_a=0.2, mass_b=0.1)
    sine, speed = ghost_ball_shot(np.array([1.0]), np.array([0.6]), np.array([0.0]), p)
    impact = collision.speed_after(speed, 1.0 - p.contact_distance, p.deceleration)
    departure = collision.direct_impact(impact, 0.0, p.mass_a, p.mass_b, p.restitution)[1]
    assert sine[0] == 0.0 and departure[0] == pytest.approx(np.sqrt(2 * p.deceleration * 0.6), rel=1e-12)


def test_the_step_is_the_collision_module_s_array_functions_on_a_s_aim() -> None:
    p = BilliardsParams(mass_a=0.2, restitution=0.8)
    task = BilliardsTask(p)
    state = task.initial_state(vegym.rng.seed_keys(np.arange(2000)))
    action = np.random.default_rng(5).uniform(-1, 1, (2000, 2))
    action[:50, 0] = [-0.999, 0.999] * 25  # nearly grazing strikes
    _, _, info = task.transition(state, action)
    speed = 0.5 * (action[:, 1] + 1.0) * p.speed_max
    aim = info["strike_velocity"] / speed[:, None]
    travel = collision.first_contact(state["ball_a"], aim, state["ball_b"], p.contact_distance)
    hit = info["contact"]
    np.testing.assert_array_equal(hit, travel <= speed**2 / (2 * p.deceleration))
    assert 0.5 < hit.mean() < 1.0
    point = state["ball_a"][hit] + travel[hit, None] * aim[hit]
    np.testing.assert_allclose(info["contact_point"][hit], point, atol=1e-9)
    impact_speed = np.where(hit, collision.speed_after(speed, np.where(hit, travel, 0.0), p.deceleration), 0.0)
    impact = impact_speed[hit, None] * aim[hit]
    after_a, after_b = collision.oblique_impact(
        info["contact_point"][hit], state["ball_b"][hit], impact, np.zeros_like(impact), p.mass_a, p.mass_b, 0.8
    )
    np.testing.assert_allclose(info["velocity_a"][hit], after_a, atol=1e-9)
    np.testing.assert_allclose(info["velocity_b"][hit], after_b, atol=1e-9)
    rest_a, _, time_a = collision.slide(info["contact_point"], info["velocity_a"], p.deceleration)
    rest_b, _, time_b = collision.slide(state["ball_b"], info["velocity_b"], p.deceleration)
    np.testing.assert_allclose(info["rest_a"], rest_a, atol=1e-12)
    np.testing.assert_allclose(info["rest_b"], rest_b, atol=1e-12)
    energy = collision.energy_loss(info["closing_speed"], p.mass_a, p.mass_b, 0.8)
    np.testing.assert_allclose(info["energy_lost"], energy, rtol=1e-12)
    duration = (speed - impact_speed) / p.deceleration + np.maximum(time_a, time_b)
    np.testing.assert_allclose(info["duration"], duration, rtol=1e-9)


def test_is_success_is_b_resting_within_the_target_radius_of_the_target() -> None:
    """``is_success == (|rest_b - target| <= target_radius)``, on ghost-ball strikes perturbed to miss by about
    the target radius."""
    n = 400
    for seed, noise in enumerate((0.02, 0.05, 0.1)):
        env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
        p, rng = env.unwrapped.params, np.random.default_rng(seed)
        obs, _ = env.reset(seed=seed)
        action = BilliardsGhostBall(p).predict(obs)[0] + rng.normal(0.0, noise, (n, 2))
        _, reward, _, _, info = env.step(np.clip(action, -1.0, 1.0).astype(np.float32))
        miss = np.linalg.norm(info["rest_b"] - info["target"], axis=-1)
        np.testing.assert_allclose(info["miss_distance"], miss, rtol=1e-12, atol=1e-15)
        hit = miss <= p.target_radius
        np.testing.assert_array_equal(info["is_success"], hit)
        np.testing.assert_allclose(reward, -miss / p.target_distance_max + np.where(hit, p.hit_bonus, 0.0))
        assert 0.05 < hit.mean() < 0.95
        assert np.count_nonzero((miss > p.target_radius) & (miss <= 2.0 * p.target_radius)) > 10


def test_setups_fill_their_documented_ranges_with_independent_draws(assert_independent_draws_fill: Callable) -> None:
    """Starting State: A at the origin, B at a uniform distance and bearing from it, the target at a uniform
    distance from B and a uniform bearing within bearing_max off the line A-B."""
    p = BilliardsParams()
    state = BilliardsTask(p).initial_state(vegym.rng.seed_keys(np.arange(4000)))
    b, leave = state["ball_b"], state["target"] - state["ball_b"]
    assert (state["ball_a"] == 0.0).all()
    line = np.arctan2(b[:, 1], b[:, 0])
    assert_independent_draws_fill(
        {
            "ball distance": (np.hypot(b[:, 0], b[:, 1]), p.ball_distance_min, p.ball_distance_max),
            "line": (line, -np.pi, np.pi),
            "target distance": (np.hypot(leave[:, 0], leave[:, 1]), p.target_distance_min, p.target_distance_max),
            "off the line": (np.angle(np.exp(1j * (np.arctan2(leave[:, 1], leave[:, 0]) - line))), -1.0, 1.0),
        }
    )
    assert p.bearing_max == 1.0  # "off the line"'s range above


def test_the_observation_space_is_the_documented_box_and_equal_range_ends_are_valid() -> None:
    space = gym.make(ENV_ID).observation_space
    np.testing.assert_array_equal(space.low, [0, 0, -1, 0])
    np.testing.assert_array_equal(space.high, [1, 1, 1, 1])
    BilliardsParams(ball_distance_min=0.8, ball_distance_max=0.8)
    BilliardsParams(target_distance_min=0.6, target_distance_max=0.6)


def test_observations_stay_in_the_box_when_the_target_is_nanometres_from_b() -> None:
    """The target's distance is found from coordinates of metres: 67 of 3,000 episodes at 1 nm observed 1.0000001."""
    env = gym.make(ENV_ID, target_distance_min=1e-9, target_distance_max=1e-9)
    for seed in range(150, 450):
        obs, _ = env.reset(seed=seed)
        assert env.observation_space.contains(obs), (seed, obs)


def test_balls_a_million_kilometres_apart_still_collide_with_finite_results() -> None:
    """The contact's root cancelled at large distances: balls up to 1e9 m apart (slowed by 1e-9 m/s^2, so that A
    reaches B) found contacts at B's centre, and 7 of these 20 strikes gave NaN velocities and rewards."""
    env = gym.make(ENV_ID, ball_distance_max=1e9, deceleration=1e-9)
    for seed in range(20):
        env.reset(seed=seed)
        _, reward, _, _, info = env.step(np.zeros(2, np.float32))
        assert info["contact"] and np.isfinite(reward), seed
        assert np.all(np.isfinite(info["velocity_b"])) and np.isfinite(info["miss_distance"]), seed


def test_balls_and_targets_closer_than_their_coordinates_resolve_observe_and_reward_finite_numbers() -> None:
    """Balls of radius 1e-9 m up to a million km apart: A's centre landed on B's in floats, and the line of centres
    (0 / 0) gave NaN rewards on 128 of these 300 strikes; a target 1e-9 m from B there lies on B, and 28 of 30 resets
    observed NaN (a helper's review). The strike is head-on then, and the target straight ahead."""
    env = gym.make(ENV_ID, radius_a=1e-9, radius_b=1e-9, deceleration=1e-9, ball_distance_max=1e9)
    for seed in range(100):
        for cut in (-0.5, 0.0, 0.5):
            env.reset(seed=seed)
            obs, reward, _, _, info = env.step(np.array([cut, 0.0], np.float32))
            assert np.isfinite(reward) and np.all(np.isfinite(info["velocity_b"])), (seed, cut)
            assert env.observation_space.contains(obs)
    on_b = gym.make(ENV_ID, ball_distance_max=1e9, target_distance_min=1e-9, target_distance_max=1e-9, speed_max=1e9)
    for seed in range(30):
        obs, _ = on_b.reset(seed=seed)
        assert env.observation_space.contains(obs), (seed, obs)
