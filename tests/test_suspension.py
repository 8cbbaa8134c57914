"""Suspension-v0: skyhook against random and passive dampers, info in SI, the cumulative terrain, bump stops."""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest

import vegym  # noqa: F401
from agents.analytic import SuspensionContinuousSkyhook, SuspensionSkyhook, controller_for
from vegym.envs.suspension import SuspensionParams
from vegym.physics import suspension

ENV_ID = "vegym/Suspension-v0"
EPISODES = 50


def first_episodes(policy: str | float, n: int = EPISODES, seed: int = 0, **params: float) -> dict[str, np.ndarray]:
    """Return, final success and length of the first episode of n sub-envs (seeds seed .. seed + n - 1) under the
    skyhook (``"skyhook"``), the continuous skyhook (``"continuous"``), uniform random actions (``"random"``) or a
    constant action (a passive damper)."""
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **params)
    controller, rng = controller_for(env), np.random.default_rng(seed)
    continuous = SuspensionContinuousSkyhook(env.unwrapped.params)
    obs, _ = env.reset(seed=seed)
    done, success = np.zeros(n, bool), np.zeros(n, bool)
    returns, lengths = np.zeros(n), np.zeros(n, dtype=np.int64)
    while not done.all():
        if policy == "skyhook":
            action = controller.predict(obs)[0]
        elif policy == "continuous":
            action = continuous.predict(obs)[0]
        elif policy == "random":
            action = rng.uniform(-1.0, 1.0, (n, 1)).astype(np.float32)
        else:
            action = np.full((n, 1), policy, np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        returns[~done] += reward[~done]
        lengths[~done] += 1
        ended = (terminated | truncated) & ~done
        success[ended] = info["is_success"][ended]
        done |= ended
    return {"return": returns, "success": success, "length": lengths}


def test_skyhook_beats_random_and_every_passive_setting_clearly() -> None:
    sky, chance = first_episodes("skyhook"), first_episodes("random")
    passive = {a: first_episodes(a) for a in (-1.0, 0.0, 1.0)}
    print(
        f"\nSuspension-v0 over {EPISODES} episodes: skyhook return {sky['return'].mean():.3f}, success "
        f"{sky['success'].mean():.0%}; random {chance['return'].mean():.3f}, {chance['success'].mean():.0%}; "
        + "; ".join(
            f"passive a={a:+.0f} {r['return'].mean():.3f}, {r['success'].mean():.0%}" for a, r in passive.items()
        )
    )
    assert sky["success"].mean() >= 0.8 and chance["success"].mean() <= 0.6
    assert sky["return"].mean() < 0.0 and sky["return"].mean() > 0.7 * chance["return"].mean()  # 30% less cost
    assert np.mean(sky["return"] > chance["return"]) >= 0.9
    for a, result in passive.items():
        assert sky["return"].mean() > result["return"].mean(), a
    assert np.all(sky["length"] == 1000)  # never hits a bump stop
    assert np.mean(passive[-1.0]["length"] < 1000) > 0.2  # the softest damper often does
    assert isinstance(controller_for(gym.make(ENV_ID)), SuspensionSkyhook)


def test_continuous_skyhook_reference_rides_more_comfortably_than_the_on_off_one() -> None:
    on_off, continuous = first_episodes("skyhook"), first_episodes("continuous")
    print(
        f"\nSuspension-v0 over {EPISODES} episodes: on-off skyhook return {on_off['return'].mean():.3f}, success "
        f"{on_off['success'].mean():.0%}; continuous skyhook {continuous['return'].mean():.3f}, "
        f"{continuous['success'].mean():.0%}"
    )
    assert 0.9 * on_off["return"].mean() < continuous["return"].mean() < 0.0  # returns are negative: 10% less cost
    assert continuous["success"].mean() >= on_off["success"].mean() and np.all(continuous["length"] == 1000)
    assert np.mean(continuous["return"] > on_off["return"]) >= 0.8


def on_off_law(velocity: np.ndarray, relative: np.ndarray, p: SuspensionParams) -> np.ndarray:
    return suspension.skyhook_damping(velocity, relative, p.damping_min, p.damping_max)


def continuous_law(velocity: np.ndarray, relative: np.ndarray, p: SuspensionParams) -> np.ndarray:
    return suspension.continuous_skyhook_damping(velocity, relative, p.damping_max, p.damping_min, p.damping_max)


@pytest.mark.parametrize(
    ("controller_cls", "law"), [(SuspensionSkyhook, on_off_law), (SuspensionContinuousSkyhook, continuous_law)]
)
def test_controllers_from_the_observation_are_their_laws_on_the_true_state(controller_cls: type, law: Callable) -> None:
    env = gym.make_vec(ENV_ID, num_envs=64, vectorization_mode="vector_entry_point")
    p: SuspensionParams = env.unwrapped.params
    controller = controller_cls(p)
    obs, _ = env.reset(seed=3)
    for _ in range(200):
        state = env.unwrapped.state
        assert np.abs(obs[:, 1:3]).max() < 1.0  # the velocities unclipped (the continuous law takes their ratio)
        damping = law(state["velocity"], state["velocity"] - state["base_velocity"], p)
        obs, _, _, _, info = env.step(controller.predict(obs)[0])
        np.testing.assert_allclose(info["damping"], damping, rtol=1e-5, atol=1e-3 * p.damping_max)


def test_info_is_the_quarter_car_step_in_si_units_over_the_cumulative_terrain() -> None:
    env = gym.make(ENV_ID)
    env.reset(seed=5)
    p: SuspensionParams = env.unwrapped.params
    terrain = {k: env.unwrapped.state[k] for k in ("amplitude", "wavenumber", "phase")}
    start, _ = suspension.terrain(np.zeros(1), *terrain.values())
    y, v = np.full(1, p.static_length), env.unwrapped.state["velocity"].copy()
    base, base_velocity, squared = np.zeros(1), v.copy(), 0.0
    for k, a in enumerate(np.linspace(-1.0, 1.0, 40, dtype=np.float32)):
        c = p.damping_min + 0.5 * (float(a) + 1.0) * (p.damping_max - p.damping_min)
        y, v, acceleration = suspension.step(y, v, base, base_velocity, c, p.dt, p.spring)
        x = (k + 1) * p.dt * p.speed
        height, slope = suspension.terrain(np.array([x]), *terrain.values())
        base, base_velocity = height - start, slope * p.speed
        squared += p.dt * acceleration[0] ** 2
        _, reward, terminated, truncated, info = env.step(np.array([a]))
        assert info["damping"] == pytest.approx(c, rel=1e-12)
        expected = (y[0], v[0], acceleration[0], base[0], base_velocity[0])
        observed = tuple(info[k] for k in ("body_height", "body_velocity", "body_acceleration", "base_height"))
        assert (*observed, info["base_velocity"]) == pytest.approx(expected, rel=1e-9, abs=1e-12)
        assert info["distance"] == pytest.approx(x, rel=1e-12)
        assert info["travel"] == pytest.approx(y[0] - base[0] - p.static_length, abs=1e-15)
        assert info["rms_acceleration"] == pytest.approx(np.sqrt(squared / ((k + 1) * p.dt)), rel=1e-12)
        assert info["reward_terms"] == {
            "comfort": pytest.approx(-p.dt * min((acceleration[0] / p.accel_scale) ** 2, 1.0), rel=1e-12),
            "bump_stop": 0.0,
        }
        assert info["dt"] == p.dt and reward == sum(info["reward_terms"].values())
        assert not terminated and not truncated
    assert set(info) == {
        "body_height",
        "body_velocity",
        "body_acceleration",
        "base_height",
        "base_velocity",
        "travel",
        "damping",
        "distance",
        "rms_acceleration",
        "dt",
        "reward_terms",
        "is_success",
    }


def test_terrain_is_drawn_from_the_seed_within_its_ranges() -> None:
    env = gym.make_vec(ENV_ID, num_envs=500, vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    p: SuspensionParams = env.unwrapped.params
    state = env.unwrapped.state
    wavelength = 2.0 * np.pi / state["wavenumber"]
    slope = state["amplitude"] * state["wavenumber"]
    assert state["amplitude"].shape == (500, p.n_waves)
    assert np.all((wavelength >= p.wavelength_min) & (wavelength <= p.wavelength_max))
    assert np.all((slope >= p.slope_min) & (slope <= p.slope_max))
    assert np.all((state["phase"] >= 0.0) & (state["phase"] < 2.0 * np.pi))
    quarter = np.log(p.wavelength_max / p.wavelength_min) / 4.0
    assert np.mean(np.log(wavelength / p.wavelength_min) < quarter) == pytest.approx(0.25, abs=0.04)  # log-uniform
    np.testing.assert_array_equal(state["base"], 0.0)
    np.testing.assert_array_equal(state["height"], p.static_length)


def test_the_ride_does_not_depend_on_the_step_only_rates_are_parameters() -> None:
    """A passive damper over the same roads at dt = 0.01 s and 0.0025 s: the same RMS acceleration within 4% (the
    semi-implicit Euler error is first order; the book's per-step terrain difference would scale it with dt)."""
    rms = []
    for dt, steps in ((0.0025, 4000), (0.01, 1000)):
        env = gym.make_vec(
            ENV_ID,
            num_envs=20,
            vectorization_mode="vector_entry_point",
            max_episode_steps=steps,
            dt=dt,
            episode_steps=steps,
        )
        env.reset(seed=1)
        for _ in range(steps):
            _, _, terminated, _, info = env.step(np.zeros((20, 1), np.float32))
            assert not terminated.any()
        rms.append(info["rms_acceleration"])
    np.testing.assert_allclose(rms[0], rms[1], rtol=0.04)


def test_a_soft_damper_on_a_resonant_road_hits_the_bump_stop_and_pays_for_the_rest_of_the_episode() -> None:
    p = SuspensionParams()
    resonant = 2.0 * np.pi * p.speed / p.spring.natural_frequency
    env = gym.make(ENV_ID, n_waves=1, wavelength_min=resonant, wavelength_max=resonant, slope_min=0.01)
    env.reset(seed=0)
    terminated, steps = False, 0
    while not terminated and steps < 1000:
        _, reward, terminated, _, info = env.step(np.array([-1.0], np.float32))
        steps += 1
    assert terminated and abs(info["travel"]) > p.travel_limit and not info["is_success"]
    remaining = (p.episode_steps - steps) * p.dt
    assert info["reward_terms"]["bump_stop"] == pytest.approx(-(p.bottom_out_penalty + remaining), rel=1e-12)
    assert -reward > remaining  # more than the worst the rest of the episode could have cost


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"modulus": 1000.0}, "modulus"),
        ({"gravity": 98.1}, r"modulus=8000.0 is outside .*\(mass \* gravity = 300 \* 98.1"),  # names the one passed
        ({"damping_min": 5000.0}, "damping_min"),
        ({"slope_min": 0.02}, "slope_min"),
        ({"wavelength_min": 40.0}, "wavelength_min"),
        ({"dt": 0.2}, "dt"),
        ({"damping_max": 1e200}, r"damping_max=1e\+200 is outside the allowed range \[1e-09, 1e\+09\]"),  # squared: inf
        ({"damping_max": 1e9}, r"dt=0.01 is outside"),
        ({"mass": 1e-3}, r"dt=0.01 is outside .* mass=0.001"),  # names the parameter passed, not only dt
        ({"n_waves": 0}, "n_waves"),
    ],
)
def test_bad_parameters_raise_value_error_naming_them(kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        gym.make(ENV_ID, **kwargs)


@pytest.mark.parametrize("law", ["on-off", "continuous", "random"])
def test_observations_are_scaled_near_unit_spread_and_the_velocities_never_clip(law: str) -> None:
    """The docstring's figures over seeds 0-199: each entry's standard deviation 0.17-0.29 (at velocity_scale 1
    m/s the velocities' was 0.08-0.10), the velocities below 0.32 m/s under the laws (so the continuous law's ratio
    stays exact) and 0.38 m/s under random actions."""
    env = gym.make_vec(ENV_ID, num_envs=200, vectorization_mode="vector_entry_point")
    p: SuspensionParams = env.unwrapped.params
    controller = {"on-off": SuspensionSkyhook(p), "continuous": SuspensionContinuousSkyhook(p), "random": None}[law]
    env.action_space.seed(0)
    obs, _ = env.reset(seed=0)
    seen = [obs]
    for _ in range(p.episode_steps - 1):
        obs = env.step(controller.predict(obs)[0] if controller else env.action_space.sample())[0]
        seen.append(obs)
    seen = np.concatenate(seen)
    assert ((0.17 < seen.std(axis=0)) & (seen.std(axis=0) < 0.29)).all(), seen.std(axis=0)
    assert np.abs(seen[:, 1:3]).max() * p.velocity_scale < (0.38 if controller is None else 0.32)


@pytest.mark.parametrize("sign", [-1.0, 1.0], ids=["compression", "extension"])
def test_a_bump_stop_ends_the_episode_in_compression_as_in_extension(sign: float) -> None:
    """Episode End: terminated when ``|travel| > travel_limit``, either way, with the documented bump-stop charge,
    and never a success (here under a comfort bound that any ride meets)."""
    env = gym.make(ENV_ID, comfort_rms=100.0)
    env.reset(seed=0)
    p: SuspensionParams = env.unwrapped.params
    state = env.unwrapped.state
    state["height"][0] = state["base"][0] + p.static_length + sign * 2.5 * p.travel_limit
    _, reward, terminated, _, info = env.step(np.array([0.0], np.float32))
    assert terminated and not info["is_success"]
    assert np.sign(info["travel"]) == sign and abs(info["travel"]) > p.travel_limit
    remaining = (p.episode_steps - 1) * p.dt
    assert info["reward_terms"]["bump_stop"] == pytest.approx(-(p.bottom_out_penalty + remaining), rel=1e-12)
    assert reward == pytest.approx(info["reward_terms"]["comfort"] + info["reward_terms"]["bump_stop"], rel=1e-12)


@pytest.mark.parametrize("offset", [-0.6, 0.5])
def test_observed_travel_and_acceleration_are_the_state_over_their_scales(offset: float) -> None:
    """Observation Space: obs[0] is (spring length - static length) / travel_limit and obs[3] the body acceleration
    of the step over accel_scale, the acceleration from dv/dt = -(k/m)(y - y_b - l) - (c/m)(v - v_b) - g."""
    env = gym.make(ENV_ID)
    env.reset(seed=3)
    p: SuspensionParams = env.unwrapped.params
    k = p.modulus / p.natural_length
    static_length = p.natural_length - p.mass * p.gravity / k
    state = env.unwrapped.state
    state["height"][0] = state["base"][0] + static_length + offset * p.travel_limit
    y, v, y_b, v_b = (float(state[name][0]) for name in ("height", "velocity", "base", "base_velocity"))
    obs, _, terminated, _, info = env.step(np.array([-1.0], np.float32))  # c = damping_min
    assert not terminated
    acceleration = -(k / p.mass) * (y - y_b - p.natural_length) - p.damping_min / p.mass * (v - v_b) - p.gravity
    assert info["body_velocity"] == pytest.approx(v + p.dt * acceleration, rel=1e-9)
    assert 0.1 < abs(acceleration / p.accel_scale) < 1.0  # unclipped, and far from zero
    assert obs[3] == pytest.approx(acceleration / p.accel_scale, rel=1e-5)
    travel = info["body_height"] - info["base_height"] - static_length
    assert 0.1 < abs(travel / p.travel_limit) < 1.0
    assert obs[0] == pytest.approx(travel / p.travel_limit, rel=1e-5)
    assert np.sign(obs[0]) == np.sign(offset)  # the travel still has the sign it was given


@pytest.mark.parametrize("controller_cls", [SuspensionSkyhook, SuspensionContinuousSkyhook])
def test_the_damper_laws_act_finitely_when_the_damper_has_one_setting(controller_cls: type) -> None:
    """damping_min == damping_max is a valid passive damper: every action sets it (the laws divided 0 by 0)."""
    env = gym.make(ENV_ID, damping_min=2000.0, damping_max=2000.0)
    obs, _ = env.reset(seed=0)
    controller = controller_cls(env.unwrapped.params)
    for _ in range(20):
        action, _ = controller.predict(obs)
        assert np.all(np.isfinite(action))
        obs, *_ = env.step(action)


@pytest.mark.filterwarnings("ignore:.*plans episodes of episode_steps")  # the time limit past the plan
def test_a_bump_stop_past_the_planned_episode_costs_the_penalty_alone() -> None:
    """The bump-stop charge covers the planned steps left, none once the episode runs past them."""
    env = gym.make(ENV_ID, episode_steps=10, max_episode_steps=30)
    env.reset(seed=0)
    p: SuspensionParams = env.unwrapped.params
    for _ in range(15):
        env.step(np.zeros(1, np.float32))
    state = env.unwrapped.state
    state["height"][0] = state["base"][0] + p.static_length + 2.5 * p.travel_limit
    _, _, terminated, _, info = env.step(np.zeros(1, np.float32))
    assert terminated and info["reward_terms"]["bump_stop"] == -p.bottom_out_penalty


def test_comfort_costs_the_squared_acceleration_over_its_scale_up_to_one_per_second() -> None:
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    p: SuspensionParams = env.unwrapped.params
    state = env.unwrapped.state
    state["velocity"][0] = state["base_velocity"][0] + 0.5  # the stiff damper: about -6.7 m/s^2, over accel_scale
    info = env.step(np.ones(1, np.float32))[4]
    assert abs(info["body_acceleration"]) > p.accel_scale and info["reward_terms"]["comfort"] == -p.dt
    env.reset(seed=0)
    state = env.unwrapped.state
    state["velocity"][0] = state["base_velocity"][0] + 0.1  # about -1.3 m/s^2
    info = env.step(np.ones(1, np.float32))[4]
    expected = -p.dt * (info["body_acceleration"] / p.accel_scale) ** 2
    assert 0.0 < -expected < p.dt and info["reward_terms"]["comfort"] == pytest.approx(expected, rel=1e-12)


def test_a_ride_starts_at_rest_on_its_spring_moving_with_the_terrain_under_it() -> None:
    """Starting State: the body at the static length over the ground and both at the ground's vertical speed,
    ``slope(0) * speed``."""
    env = gym.make(ENV_ID)
    env.reset(seed=2)
    p: SuspensionParams = env.unwrapped.params
    state = env.unwrapped.state
    ground, slope = suspension.terrain(np.zeros(1), state["amplitude"], state["wavenumber"], state["phase"])
    assert state["height"][0] - state["base"][0] == pytest.approx(p.static_length, rel=1e-12)
    assert slope[0] != 0.0 and state["offset"][0] == pytest.approx(ground[0], rel=1e-12)
    assert state["velocity"][0] == state["base_velocity"][0] == pytest.approx(slope[0] * p.speed, rel=1e-12)
