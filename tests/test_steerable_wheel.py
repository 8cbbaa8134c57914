"""SteerableWheel-v0: pure pursuit completes, info is the wheel physics, waypoints and endings follow the docs."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vegym  # noqa: F401
from agents.analytic import SteerableWheelPurePursuit, controller_for
from vegym.envs.steerable_wheel import SteerableWheelParams, SteerableWheelTask, segment_distance
from vegym.physics import wheel
from vegym.physics.wheel import Pose

ENV_ID = "vegym/SteerableWheel-v0"
INFO_KEYS = {
    "position",
    "heading",
    "roll_angle",
    "speed",
    "steer_increment",
    "radius",
    "dt",
    "waypoint_index",
    "reward_terms",
    "is_success",
}


def first_episodes(policy: str, n: int = 100, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Success and return of the first episode of each of n sub-envs (seeds seed .. seed + n - 1)."""
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    controller = controller_for(env)
    env.action_space.seed(seed)
    obs, _ = env.reset(seed=seed)
    done, success, returns = np.zeros(n, bool), np.zeros(n, bool), np.zeros(n)
    while not done.all():
        action = controller.predict(obs)[0] if policy == "pure_pursuit" else env.action_space.sample()
        obs, reward, terminated, truncated, info = env.step(action)
        returns[~done] += reward[~done]
        ended = (terminated | truncated) & ~done
        success[ended] = info["is_success"][ended]
        done |= ended
    return success, returns


def test_pure_pursuit_completes_at_least_95_percent_and_beats_random_by_far() -> None:
    success, returns = first_episodes("pure_pursuit")
    random_success, random_returns = first_episodes("random")
    assert success.mean() >= 0.95
    assert random_success.mean() <= 0.05
    assert returns.mean() > random_returns.mean() + 40.0
    assert isinstance(controller_for(gym.make(ENV_ID)), SteerableWheelPurePursuit)


def test_info_keys_are_the_pinned_ones_and_describe_the_step_in_si_units() -> None:
    env = gym.make(ENV_ID)
    env.reset(seed=4)
    p: SteerableWheelParams = env.unwrapped.params
    state = {k: v.copy() for k, v in env.unwrapped.state.items()}  # the env updates its own arrays in place
    pose = Pose(state["position"][:, 0], state["position"][:, 1], state["heading"], state["roll"])
    path = 0.0
    speed = 0.0
    for action in np.array([[1.0, 0.5], [1.0, -0.25], [0.2, 1.0], [-1.0, 0.0]] * 5, np.float32):
        _, reward, terminated, truncated, info = env.step(action)
        assert set(info) == INFO_KEYS
        action = action.astype(np.float64)
        command = 0.5 * p.max_speed * (action[0] + 1.0)
        speed = float(np.clip(command, speed - p.max_acceleration * p.dt, speed + p.max_acceleration * p.dt))
        yaw_rate = p.max_yaw_rate * float(action[1])
        pose = wheel.steer_step(pose, np.array([speed]), np.array([yaw_rate]), p.dt, p.wheel)
        path += speed * p.dt
        assert info["speed"] == speed and 0.0 <= speed <= p.max_speed
        assert info["steer_increment"] == pytest.approx(yaw_rate * p.dt, rel=1e-15)
        np.testing.assert_array_equal(info["position"], [pose.x[0], pose.z[0]])
        assert info["heading"] == pose.heading[0] and -np.pi <= info["heading"] <= np.pi
        assert info["roll_angle"] * p.radius == pytest.approx(path, rel=1e-12)
        assert (info["radius"], info["dt"]) == (p.radius, p.dt)
        assert info["waypoint_index"] == 0 and info["is_success"] is False and not terminated and not truncated
        assert set(info["reward_terms"]) == {"progress", "waypoint", "time", "effort", "exit"}
        assert reward == pytest.approx(sum(info["reward_terms"].values()), rel=1e-12)
        assert info["reward_terms"]["time"] == -p.time_penalty * p.dt


def single_state(task: SteerableWheelTask, position, heading, waypoints, speed=0.0) -> dict[str, np.ndarray]:
    return {
        "position": np.array([position], float),
        "heading": np.array([heading], float),
        "roll": np.zeros(1),
        "speed": np.array([speed], float),
        "waypoints": np.array([waypoints], float),
        "index": np.zeros(1, np.int64),
        "key": np.zeros(1, np.uint64),
        "step": np.zeros(1, np.int64),
    }


