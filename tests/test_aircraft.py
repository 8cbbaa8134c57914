"""Aircraft-v0 and AircraftGusty-v0: the autopilot's scores, the gusty steady error, the demand schedule, info."""

from __future__ import annotations

import math
from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest

import vegym  # noqa: F401
from agents.analytic import AircraftDraftCompensatingAutopilot, controller_for
from vegym import rng
from vegym.envs.aircraft import AircraftEnvParams, AircraftTask
from vegym.envs.base import owned
from vegym.physics import aircraft

ENV_ID, GUSTY_ID = "vegym/Aircraft-v0", "vegym/AircraftGusty-v0"
EPISODES = 500


def fly(env_id: str, policy, episodes: int = EPISODES, seed: int = 0) -> dict[str, np.ndarray]:
    """One full episode of every sub-env of a vector env: returns, final success, altitude errors per step."""
    env = gym.make_vec(env_id, num_envs=episodes, vectorization_mode="vector_entry_point")
    obs, _ = env.reset(seed=seed)
    total, altitude_errors = np.zeros(episodes), []
    truncated = np.zeros(episodes, dtype=bool)
    while not truncated.any():
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        assert not terminated.any()
        total += reward
        altitude_errors.append(info["errors"][:, 0])
    assert truncated.all() and len(altitude_errors) == env.unwrapped.params.episode_steps
    return {
        "return": total,
        "success": info["is_success"],
        "altitude_error": np.array(altitude_errors),
        "draft": env.unwrapped.state["draft"],
        "env": env,
    }


def autopilot(env_id: str):
    controller = controller_for(gym.make(env_id))
    return lambda obs: controller.predict(obs)[0]


def random_policy(seed: int = 0):
    rng = np.random.default_rng(seed)
    return lambda obs: rng.uniform(-1.0, 1.0, (len(obs), 3)).astype(np.float32)


def test_autopilot_succeeds_on_at_least_90_percent_and_beats_random_by_far() -> None:
    pilot, chance = fly(ENV_ID, autopilot(ENV_ID)), fly(ENV_ID, random_policy())
    print(
        f"\nAircraft-v0 over {EPISODES} episodes: autopilot success {pilot['success'].mean():.1%}, "
        f"return {pilot['return'].mean():.1f}; random success {chance['success'].mean():.1%}, "
        f"return {chance['return'].mean():.1f}"
    )
    assert pilot["success"].mean() >= 0.9
    assert chance["success"].mean() < 0.05
    assert pilot["return"].mean() > 3.0 * chance["return"].mean()  # returns are negative: 3x less error


def test_gusty_autopilot_keeps_a_steady_altitude_error_that_the_observation_lets_an_agent_remove() -> None:
    pilot = fly(GUSTY_ID, autopilot(GUSTY_ID))
    steady = np.abs(pilot["altitude_error"][-30:]).mean()
    expected = np.abs(pilot["draft"]).mean() / aircraft.AutopilotGains().climb_gain
    p: AircraftEnvParams = pilot["env"].unwrapped.params
    compensating = AircraftDraftCompensatingAutopilot(p)

    def compensated(obs: np.ndarray) -> np.ndarray:
        return compensating.predict(obs)[0]

    agent = fly(GUSTY_ID, compensated)
    agent_steady = np.abs(agent["altitude_error"][-30:]).mean()
    print(
        f"\nAircraftGusty-v0 over {EPISODES} episodes: autopilot steady altitude error (mean |y_d - y|, last 30 s) "
        f"{steady:.2f} m (|w| / k_v = {expected:.2f} m), success {pilot['success'].mean():.1%}; "
        f"draft-compensating policy {agent_steady:.2f} m, success {agent['success'].mean():.1%}"
    )
    assert steady == pytest.approx(expected, rel=0.05)
    assert 8.0 < steady < 12.0  # the documented 10.1 m (|w| / k_v averages 10.0 m over the drafts)
    assert agent_steady < steady / 3.0 and agent["success"].mean() > pilot["success"].mean() + 0.1


def test_controller_from_the_observation_is_the_physics_autopilot_on_the_true_state() -> None:
    env = gym.make_vec(ENV_ID, num_envs=64, vectorization_mode="vector_entry_point")
    controller = controller_for(env)
    task: AircraftTask = env.unwrapped.task
    obs, _ = env.reset(seed=4)
    for _ in range(120):
        state = env.unwrapped.state
        errors = aircraft.tracking_errors(task.aircraft_state(state), state["demand"])
        exact = aircraft.action_from_command(
            aircraft.autopilot(errors, task.physics, aircraft.AutopilotGains()), task.physics
        )
        action = controller.predict(obs)[0]
        np.testing.assert_allclose(action, exact, atol=1e-5)
        obs, *_ = env.step(action)


