"""Thread-v0: velocity feedback against random, the pluck, info in SI, settling, step independence, substeps."""

from __future__ import annotations

import re
import subprocess
import sys
import warnings
from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest

import vegym  # noqa: F401
from agents.analytic import ThreadVelocityFeedback, controller_for
from vegym.envs.thread import MOST_SUBSTEPS, ThreadEnvParams, ThreadTask
from vegym.physics import thread

ENV_ID = "vegym/Thread-v0"
EPISODES = 50


def first_episodes(policy: str, n: int = EPISODES, seed: int = 0, gain: float | None = None) -> dict[str, np.ndarray]:
    """Return, success and length (steps) of the first episode of n sub-envs under feedback (of the controller's
    default gain, or ``gain`` in N s/m), random or no force."""
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    controller, rng = ThreadVelocityFeedback(env.unwrapped.params, gain), np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    done, success = np.zeros(n, bool), np.zeros(n, bool)
    returns, lengths = np.zeros(n), np.zeros(n, dtype=np.int64)
    while not done.all():
        if policy == "feedback":
            action = controller.predict(obs)[0]
        elif policy == "random":
            action = rng.uniform(-1.0, 1.0, (n, 6)).astype(np.float32)
        else:
            action = np.zeros((n, 6), np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        returns[~done] += reward[~done]
        lengths[~done] += 1
        ended = (terminated | truncated) & ~done
        success[ended] = info["is_success"][ended]
        done |= ended
    return {"return": returns, "success": success, "length": lengths}


def test_velocity_feedback_settles_every_pluck_within_a_second_and_beats_random_by_far() -> None:
    feedback, chance, passive = first_episodes("feedback"), first_episodes("random"), first_episodes("none")
    print(
        f"\nThread-v0 over {EPISODES} episodes: feedback return {feedback['return'].mean():.3f}, success "
        f"{feedback['success'].mean():.0%}, settled after {feedback['length'].mean() * 0.01:.2f} s on average "
        f"({feedback['length'].max() * 0.01:.2f} s at most); random {chance['return'].mean():.2f}, "
        f"{chance['success'].mean():.0%}; no force {passive['return'].mean():.2f}, {passive['success'].mean():.0%}"
    )
    assert feedback["success"].all() and feedback["length"].max() <= 100
    assert not chance["success"].any() and not passive["success"].any()
    assert feedback["return"].min() > 10.0 * passive["return"].max() > 10.0 * chance["return"].max()
    assert isinstance(controller_for(gym.make(ENV_ID)), ThreadVelocityFeedback)


def test_default_gain_is_half_of_one_at_which_the_held_feedback_stops_settling() -> None:
    """The default gain, capped at c_fb dt / m = 1/4: twice it still settles every pluck, 2.2 times it fewer than
    half (those that end before the instability grows) and 3 times it none, so the sampled-data limit lies between
    c_fb dt / m = 0.5 and 0.55 at the defaults (not at 1)."""
    p = ThreadEnvParams()
    default = ThreadVelocityFeedback(p).gain
    assert default * p.dt / p.node_mass == pytest.approx(0.25)
    stable, beyond, unstable = (first_episodes("feedback", 20, gain=k * default) for k in (2.0, 2.2, 3.0))
    print(
        f"\nThread-v0 over 20 episodes: gain {2 * default:.2f} N s/m return {stable['return'].mean():.3f}, success "
        f"{stable['success'].mean():.0%}; gain {2.2 * default:.2f} N s/m {beyond['return'].mean():.3f}, "
        f"{beyond['success'].mean():.0%}; gain {3 * default:.2f} N s/m {unstable['return'].mean():.3f}, "
        f"{unstable['success'].mean():.0%}"
    )
    assert stable["success"].all() and beyond["success"].mean() < 0.5 and not unstable["success"].any()


def test_controller_from_the_observation_is_saturated_collocated_velocity_feedback() -> None:
    env = gym.make_vec(ENV_ID, num_envs=32, vectorization_mode="vector_entry_point")
    p: ThreadEnvParams = env.unwrapped.params
    controller = controller_for(env)
    slowest = thread.mode_frequencies(p.physics)[0]
    assert controller.gain == min(2.0 * p.node_mass * slowest, p.node_mass / (4.0 * p.dt)) == 0.5
    obs, _ = env.reset(seed=1)
    for _ in range(30):
        velocities = env.unwrapped.state["velocities"][:, p.actuated]
        expected = np.clip(-controller.gain * velocities / p.max_force, -1.0, 1.0).reshape(32, -1)
        action = controller.predict(obs)[0]
        np.testing.assert_allclose(action, expected, atol=1e-6)
        obs, _, _, _, info = env.step(action)
        np.testing.assert_allclose(info["forces"], p.max_force * action.reshape(32, 3, 2))


def test_the_pluck_is_a_triangle_on_the_rest_shape_released_at_rest() -> None:
    env = gym.make_vec(ENV_ID, num_envs=400, vectorization_mode="vector_entry_point")
    obs, _ = env.reset(seed=0)
    p: ThreadEnvParams = env.unwrapped.params
    state = env.unwrapped.state
    rest = thread.static_equilibrium(p.physics)
    lift = state["positions"] - rest
    np.testing.assert_array_equal(lift[..., 0], 0.0)
    np.testing.assert_array_equal(state["velocities"], 0.0)
    peak = np.max(np.abs(lift[..., 1]), axis=1)
    x = rest[:, 0] / p.span
    assert np.all(peak <= p.pluck_max) and peak.min() > 0.0
    for row in lift[:, :, 1]:
        slopes = np.diff(np.concatenate([[0.0], row, [0.0]])) / np.diff(np.concatenate([[0.0], x, [1.0]]))
        kinks = np.flatnonzero(np.abs(np.diff(slopes)) > 1e-9 * p.pluck_max)
        assert len(kinks) <= 2 and (len(kinks) < 2 or kinks[1] == kinks[0] + 1)  # one straight piece per side
    assert 0.4 < np.mean(lift[:, :, 1].sum(axis=1) > 0) < 0.6  # up or down
    assert np.all(state["initial_excess"] > 0.0) and np.all(obs[:, -1] == 0.5)  # f / (1 + f) of f = 1
    excess = thread.energy(state["positions"], state["velocities"], p.physics)
    excess -= thread.energy(rest[None], np.zeros((1, 9, 2)), p.physics)
    np.testing.assert_allclose(state["initial_excess"], excess, rtol=1e-12)


def test_plucks_fill_their_documented_ranges_with_independent_draws(assert_independent_draws_fill: Callable) -> None:
    """Starting State: the pluck point uniform in [pluck_margin, 1 - pluck_margin] of the span, the height uniform
    in [pluck_min, pluck_max], up or down. Both are read back from the triangle's two slopes, ``h / at`` at the
    first node and ``-h / (span - at)`` at the last (the pluck point lies between them). Position and height were
    drawn from one lane: plucks near the left end were all 3 cm high, near the right 10 cm."""
    p = ThreadEnvParams()
    task = ThreadTask(p)
    lift = task.initial_state(vegym.rng.seed_keys(np.arange(4000)))["positions"][..., 1] - task.equilibrium[:, 1]
    x = task.equilibrium[:, 0]
    assert x[0] < p.pluck_margin * p.span and x[-1] > (1.0 - p.pluck_margin) * p.span
    left, right = lift[:, 0] / x[0], lift[:, -1] / (p.span - x[-1])
    at = p.span * right / (left + right)
    height = left * at
    assert_independent_draws_fill(
        {
            "pluck point": (at, p.pluck_margin * p.span, (1.0 - p.pluck_margin) * p.span),
            "height": (np.abs(height), p.pluck_min, p.pluck_max),
            "up or down": (np.sign(height), -1.0, 1.0),
        }
    )


def test_the_observation_is_the_displacement_from_rest_the_velocity_and_the_energy_left() -> None:
    """Observation Space: each node's (x, y) displacement from the rest shape over pluck_max, then its velocity
    over velocity_scale, both clipped to [-1, 1], then f / (1 + f) of the fraction f of the initial excess energy
    left; computed here from the step's info (random full forces drive some entries to the clip)."""
    env = gym.make(ENV_ID)
    p: ThreadEnvParams = env.unwrapped.params
    rest = thread.static_equilibrium(p.physics)
    obs, _ = env.reset(seed=3)
    size = 2 * p.n_nodes
    np.testing.assert_array_equal(obs[0:size:2], 0.0)  # the pluck is vertical
    assert np.abs(obs[1:size:2]).max() > 0.2
    rng, clipped = np.random.default_rng(0), 0
    for _ in range(200):
        obs, _, terminated, truncated, info = env.step(rng.choice([-1.0, 1.0], 6).astype(np.float32))
        displacement = np.clip((info["positions"] - rest).ravel() / p.pluck_max, -1.0, 1.0)
        velocity = np.clip(info["velocities"].ravel() / p.velocity_scale, -1.0, 1.0)
        fraction = max(info["energy_fraction"], 0.0)
        expected = np.concatenate([displacement, velocity, [fraction / (1.0 + fraction)]]).astype(np.float32)
        np.testing.assert_allclose(obs, expected, rtol=1e-6, atol=1e-7)
        clipped += int(np.sum(np.abs(obs[:-1]) == 1.0))
        assert not (terminated or truncated)
    assert np.abs(obs[0:size:2]).max() > 0.01 and clipped > 0


def test_info_is_the_thread_step_in_si_units_and_settling_ends_the_episode() -> None:
    env = gym.make(ENV_ID)
    env.reset(seed=6)
    p: ThreadEnvParams = env.unwrapped.params
    task = env.unwrapped.task
    positions, velocities = env.unwrapped.state["positions"].copy(), env.unwrapped.state["velocities"].copy()
    initial = float(env.unwrapped.state["initial_excess"][0])
    controller = controller_for(env)
    observed = np.empty((1, *env.observation_space.shape), np.float32)
    env.unwrapped.task.observe(env.unwrapped.state, observed)
    obs = observed[0]
    terminated, steps = False, 0
    while not terminated and steps < 100:
        steps += 1
        action = controller.predict(obs)[0]
        applied = np.zeros((1, 9, 2))
        applied[0, p.actuated] = p.max_force * action.astype(np.float64).reshape(3, 2)
        for _ in range(task.substeps):
            positions, velocities = thread.step(positions, velocities, applied, p.dt / task.substeps, p.physics)
        obs, reward, terminated, truncated, info = env.step(action)
        assert set(info) == {
            "positions",
            "velocities",
            "forces",
            "energy",
            "excess_energy",
            "energy_fraction",
            "dt",
            "reward_terms",
            "is_success",
        }
        np.testing.assert_array_equal(info["positions"], positions[0])
        np.testing.assert_array_equal(info["velocities"], velocities[0])
        energy = thread.energy(positions, velocities, p.physics)[0]
        assert info["energy"] == energy and info["excess_energy"] == pytest.approx(energy - task.rest_energy)
        fraction = info["excess_energy"] / initial
        assert info["energy_fraction"] == pytest.approx(fraction, rel=1e-12)
        assert info["reward_terms"] == {
            "energy": pytest.approx(-p.dt * fraction, rel=1e-12),
            "effort": pytest.approx(-p.effort_weight * p.dt * float(np.mean(action.astype(np.float64) ** 2))),
        }
        assert reward == sum(info["reward_terms"].values()) and info["dt"] == p.dt and not truncated
        assert terminated == info["is_success"] == (fraction <= p.settle_fraction)
        assert obs[-1] == pytest.approx(fraction / (1.0 + fraction), rel=1e-6)  # float32
    assert terminated and steps < 100


def test_the_motion_does_not_depend_on_the_control_step() -> None:
    """Without forces, 0.5 s at dt = 0.01 s (3 substeps) and 0.002 s (1 substep) from the same pluck: the same
    thread within the first-order error of the integration steps (3.3 ms and 2 ms)."""
    runs = []
    for dt in (0.01, 0.002):
        env = gym.make(ENV_ID, dt=dt, max_episode_steps=1000)
        env.reset(seed=2)
        assert env.unwrapped.task.substeps == {0.01: 3, 0.002: 1}[dt]
        for _ in range(round(0.5 / dt)):
            _, _, _, _, info = env.step(np.zeros(6, np.float32))
        runs.append(info["positions"])
    np.testing.assert_allclose(runs[0], runs[1], atol=2e-3)  # 2 mm; the pluck is up to 10 cm
    assert np.max(np.abs(runs[0] - thread.static_equilibrium(env.unwrapped.params.physics))) > 0.01


def test_actuators_are_spread_evenly_and_mirror_symmetric_where_they_can_be() -> None:
    for n_nodes, n_actuators, expected in ((9, 3, [2, 4, 6]), (9, 2, [2, 6]), (10, 2, [3, 6]), (4, 4, [0, 1, 2, 3])):
        actuated = ThreadEnvParams(n_nodes=n_nodes, n_actuators=n_actuators).actuated
        np.testing.assert_array_equal(actuated, expected)
        np.testing.assert_array_equal(actuated, (n_nodes - 1 - actuated)[::-1])
    np.testing.assert_array_equal(ThreadEnvParams(n_nodes=10, n_actuators=3).actuated, [2, 5, 7])


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"n_actuators": 10}, "n_actuators"),
        ({"pluck_min": 0.2}, "pluck_min"),
        ({"pluck_margin": 0.5}, "pluck_margin"),
        ({"settle_fraction": 1.0}, "settle_fraction"),
        ({"dt": 2.0}, "dt"),
        ({"stiffness": 1e-6}, r"pluck_min=0.03 is outside the allowed range empty for so soft a .* stiffness=1e-06,"),
        ({"pluck_min": 1e-9}, r"pluck_min=1e-09 is outside the allowed range about \[2.07e-07, pluck_max\]"),
        ({"natural_length": 300.0}, r"natural_length=300.0 .* rest-shape solver"),  # the solver's RuntimeError before
    ],
)
def test_bad_parameters_raise_value_error_naming_them(kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        gym.make(ENV_ID, **kwargs)


@pytest.mark.parametrize("settle_fraction", [0.01, 1e-6])
def test_the_smallest_pluck_named_in_the_error_is_about_the_one_that_passes(settle_fraction: float) -> None:
    with pytest.raises(ValueError, match=r"about \[") as error:
        ThreadEnvParams(pluck_min=1e-9, settle_fraction=settle_fraction)
    named = float(re.search(r"about \[([0-9.e+-]+),", str(error.value)).group(1))
    ThreadEnvParams(pluck_min=1.1 * named, settle_fraction=settle_fraction)
    with pytest.raises(ValueError, match="pluck_min"):
        ThreadEnvParams(pluck_min=0.8 * named, settle_fraction=settle_fraction)


@pytest.mark.parametrize(("name", "far_beyond"), [("stiffness", 1e9), ("drag", 1e7)])
def test_a_thread_needing_more_than_the_most_substeps_is_refused_at_the_bound_the_error_names(
    name: str, far_beyond: float
) -> None:
    """drag=1e7 took 2.3 s per step (ten million substeps): refused, naming the largest value that is taken."""
    with pytest.raises(ValueError, match=rf"{name}=.* is outside the allowed range .*, ([0-9.e+]+)\] for") as error:
        ThreadEnvParams(**{name: far_beyond})
    bound = float(re.search(r", ([0-9.e+]+)\] for", str(error.value)).group(1))
    assert thread.substeps(0.01, ThreadEnvParams(**{name: 0.999 * bound}).physics) <= MOST_SUBSTEPS
    with pytest.raises(ValueError, match=name):
        ThreadEnvParams(**{name: 1.001 * bound})


@pytest.mark.parametrize(
    "kwargs",
    [
        {"n_nodes": 64},
        {"span": 0.2},
        {"natural_length": 1.0},
        {"natural_length": 100.0},
        {"stiffness": 0.5},
        {"stiffness": 4e7},
        {"drag": 900.0},
    ],
)
def test_far_from_default_threads_keep_finite_observations_and_rewards(kwargs: dict) -> None:
    env = gym.make_vec(ENV_ID, num_envs=16, vectorization_mode="vector_entry_point", **kwargs)
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(50):
        assert np.all(np.isfinite(obs)) and env.observation_space.contains(obs)
        obs, reward, *_ = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32))
        assert np.all(np.isfinite(reward))