def test_a_waypoint_passed_between_samples_counts_and_several_may_count_in_one_step() -> None:
    p = SteerableWheelParams(n_waypoints=3, dt=0.5, max_acceleration=100.0, capture_radius=0.2)
    task = SteerableWheelTask(p)
    # heading +x at 2 m/s for 0.5 s: the chord runs from x = 0 to x = 1; samples at both ends miss (0.5, 0.1)
    state = single_state(task, (0.0, 0.0), np.pi / 2, [(0.5, 0.1), (0.9, -0.15), (5.0, 5.0)], speed=2.0)
    after, out, info = task.transition(state, np.array([[1.0, 0.0]]))
    np.testing.assert_allclose(after["position"], [[1.0, 0.0]], atol=1e-15)
    assert info["waypoint_index"][0] == 2 and not out["terminated"][0]
    assert info["reward_terms"]["waypoint"][0] == 2 * p.waypoint_bonus
    assert info["reward_terms"]["progress"][0] == pytest.approx(np.hypot(0.5, 0.1) - np.hypot(0.5, 0.1))
    miss = single_state(task, (0.0, 0.0), np.pi / 2, [(0.5, 0.25), (0.9, -0.15), (5.0, 5.0)], speed=2.0)
    assert task.transition(miss, np.array([[1.0, 0.0]]))[2]["waypoint_index"][0] == 0
    np.testing.assert_allclose(segment_distance(np.array([[3.0, 4.0]]), np.zeros((1, 2)), np.zeros((1, 2))), [5.0])


def test_the_last_waypoint_ends_the_episode_with_success_and_leaving_the_arena_ends_it_with_the_exit_cost() -> None:
    p = SteerableWheelParams(n_waypoints=1)
    task = SteerableWheelTask(p)
    done, out, info = task.transition(single_state(task, (0, 0), 0.0, [(0.0, 0.3)], speed=1.0), np.zeros((1, 2)))
    assert out["terminated"][0] and info["is_success"][0] and info["reward_terms"]["exit"][0] == 0.0
    np.testing.assert_allclose(out["obs"][0, [0, 3, 7]], [0.2 / p.diagonal, 0.2 / p.diagonal, 1.0])
    np.testing.assert_array_equal(task.observation(done), out["obs"])
    edge = (p.half_size - 0.05, 0.0)
    _, out, info = task.transition(single_state(task, edge, np.pi / 2, [(0.0, 5.0)], speed=1.0), np.zeros((1, 2)))
    assert out["terminated"][0] and not info["is_success"][0]
    assert info["reward_terms"]["exit"][0] == -p.exit_penalty
    assert info["reward_terms"]["progress"][0] < 0
    assert task.observation_space.contains(out["obs"][0])


def test_observation_is_in_the_wheel_frame_and_a_positive_yaw_action_turns_toward_a_waypoint_on_the_left() -> None:
    task = SteerableWheelTask(SteerableWheelParams())
    # heading +z; left is +x (PHYSICS.md section 0), so a waypoint at +x is 90 degrees to the left
    state = single_state(task, (1.0, 2.0), 0.0, [(4.0, 2.0), (1.0, -2.0), (0, 0), (0, 0), (0, 0)])
    obs = task.observation(state)[0]
    diagonal = task.params.diagonal
    np.testing.assert_allclose(obs[:3], [3.0 / diagonal, 1.0, 0.0], atol=1e-7)
    np.testing.assert_allclose(obs[3:6], [4.0 / diagonal, 0.0, -1.0], atol=1e-7)
    turned, out, _ = task.transition(state, np.array([[0.0, 1.0]]))
    assert turned["heading"][0] > 0 and out["obs"][0, 2] > 0  # the bearing's cosine grows


def test_observations_reach_their_bounds_only_where_documented() -> None:
    env = gym.make_vec(ENV_ID, num_envs=64, vectorization_mode="vector_entry_point")
    controller = controller_for(env)
    obs, _ = env.reset(seed=3)
    seen = [obs]
    for _ in range(200):
        obs, *_ = env.step(controller.predict(obs)[0])
        seen.append(obs)
    seen = np.concatenate(seen)
    space = env.single_observation_space
    assert np.all(seen >= space.low) and np.all(seen <= space.high)
    assert seen[:, 6].max() == 1.0 and seen[:, [0, 3]].max() < 1.0  # top speed is reached, distances stay inside