def test_step_flies_the_physics_step_bit_for_bit_envelope_cuts_included() -> None:
    """The step kernel's passes fly exactly :func:`aircraft.step` on the saturated commands with the draft as the
    vertical wind, where the speed limits, the floor and the ceiling cut and with a horizontal wind."""
    params = AircraftEnvParams(
        draft_max=20.0, wind_x=3.0, wind_z=-2.0, floor_altitude=900.0, altitude_min=950.0, ceiling_altitude=1700.0,
        dt=2.5,
    )  # fmt: skip
    task = AircraftTask(params)
    n, random = 256, np.random.default_rng(9)
    keys = rng.seed_keys(np.arange(n))
    state = owned({**task.initial_state(keys), "key": keys, "step": np.zeros(n, dtype=np.int64)})
    for _ in range(100):
        action = random.choice([-1.0, -0.3, 0.0, 0.5, 1.0], (n, 3))
        before = aircraft.AircraftState(*(np.copy(a) for a in task.aircraft_state(state)))
        command = aircraft.command_from_action(action, task.physics)
        expected, climb = aircraft.step(before, command, params.dt, task.physics, state["draft"])
        task.step(state, action, task.outputs(n))
        for field, value in zip(aircraft.AircraftState._fields, expected, strict=True):
            assert np.array_equal(getattr(task.aircraft_state(state), field), value), field
        assert np.array_equal(state["vertical_speed"], climb)
        state["step"] += 1
    altitude, speed = state["position"][:, 1], state["speed"]  # some aircraft end on each limit
    assert (altitude == 900.0).any() and (altitude == 1700.0).any() and (speed == 60.0).any() and (speed == 200.0).any()


def test_task_on_any_subset_of_a_batch_gives_exactly_those_rows() -> None:
    """What mixed resets rely on: a sub-batch (the sub-envs not resetting) steps exactly as in the full batch."""
    params = AircraftEnvParams(draft_max=4.0, gust_amplitude=2.0, change_interval_min=3.0, change_interval_max=6.0)
    task = AircraftTask(params)
    n, random = 64, np.random.default_rng(8)
    keys = rng.seed_keys(np.arange(n))
    state = owned({**task.initial_state(keys), "key": keys, "step": np.zeros(n, dtype=np.int64)})
    for _ in range(60):
        action = random.uniform(-1.0, 1.0, (n, 3))
        subset = random.random(n) < 0.5
        part_state = {k: v[subset] for k, v in state.items()}
        full, part = task.outputs(n), task.outputs(int(subset.sum()))
        task.step(state, action, full)
        task.step(part_state, action[subset], part)
        for k, v in part_state.items():
            assert np.array_equal(v, state[k][subset]), k
        for k, v in part.items():
            assert np.array_equal(v, full[k][subset]), k
        full_info, part_info = task.info(state, full), task.info(part_state, part)
        for k in ("position", "vertical_speed", "demand", "errors", "is_success"):
            assert np.array_equal(part_info[k], full_info[k][subset]), k
        state["step"] += 1
        obs = np.empty_like(full["obs"])
        task.observe(state, obs)
        assert np.array_equal(obs, full["obs"])
    assert np.all(state["changes"] >= 5)


def test_demands_change_at_random_times_from_the_seed_alone_and_never_near_the_end() -> None:
    p = AircraftEnvParams()
    schedules = []
    for policy in (random_policy(1), random_policy(2)):
        env = gym.make_vec(ENV_ID, num_envs=200, vectorization_mode="vector_entry_point")
        obs, _ = env.reset(seed=9)
        demands, since = [env.unwrapped.state["demand"].copy()], [obs[:, 7]]
        for _ in range(p.episode_steps):
            obs, *_ = env.step(policy(obs))
            demands.append(env.unwrapped.state["demand"].copy())
            since.append(obs[:, 7])
        schedules.append((np.array(demands), np.array(since)))
    (demands, since), (other, _) = schedules
    assert np.array_equal(demands, other)
    changed = np.any(demands[1:] != demands[:-1], axis=-1)
    steps, envs = np.nonzero(changed)
    steps = steps + 1
    assert steps.max() <= p.episode_steps - p.final_hold / p.dt
    assert np.all(since[steps, envs] == 0.0)
    for i in range(200):
        at = np.concatenate([[0], steps[envs == i]])
        assert (
            len(at) >= 2
            and np.all(np.diff(at) >= p.change_interval_min)
            and np.all(np.diff(at) <= p.change_interval_max)
        )
    low = np.array([p.altitude_min, p.speed_demand_min, -math.pi])
    high = np.array([p.altitude_max, p.speed_demand_max, math.pi])
    assert np.all((demands >= low) & (demands < high))