def test_a_batch_of_several_blocks_steps_each_episode_as_alone_bit_for_bit() -> None:
    """The step kernel advances blocks of threads in passes (the last one partial): every row of a batch of 300
    must come out as that episode stepped on its own."""
    task = gym.make(ENV_ID).unwrapped.task
    n = 300
    keys = np.arange(1, n + 1, dtype=np.uint64) * np.uint64(0x9E3779B97F4A7C15)
    state = task.initial_state(keys)
    action = np.random.default_rng(0).uniform(-1.0, 1.0, (n, 6))
    rows = [{k: v[i : i + 1].copy() for k, v in state.items()} for i in range(n)]
    for _ in range(3):
        out = task.outputs(n)
        task.step(state, action, out)
        for i in (0, 1, 255, 256, 257, 299):
            alone = task.outputs(1)
            task.step(rows[i], action[i : i + 1], alone)
            for name, value in out.items():
                np.testing.assert_array_equal(value[i : i + 1], alone[name], err_msg=name)
            for name, value in state.items():
                np.testing.assert_array_equal(value[i : i + 1], rows[i][name], err_msg=name)


def test_the_energy_entry_follows_energy_pumped_far_above_the_pluck() -> None:
    """Random forces pump in many times the pluck's energy: the entry f / (1 + f) keeps telling those apart (clipped
    at f = 1 it read 1 on 99% of such steps)."""
    env = gym.make_vec(ENV_ID, num_envs=16, vectorization_mode="vector_entry_point")
    env.reset(seed=2)
    rng = np.random.default_rng(2)
    fractions, entries = [], []
    for _ in range(150):
        obs, _, _, _, info = env.step(rng.uniform(-1.0, 1.0, (16, 6)).astype(np.float32))
        fractions.append(info["energy_fraction"])
        entries.append(obs[:, -1])
    fractions, entries = np.concatenate(fractions), np.concatenate(entries)
    assert np.median(fractions) > 2.0  # far above the pluck's energy
    np.testing.assert_allclose(entries, fractions / (1.0 + fractions), rtol=1e-6)
    assert entries.max() < 1.0 and len(np.unique(entries)) > 0.9 * len(entries)