def test_episodes_draw_waypoints_and_start_poses_from_the_seed_inside_the_margin() -> None:
    p = SteerableWheelParams()
    task = SteerableWheelTask(p)
    keys = vegym.rng.seed_keys(np.arange(500))
    state = task.initial_state(keys)
    extent = p.half_size - p.waypoint_margin
    assert np.abs(state["waypoints"]).max() <= extent and np.abs(state["position"]).max() <= extent
    assert np.abs(state["waypoints"]).max() > 0.95 * extent
    np.testing.assert_array_equal(task.initial_state(keys[7:9])["waypoints"], state["waypoints"][7:9])
    assert np.all(state["speed"] == 0) and np.all(np.abs(state["heading"]) <= np.pi)


def test_task_step_batched_equals_looped_bit_for_bit() -> None:
    task = SteerableWheelTask(SteerableWheelParams())
    keys = vegym.rng.seed_keys(np.arange(16))
    state = {**task.initial_state(keys), "key": keys, "step": np.zeros(16, np.int64)}
    actions = np.random.default_rng(0).uniform(-1, 1, (30, 16, 2))
    for action in actions:
        batched, batched_out, _ = task.transition(state, action)
        for i in range(16):
            one, one_out, _ = task.transition({k: v[i : i + 1] for k, v in state.items()}, action[i : i + 1])
            for k, v in one_out.items():
                np.testing.assert_array_equal(v[0], batched_out[k][i])
            for k, v in one.items():
                np.testing.assert_array_equal(v[0], batched[k][i])
        state = batched


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        ("waypoint_margin", 10.0, r"waypoint_margin=10.0 is outside the allowed range \[0, arena_size / 2 = 10\)"),
        ("capture_radius", 12.0, r"capture_radius=12.0 is outside the allowed range \[0, arena_size / 2 = 10\)"),
        ("dt", 2.0, r"dt=2.0 is outside the allowed range \[1e-09, 1\]"),
        ("n_waypoints", 0, r"n_waypoints=0 is outside the allowed range \[1, 64\]"),
        ("max_yaw_rate", 0.0, r"max_yaw_rate=0.0 is outside the allowed range \[1e-09, 1e\+09\]"),
        ("n_waypoints", 2.5, r"n_waypoints=2.5 must be an integer"),
    ],
)
def test_bad_parameters_raise_value_error_naming_them(name: str, value: float, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        gym.make(ENV_ID, **{name: value})


def test_rendered_frame_shows_the_arena_and_changes_as_the_wheel_rolls() -> None:
    """The top view (seen from above: x right, z down) draws the arena's edge, the next waypoint (red dot) and the
    wheel (black footprint, green heading arrow) where the state has them; the side view's spokes turn."""
    from vegym.render import canvas

    env = gym.make(ENV_ID, render_mode="rgb_array")
    env.reset(seed=1)
    first = env.render()
    for _ in range(5):
        env.step(np.array([1.0, 0.3], np.float32))
    later = env.render()
    assert first.shape == later.shape == (640, 880, 3)
    assert np.any(first[70:270, 600:860] != later[70:270, 600:860])  # the side view's spokes have turned
    p, state = env.unwrapped.params, env.unwrapped.state
    h, pad = p.half_size, 0.04 * p.arena_size
    world = (-h - pad, h + pad, -h - pad, h + pad)
    top = canvas.Panel(canvas.new_surface(880, 640), (20, 70, 560, 560), world, equal_aspect=True)

    def colours_near(x: float, z: float) -> set[tuple[int, ...]]:
        column, row = top.to_px(x, -z)
        return {tuple(c) for c in later[row - 2 : row + 3, column - 2 : column + 3].reshape(-1, 3)}

    assert canvas.BLACK in colours_near(-h, 0.0) and canvas.BLACK in colours_near(0.0, h)
    waypoint = state["waypoints"][0, int(state["index"][0])]
    assert colours_near(*waypoint) == {canvas.RED}
    assert {canvas.BLACK, canvas.GREEN} <= colours_near(*state["position"][0])


@pytest.mark.parametrize(
    ("heading", "axis", "side"),
    [(np.pi / 2, 0, 1.0), (-np.pi / 2, 0, -1.0), (0.0, 1, 1.0), (np.pi, 1, -1.0)],
    ids=["plus_x", "minus_x", "plus_z", "minus_z"],
)
def test_leaving_the_arena_across_any_side_ends_the_episode_with_the_exit_cost(
    heading: float, axis: int, side: float
) -> None:
    """Episode End: the wheel leaves when ``max(|x|, |z|) > arena_size / 2``, across each of the four sides."""
    p = SteerableWheelParams(n_waypoints=1)
    task = SteerableWheelTask(p)
    start = np.zeros(2)
    start[axis] = side * (p.half_size - 0.05)  # forward is (sin psi, 0, cos psi)
    state = single_state(task, tuple(start), heading, [(0.0, 0.0) if axis else (0.0, 5.0)], speed=1.0)
    after, out, info = task.transition(state, np.zeros((1, 2)))
    assert abs(after["position"][0, 1 - axis]) < 1e-12 and side * after["position"][0, axis] > p.half_size
    assert out["terminated"][0] and not info["is_success"][0]
    assert info["reward_terms"]["exit"][0] == -p.exit_penalty
    assert out["reward"][0] == pytest.approx(sum(t[0] for t in info["reward_terms"].values()), rel=1e-12)


def test_passing_the_last_waypoint_on_the_step_that_leaves_the_arena_is_a_success_without_the_exit_cost() -> None:
    p = SteerableWheelParams(n_waypoints=1)
    task = SteerableWheelTask(p)
    state = single_state(task, (p.half_size - 0.05, 0.0), np.pi / 2, [(p.half_size - 0.02, 0.0)], speed=1.0)
    after, out, info = task.transition(state, np.zeros((1, 2)))
    assert after["position"][0, 0] > p.half_size
    assert out["terminated"][0] and info["is_success"][0] and info["reward_terms"]["exit"][0] == 0.0


def test_a_waypoint_is_passed_only_within_capture_radius_of_the_step_s_own_path() -> None:
    """The step's path is the segment from its start to its end: a waypoint 5 m ahead of a 0.2 m step is not
    passed, and with capture_radius = 0 waypoints exactly on the path are passed, several in one step, up to the
    last (index past the end: success)."""
    p = SteerableWheelParams(n_waypoints=3, dt=0.5, max_acceleration=100.0, capture_radius=0.0)
    task = SteerableWheelTask(p)  # heading +z at 2 m/s for 0.5 s: from z = 0 to z = 1 exactly
    ahead = single_state(task, (0.0, 0.0), 0.0, [(0.0, 5.0), (0.0, 6.0), (0.0, 7.0)], speed=2.0)
    assert task.transition(ahead, np.array([[1.0, 0.0]]))[2]["waypoint_index"][0] == 0
    on_path = single_state(task, (0.0, 0.0), 0.0, [(0.0, 0.5), (0.0, 0.9), (0.0, 7.0)], speed=2.0)
    after, out, info = task.transition(on_path, np.array([[1.0, 0.0]]))
    np.testing.assert_array_equal(after["position"], [[0.0, 1.0]])
    assert info["waypoint_index"][0] == 2 and not out["terminated"][0]
    last_two = single_state(task, (0.0, 0.0), 0.0, [(9.0, 9.0), (0.0, 0.5), (0.0, 0.9)], speed=2.0)
    last_two["index"][0] = 1
    _, out, info = task.transition(last_two, np.array([[1.0, 0.0]]))
    assert info["waypoint_index"][0] == 3 and out["terminated"][0] and info["is_success"][0]
    assert info["reward_terms"]["waypoint"][0] == 2 * p.waypoint_bonus


def test_a_waypoint_beyond_the_arena_diagonal_is_observed_at_distance_one_and_one_underfoot_straight_ahead() -> None:
    """The terminal observation after an exit can lie farther than the diagonal from a waypoint: its distance
    stays 1; a waypoint at the wheel's centre has bearing sine 0 and cosine 1."""
    p = SteerableWheelParams(n_waypoints=2, waypoint_margin=0.0)
    task = SteerableWheelTask(p)
    assert p.diagonal == pytest.approx(np.sqrt(2.0) * 20.0, rel=1e-15)
    outside = single_state(task, (-p.half_size - 0.5, -p.half_size - 0.5), 0.3, [(p.half_size, p.half_size)] * 2)
    obs = task.observation(outside)[0]
    assert obs[0] == 1.0 and task.observation_space.contains(obs)
    underfoot = task.observation(single_state(task, (1.0, 2.0), 0.3, [(1.0, 2.0), (4.0, 6.0)]))[0]
    np.testing.assert_array_equal(underfoot[:3], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(underfoot[3], 5.0 / p.diagonal, rtol=1e-6)


def test_progress_and_effort_terms_follow_the_documented_formulas() -> None:
    """Rewards: progress is ``progress_weight`` times the metres gained toward the current waypoint over the step
    (from the positions before and after), effort is ``-effort_penalty * dt * a1^2``."""
    p = SteerableWheelParams(progress_weight=1.5, effort_penalty=0.3, dt=0.2)
    task = SteerableWheelTask(p)
    target = np.array([5.0, 3.0])
    start = np.array([-1.0, 0.5])
    waypoints = [tuple(target), (0, 0), (0, 0), (0, 0), (0, 0)]
    state = single_state(task, tuple(start), np.pi / 2, waypoints, speed=2.0)
    a1 = 0.6
    after, _, info = task.transition(state, np.array([[1.0, a1]]))
    end = after["position"][0]
    gained = np.linalg.norm(target - start) - np.linalg.norm(target - end)
    assert gained > 0.1 and info["steer_increment"][0] != 0.0
    assert info["reward_terms"]["progress"][0] == pytest.approx(p.progress_weight * gained, rel=1e-12)
    assert info["reward_terms"]["effort"][0] == pytest.approx(-p.effort_penalty * p.dt * a1**2, rel=1e-12)
    assert info["waypoint_index"][0] == 0 and info["reward_terms"]["exit"][0] == 0.0


@pytest.mark.parametrize(
    ("distance", "bearing_deg", "speed"),
    [
        (1.5, 60.0, 1.8),  # the yaw-rate limit binds: command max_yaw_rate / kappa below max_speed
        (10.0, 10.0, 1.8),  # a gentle arc: full speed
        (0.5, 150.0, 1.0),  # a waypoint behind, to the left: kappa = 2 / min_lookahead
        (0.5, -150.0, 1.0),  # behind, to the right
        (1.5, 60.0, 0.0),  # from rest: the step's speed is max_acceleration * dt, whatever the command
    ],
)
def test_pure_pursuit_commands_the_fastest_speed_its_curvature_allows_and_the_yaw_rate_of_the_applied_speed(
    distance: float, bearing_deg: float, speed: float
) -> None:
    params = SteerableWheelParams()
    bearing = np.radians(bearing_deg)
    obs = np.zeros((1, 8), np.float32)
    obs[0, :3] = distance / params.diagonal, np.sin(bearing), np.cos(bearing)
    obs[0, 6] = speed / params.max_speed
    action = SteerableWheelPurePursuit(params).predict(obs)[0][0]

    lookahead = min(max(distance, 1.0), 2.0)
    curvature = 2.0 * (np.sin(bearing) if np.cos(bearing) >= 0.0 else np.sign(bearing)) / lookahead
    command = min(params.max_speed, params.max_yaw_rate / abs(curvature))
    dv = params.max_acceleration * params.dt
    applied = min(max(command, obs[0, 6] * params.max_speed - dv), obs[0, 6] * params.max_speed + dv)
    yaw_rate = min(max(curvature * applied, -params.max_yaw_rate), params.max_yaw_rate)
    assert action[0] == pytest.approx(2.0 * command / params.max_speed - 1.0, abs=1e-6)
    assert action[1] == pytest.approx(yaw_rate / params.max_yaw_rate, abs=1e-6)


def test_pure_pursuit_turns_left_toward_a_waypoint_dead_behind() -> None:
    """A waypoint straight behind (sin eta = 0, cos eta = -1) gets the full left turn of one just left of it."""
    params = SteerableWheelParams()
    obs = np.zeros((2, 8), np.float32)
    obs[:, 0], obs[:, 2], obs[:, 6] = 0.3, -1.0, 0.5
    obs[1, 1] = 1e-6  # just left of behind
    action = SteerableWheelPurePursuit(params).predict(obs)[0]
    assert action[0, 1] > 0.0
    np.testing.assert_array_equal(action[0], action[1])