def test_info_is_the_step_just_taken_in_si_units() -> None:
    env = gym.make(GUSTY_ID)
    env.reset(seed=2)
    before = {k: v.copy() for k, v in env.unwrapped.state.items()}
    _, reward, _, _, info = env.step(np.array([0.5, -1.0, 1.0], dtype=np.float32))
    assert set(info) == {
        "position",
        "speed",
        "heading",
        "vertical_speed",
        "dt",
        "demand",
        "errors",
        "reward_terms",
        "is_success",
    }
    assert set(info["reward_terms"]) == {"altitude", "speed", "heading", "effort"}
    p = env.unwrapped.params
    assert info["dt"] == p.dt == 1.0
    assert info["speed"] == pytest.approx(before["speed"][0] + 0.5 * p.max_acceleration)
    assert info["heading"] == pytest.approx(aircraft.wrap(before["heading"][0] + p.max_turn_rate))
    gust = info["vertical_speed"] + p.max_descent_rate - before["draft"][0]
    assert abs(gust) <= p.gust_amplitude and gust != 0.0
    assert info["position"][1] == pytest.approx(before["position"][0, 1] + info["vertical_speed"] * p.dt)
    np.testing.assert_array_equal(info["demand"], before["demand"][0])
    np.testing.assert_allclose(
        info["errors"],
        [
            info["demand"][0] - info["position"][1],
            info["demand"][1] - info["speed"],
            aircraft.wrap(info["demand"][2] - info["heading"]),
        ],
    )
    assert info["is_success"] == bool(
        np.all(np.abs(info["errors"]) <= [p.altitude_tolerance, p.speed_tolerance, p.heading_tolerance])
    )
    assert info["reward_terms"]["effort"] == pytest.approx(-p.effort_weight * (0.25 + 1.0 + 1.0) / 3.0)
    assert reward == pytest.approx(sum(info["reward_terms"].values()))


def test_on_a_demand_change_step_the_info_shows_the_demand_its_errors_were_scored_against() -> None:
    """A change hands out its new demand at the end of the step (the next observation shows it); that step's
    info reports the demand in force during it, which its errors and rewards used."""
    env = gym.make(ENV_ID)
    env.reset(seed=4)
    changes = 0
    for _ in range(300):
        demand_before = env.unwrapped.state["demand"][0].copy()
        *_, truncated, info = env.step(env.action_space.sample())
        np.testing.assert_array_equal(info["demand"], demand_before)
        changes += not np.array_equal(env.unwrapped.state["demand"][0], demand_before)
        expected = [demand_before[0] - info["position"][1], demand_before[1] - info["speed"]]
        expected.append(aircraft.wrap(demand_before[2] - info["heading"]))
        np.testing.assert_allclose(info["errors"], expected, rtol=0, atol=1e-9)
        if truncated:
            break
    assert changes >= 2


@pytest.mark.parametrize(
    ("env_id", "kwargs", "climb_action"),
    [(GUSTY_ID, {}, 1.0), (GUSTY_ID, {}, -1.0), (ENV_ID, {"max_descent_rate": 30.0}, -1.0)],
)
def test_the_observed_climb_command_is_the_commanded_rate_over_the_vertical_speed_scale(
    env_id: str, kwargs: dict, climb_action: float
) -> None:
    env = gym.make(env_id, **kwargs)
    env.reset(seed=0)
    p = env.unwrapped.params
    obs = env.step(np.array([0.0, climb_action, 0.0], np.float32))[0]
    rate = p.max_climb_rate if climb_action > 0 else -p.max_descent_rate
    scale = max(p.max_climb_rate, p.max_descent_rate) + p.draft_max + p.gust_amplitude
    assert obs[6] == pytest.approx(rate / scale, rel=1e-6) and env.observation_space.contains(obs)