@pytest.mark.parametrize("stiffness", [5e-324, 1e-320, 1e-300])
def test_a_thread_too_soft_for_the_rest_shape_solver_is_refused_naming_a_parameter(stiffness: float) -> None:
    """stiffness=5e-324 or 1e-320 (allowed once: (0, inf)) hung in the rest-shape solver, whose shift 1e-6 S
    underflowed to 0 and never grew; 1e-300 raised numpy's LinAlgError 'Eigenvalues did not converge', naming no
    parameter, after overflow warnings (a helper's fuzzing); stiffnesses end at 1e-9 N/m now. In a subprocess, so
    that a hang fails the test instead of the run."""
    code = (
        "import warnings; warnings.simplefilter('error'); from vegym.envs.thread import ThreadEnvParams\n"
        f"try:\n    ThreadEnvParams(stiffness={stiffness!r})\nexcept ValueError as error:\n    print(error)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert re.search(
        rf"stiffness={re.escape(repr(stiffness))} is outside the allowed range \[1e-09, 1e\+09\]", done.stdout
    )


@pytest.mark.parametrize("pluck_margin", [0.0, 1e-300, 5e-324])
def test_plucks_reaching_the_ends_of_the_span_warn_of_nothing(pluck_margin: float) -> None:
    """pluck_margin=0 (the closed end of its range [0, 0.5)) puts the validation's extreme plucks at the ends of the
    span, where plucked() divided by their zero distance from the end in the side np.where discards: a numpy
    RuntimeWarning 'divide by zero' at every make (a helper's fuzzing); a subnormal margin's distance, 'overflow'."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(ENV_ID, pluck_margin=pluck_margin)
        obs, _ = env.reset(seed=0)
        for _ in range(20):
            obs, reward, *_ = env.step(env.action_space.sample())
        assert np.all(np.isfinite(obs)) and np.isfinite(reward)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"node_mass": 5e-324}, r"node_mass=5e-324 is outside the allowed range \[1e-09, 1e\+09\]"),
        (
            {"node_mass": 1e-9, "drag": 0.0},
            r"stiffness=400.0 is outside the allowed range \[1e-09, 2.5\] for node_mass=1e-09",
        ),
        (
            {"node_mass": 1e-9, "stiffness": 1e-9},
            r"drag=0.002 is outside the allowed range \[0, 5e-05\] for node_mass=1e-09",
        ),
        ({"span": 1e300}, "span=1e[+]300 is outside the allowed range"),
    ],
)
def test_extreme_threads_are_refused_with_a_value_error_naming_a_parameter(kwargs: dict, name: str) -> None:
    """node_mass=5e-324 raised ZeroDivisionError (its stable step sqrt(m / S) underflowed to 0), or with
    stiffness=1e-11 OverflowError (the ceil of an infinite substep count), and span=1e300 OverflowError (span**2 in
    the rest-shape solver's start), all allowed by the ranges then (a helper's fuzzing); too light a node for the
    step still names the spring or the drag."""
    with pytest.raises(ValueError, match=name):
        ThreadEnvParams(**kwargs)