def test_the_observed_time_since_the_last_change_counts_seconds_over_change_interval_max() -> None:
    env = gym.make(ENV_ID, dt=2.0)  # the first change comes after change_interval_min = 45 s at the earliest
    env.reset(seed=0)
    for step in range(1, 21):
        obs = env.step(np.zeros(3, np.float32))[0]
        assert obs[7] == pytest.approx(2.0 * step / 120.0, rel=1e-6)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_each_action_axis_costs_its_share_of_the_effort(axis: int) -> None:
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    action = np.zeros(3, np.float32)
    action[axis] = -1.0
    info = env.step(action)[4]
    assert info["reward_terms"]["effort"] == pytest.approx(-env.unwrapped.params.effort_weight / 3.0, rel=1e-12)


def test_extreme_actions_keep_the_aircraft_in_its_envelope_and_observations_in_bounds() -> None:
    env = gym.make_vec(
        GUSTY_ID,
        num_envs=8,
        vectorization_mode="vector_entry_point",
        ceiling_altitude=2000.0,
        episode_steps=600,
        max_episode_steps=600,
    )
    p = env.unwrapped.params
    obs, _ = env.reset(seed=0)
    for sign, steps in ((1.0, 150), (-1.0, 450)):
        for _ in range(steps):
            obs, _, _, _, info = env.step(np.full((8, 3), sign, dtype=np.float32))
            assert env.observation_space.contains(obs)
        edge = p.ceiling_altitude if sign > 0 else p.floor_altitude
        np.testing.assert_allclose(info["position"][:, 1], edge)
        np.testing.assert_allclose(info["speed"], p.max_speed if sign > 0 else p.min_speed)
        assert np.all(np.abs(obs[:, 0]) == 1.0)


def test_gusty_is_aircraft_with_drafts_and_gusts_by_registration() -> None:
    assert gym.spec(GUSTY_ID).kwargs == {"draft_max": 4.0, "gust_amplitude": 2.0}
    assert gym.spec(ENV_ID).kwargs == {}
    assert gym.spec(ENV_ID).max_episode_steps == AircraftEnvParams().episode_steps
    calm = gym.make(GUSTY_ID, draft_max=0.0, gust_amplitude=0.0)
    plain = gym.make(ENV_ID)
    assert np.array_equal(calm.reset(seed=5)[0], plain.reset(seed=5)[0])
    action = np.array([0.2, 0.7, -0.4], dtype=np.float32)
    assert np.array_equal(calm.step(action)[0], plain.step(action)[0])


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"speed_demand_max": 250.0}, "speed_demand_max"),
        ({"altitude_min": -5.0}, "altitude_min"),
        ({"ceiling_altitude": 1500.0}, "ceiling_altitude"),
        ({"final_hold": 400.0}, "final_hold"),
        (
            {"episode_steps": 50},
            r"final_hold=90.0 is outside the allowed range \[0, episode_steps \* dt = 50 \* 1.0 = 50\]",
        ),
        ({"change_interval_min": 130.0}, "change_interval_min"),
        ({"altitude_scale": 0.0}, "altitude_scale"),
        ({"episode_steps": 0}, "episode_steps"),
        ({"altitude_min": 1700.0}, "altitude_min=1700.0 is outside the allowed range .*altitude_max=1600.0"),
        ({"speed_demand_min": 50.0}, "speed_demand_min=50.0 is outside the allowed range .min_speed=60.0"),
    ],
)
def test_bad_parameters_raise_value_error_naming_them(kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        gym.make(ENV_ID, **kwargs)


def fly_one_step_from(
    altitude: float, speed: float, heading: float, demand: tuple[float, float, float]
) -> tuple[AircraftEnvParams, np.ndarray, float, dict]:
    """Aircraft-v0 reset, then set to the given altitude, airspeed, heading and demand, and one step of the zero
    action (which holds speed, altitude and heading in still air): the env's params, the step's observation,
    reward and info."""
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    state = env.unwrapped.state
    state["position"][0, 1], state["speed"][0], state["heading"][0] = altitude, speed, heading
    state["demand"][0] = demand
    obs, reward, _, _, info = env.step(np.zeros(3, np.float32))
    assert info["position"][1] == altitude and info["speed"] == speed and info["heading"] == pytest.approx(heading)
    np.testing.assert_array_equal(info["demand"], demand)
    return env.unwrapped.params, obs, reward, info


@pytest.mark.parametrize(
    ("altitude_error", "speed_error", "heading_error"),
    [(900.0, -12.0, 2.5), (-150.0, 45.0, -0.4), (-1200.0, 6.0, -3.0)],
)
def test_tracking_reward_terms_are_the_documented_clipped_errors(
    altitude_error: float, speed_error: float, heading_error: float
) -> None:
    """Rewards: ``-|altitude error| / (3 altitude_scale)`` and ``-|airspeed error| / (3 speed_scale)``, each error
    clipped to its scale, and ``-|heading error| / (3 pi)``; errors are demand minus value."""
    altitude, speed, heading = 2000.0, 120.0, 0.3
    demand = (altitude + altitude_error, speed + speed_error, heading + heading_error)
    p, _, reward, info = fly_one_step_from(altitude, speed, heading, demand)
    terms = info["reward_terms"]
    assert terms["altitude"] == pytest.approx(-min(abs(altitude_error), p.altitude_scale) / (3 * p.altitude_scale))
    assert terms["speed"] == pytest.approx(-min(abs(speed_error), p.speed_scale) / (3 * p.speed_scale))
    assert terms["heading"] == pytest.approx(-abs(heading_error) / (3 * math.pi), rel=1e-9)
    assert terms["effort"] == 0.0
    assert reward == pytest.approx(sum(terms.values()))


def test_the_heading_error_is_wrapped_across_pi() -> None:
    """Heading 3.0 rad toward a demand of -3.0: the error is 2 pi - 6 = 0.283 rad (a left turn), not -6 rad, in the
    reward term, info["errors"] and the observation's sine and cosine."""
    wrapped = 2.0 * math.pi - 6.0
    _, obs, _, info = fly_one_step_from(2000.0, 120.0, 3.0, (2000.0, 120.0, -3.0))
    assert info["errors"][2] == pytest.approx(wrapped, rel=1e-9)
    assert info["reward_terms"]["heading"] == pytest.approx(-wrapped / (3 * math.pi), rel=1e-9)
    assert obs[2:4] == pytest.approx([math.sin(wrapped), math.cos(wrapped)], abs=1e-6)


@pytest.mark.parametrize(
    ("errors", "success"),
    [
        ((10.0, 1.5, math.radians(1.5)), True),
        ((10.0, 1.5, math.radians(10.0)), False),
        ((10.0, 3.0, math.radians(1.5)), False),
        ((20.0, 1.5, math.radians(1.5)), False),
    ],
    ids=["all_within", "heading_out", "speed_out", "altitude_out"],
)
def test_success_needs_every_error_within_its_tolerance(errors: tuple[float, float, float], success: bool) -> None:
    """Episode End: is_success when within altitude_tolerance (15 m), speed_tolerance (2 m/s) and
    heading_tolerance (2 deg) of the demand, each alone failing it."""
    altitude, speed, heading = 1300.0, 110.0, -1.0
    demand = (altitude - errors[0], speed + errors[1], heading - errors[2])
    _, _, _, info = fly_one_step_from(altitude, speed, heading, demand)
    assert info["is_success"] is success


@pytest.mark.parametrize("speed", [60.0, 95.0, 137.5, 200.0])
def test_observed_airspeed_is_its_fraction_of_the_airframe_range(speed: float) -> None:
    """Observation Space: obs[4] is ``(v - min_speed) / (max_speed - min_speed)``."""
    p, obs, _, _ = fly_one_step_from(1400.0, speed, 0.0, (1400.0, 120.0, 0.0))
    assert obs[4] == pytest.approx((speed - p.min_speed) / (p.max_speed - p.min_speed), abs=1e-7)


def test_starting_states_fill_their_documented_ranges_with_independent_draws(
    assert_independent_draws_fill: Callable,
) -> None:
    p = AircraftEnvParams(draft_max=2.0)
    state = AircraftTask(p).initial_state(rng.seed_keys(np.arange(4000)))
    assert (state["position"][:, [0, 2]] == 0.0).all()
    assert_independent_draws_fill(
        {
            "altitude": (state["position"][:, 1], p.altitude_min, p.altitude_max),
            "speed": (state["speed"], p.speed_demand_min, p.speed_demand_max),
            "heading": (state["heading"], -math.pi, math.pi),
            "draft": (state["draft"], -p.draft_max, p.draft_max),
        }
    )
