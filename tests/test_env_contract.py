"""The contract every registered vegym env keeps: checkers, determinism, pickling, bounds, vector twin, errors."""

from __future__ import annotations

import copy
import dataclasses
import itertools
import math
import os
import pickle
import platform
import re
import signal
import subprocess
import sys
import time
import warnings
from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import vegym
from agents.analytic import REFERENCE_AGENTS, controller_for
from vegym import rng
from vegym.envs import base
from vegym.envs.aircraft import AircraftEnvParams
from vegym.params import LARGEST, SMALLEST
from vegym.physics.aircraft import AircraftParams
from vegym.physics.pendulum import PendulumParams

ENV_IDS = list(vegym.ENVS)


def random_actions(env_id: str, count: int, seed: int) -> np.ndarray:
    """Uniform actions with some at the extremes of the box (they end episodes early in several tasks)."""
    rng = np.random.default_rng(seed)
    shape = gym.spec(env_id).make().action_space.shape
    actions = rng.uniform(-1.0, 1.0, (count, *shape))
    extreme = rng.random(count) < 0.15
    actions[extreme] = rng.choice([-1.0, 1.0], size=(extreme.sum(), *shape))
    return actions.astype(np.float32)


def rollout(env: gym.Env, actions: np.ndarray, seed: int) -> list[tuple]:
    """Obs, reward, terminated, truncated and info of every step, resetting when an episode ends."""
    obs, _ = env.reset(seed=seed)
    records = [(obs, 0.0, False, False, {})]
    for action in actions:
        obs, reward, terminated, truncated, info = env.step(action)
        records.append((obs, reward, terminated, truncated, info))
        if terminated or truncated:
            obs, _ = env.reset()
            records.append((obs, 0.0, False, False, {}))
    return records


def assert_same(a: object, b: object) -> None:
    assert gym.utils.env_checker.data_equivalence(a, b, exact=True), f"{a!r} != {b!r}"


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_passes_gymnasium_and_sb3_checkers_without_warnings(env_id: str) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = gym.make(env_id)
        gym_check_env(env.unwrapped)
        sb3_check_env(env.unwrapped, warn=True)
    assert [str(w.message) for w in caught] == []


def test_the_native_vector_env_truncates_at_the_registered_limit_unless_given_none_or_minus_one() -> None:
    """``make_vec`` passes the registered ``max_episode_steps``; an explicit None reaches the vector env, where it
    means no limit (documented in ``VegymVectorEnv``), as -1 does there and in ``gymnasium.make``."""
    env_id = "vegym/GearTrain-v0"  # no goal ends its episodes
    limit = gym.spec(env_id).max_episode_steps
    for given, truncates in (({}, True), ({"max_episode_steps": None}, False), ({"max_episode_steps": -1}, False)):
        env = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **given)
        env.reset(seed=0)
        action = np.zeros(env.action_space.shape, np.float32)
        truncated = [env.step(action)[3] for _ in range(limit)]
        assert not np.any(truncated[:-1]) and truncated[-1].tolist() == [truncates, truncates]


PLANNED_LENGTHS = {
    "vegym/BouncingBall-v0": "episode_bounces",
    "vegym/Aircraft-v0": "episode_steps",
    "vegym/AircraftGusty-v0": "episode_steps",
    "vegym/PendulumPump-v0": "episode_steps",
    "vegym/Suspension-v0": "episode_steps",
}
"""The envs whose task plans for an episode length (a demand schedule's end, a charge for the steps left)."""


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_a_time_limit_past_the_planned_length_warns_and_a_shorter_one_does_not(env_id: str) -> None:
    """Registered, the time limit is the planned length; a longer one (max_episode_steps alone) warns once: from the
    vector env when it is made, from the single env (which cannot see its TimeLimit) at the step past the plan. A
    shorter one only cuts episodes, as truncation does, but the vector env warns when the plan was changed alone (the
    registered limit then cuts it)."""
    name = PLANNED_LENGTHS.get(env_id)
    assert name == type(gym.make(env_id).unwrapped.task).planned_length_param
    if name is None:
        return
    planned = getattr(gym.make(env_id).unwrapped.params, name)
    assert gym.spec(env_id).max_episode_steps == planned
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
        shorter = {name: planned // 2, "max_episode_steps": planned // 2}
        gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **shorter)
        gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=planned - 1)
    assert caught == []
    limit = planned + 1
    with pytest.warns(UserWarning, match=rf"max_episode_steps={limit}, but the task plans episodes of {name}="):
        gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=limit)
    cut = rf"max_episode_steps={planned} cuts the episodes that {name}={limit} plans"  # the registered limit
    with pytest.warns(UserWarning, match=cut):
        gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **{name: limit})
    short = planned // 2
    env = gym.make(env_id, max_episode_steps=short + 2, **{name: short})
    action = np.full(env.action_space.shape, 0.8, np.float32)  # BouncingBall: e = 0.9 keeps the ball bouncing
    env.reset(seed=0)
    for _ in range(short):
        env.step(action)
    ran = (
        rf"an episode has run {short + 1} steps, but the task plans episodes of {name}={short} steps \(.*\); where "
        r"the time limit truncated it, call reset\(\) first"
    )
    with pytest.warns(UserWarning, match=ran):
        env.step(action)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env.step(action)
        env.reset()
        for _ in range(short + 2):
            env.step(action)
    assert caught == []  # once per env


def test_a_step_after_a_termination_warns_that_reset_is_due_and_a_state_put_back_does_not() -> None:
    """Projectile's episodes end at their one step; a second step fired again without a word (a helper's trial)."""
    env = gym.make("vegym/Projectile-v0", max_episode_steps=-1)
    action = np.zeros(3, np.float32)
    env.reset(seed=0)
    assert env.step(action)[2]
    with pytest.warns(UserWarning, match=r"ProjectileEnv: step\(\) after the episode terminated; call reset\(\) first"):
        env.step(action)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env.reset()
        snapshot = copy.deepcopy(env.unwrapped.state)
        assert env.step(action)[2]
        env.unwrapped.state = copy.deepcopy(snapshot)  # a state to step on from
        assert env.step(action)[2]
        for name, value in snapshot.items():  # put back in place, as the env's docstring allows
            env.unwrapped.state[name][...] = value
        env.step(action)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_same_seed_gives_identical_rollouts(env_id: str) -> None:
    actions = random_actions(env_id, 60, seed=1)
    first = rollout(gym.make(env_id), actions, seed=7)
    second = rollout(gym.make(env_id), actions, seed=7)
    assert_same(first, second)
    other = rollout(gym.make(env_id), actions, seed=8)
    assert not gym.utils.env_checker.data_equivalence(first[0][0], other[0][0])


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_a_seeded_reset_of_a_used_env_replays_a_fresh_env_s_rollout(env_id: str) -> None:
    used = gym.make(env_id)
    rollout(used, random_actions(env_id, 37, seed=2), seed=1)  # ends mid-episode in the long-episode envs
    actions = random_actions(env_id, 60, seed=3)
    assert_same(rollout(used, actions, seed=7), rollout(gym.make(env_id), actions, seed=7))


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_pickled_env_continues_identically(env_id: str) -> None:
    env = gym.make(env_id)
    actions = random_actions(env_id, 40, seed=2)
    env.reset(seed=3)
    if any(env.step(actions[0])[2:4]):  # a one-step episode
        env.reset()
    clone = pickle.loads(pickle.dumps(env))
    for action in actions[1:]:
        a = env.step(action)
        b = clone.step(action)
        assert_same(a, b)
        if a[2] or a[3]:
            assert_same(env.reset(), clone.reset())


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_a_state_snapshot_put_back_replays_the_same_steps(env_id: str) -> None:
    """A single env binds its kernels to its state's arrays; a new ``state`` dict must be bound in their place."""
    env = gym.make(env_id)
    actions = random_actions(env_id, 12, seed=3)

    def play() -> list:
        results = []
        for action in actions[1:]:
            results.append(env.step(action))
            if results[-1][2] or results[-1][3]:
                results.append(env.reset())
        return results

    env.reset(seed=4)
    if any(env.step(actions[0])[2:4]):  # a one-step episode
        env.reset()
    snapshot = copy.deepcopy(env.unwrapped.state)
    first = play()
    env.unwrapped.state = copy.deepcopy(snapshot)
    assert_same(first, play())


def test_an_interrupted_first_reset_leaves_the_env_usable(monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C while the first reset binds (compiles) the kernels: the env has no state then, and resets later."""
    env, reference = (gym.make("vegym/Projectile-v0").unwrapped for _ in range(2))

    def interrupted(*args: object) -> None:
        raise KeyboardInterrupt

    with monkeypatch.context() as patch:
        patch.setattr(base, "bind_kernel", interrupted)
        with pytest.raises(KeyboardInterrupt):
            env.reset(seed=2)
    with pytest.raises(gym.error.ResetNeeded):
        env.step(np.zeros(env.action_space.shape, np.float32))
    assert_same(env.reset(seed=2), reference.reset(seed=2))
    action = np.full(env.action_space.shape, 0.3, np.float32)
    assert_same(env.step(action), reference.step(action))


def test_an_interrupted_vector_step_keeps_the_autoreset_flags_of_the_step_before(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Ctrl-C inside a vector step, after its episodes ended: the next step still starts them (the flags are replaced
    only once a step has counted the new ones)."""
    env, reference = (
        gym.make_vec("vegym/Projectile-v0", num_envs=4, vectorization_mode="vector_entry_point") for _ in range(2)
    )
    action = np.full(env.action_space.shape, 0.3, np.float32)
    for vector in (env, reference):
        vector.reset(seed=2)
        assert vector.step(action)[2].all()  # one-step episodes: every sub-env restarts on the next step
    flags = env.unwrapped._autoreset
    expected = flags.copy()

    def interrupted(*args: object) -> None:
        raise KeyboardInterrupt

    with monkeypatch.context() as patch:
        patch.setattr(base, "_end_step", interrupted)
        with pytest.raises(KeyboardInterrupt):
            env.step(action)
    assert env.unwrapped._autoreset is flags  # not a new array that the interrupted step never filled
    np.testing.assert_array_equal(flags, expected)
    assert_same(env.step(action), reference.step(action))


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_observations_stay_finite_and_inside_the_space(env_id: str) -> None:
    env = gym.make_vec(env_id, num_envs=256, vectorization_mode="vector_entry_point")
    obs, _ = env.reset(seed=0)
    actions = random_actions(env_id, 300 * 256, seed=4).reshape(300, 256, -1)
    for step_actions in actions:
        assert np.all(np.isfinite(obs))
        assert env.observation_space.contains(obs), env.single_observation_space
        obs, reward, *_ = env.step(step_actions)
        assert np.all(np.isfinite(reward))


OBSERVATION_ONLY_AGENTS = [
    (env_id, name, factory)
    for env_id in ENV_IDS
    for name, factory in {"analytic": controller_for, **REFERENCE_AGENTS.get(env_id, {})}.items()
    if name != "oracle"  # BouncingBall's oracle reads the env's episode key, not the observation
]


@pytest.mark.parametrize(
    ("env_id", "name", "factory"), OBSERVATION_ONLY_AGENTS, ids=lambda v: getattr(v, "__name__", v)
)
def test_controllers_act_finitely_on_any_observation_of_the_space(env_id: str, name: str, factory: Callable) -> None:
    """Episodes never show some observations (GearTrain's ratio 0, say), but a controller's predict still returns
    finite float32 actions of the space's shape for them: the space's corners, zeros and samples."""
    env = gym.make(env_id)
    space = env.observation_space
    space.seed(0)
    corners = [space.low, space.high, np.zeros_like(space.low)]
    batch = np.stack([*corners, *(space.sample() for _ in range(256))]).astype(np.float32)
    actions, _ = factory(env).predict(batch)
    assert actions.shape == (len(batch), *env.action_space.shape) and actions.dtype == np.float32
    assert np.all(np.isfinite(actions)), name


ALL_AGENTS = [
    (env_id, name, factory)
    for env_id in ENV_IDS
    for name, factory in {"analytic": controller_for, **REFERENCE_AGENTS.get(env_id, {})}.items()
]


@pytest.mark.parametrize(("env_id", "name", "factory"), ALL_AGENTS, ids=lambda v: getattr(v, "__name__", v))
def test_controllers_refuse_observations_of_another_shape_non_finite_ones_and_the_reset_pair(
    env_id: str, name: str, factory: Callable
) -> None:
    """As SB3's predict does for shapes and the (obs, info) pair; a NaN or inf entry would otherwise give a NaN
    action, a clipped one that looks fine, or a numpy error deep in the law."""
    env = gym.make(env_id)
    obs, info = env.reset(seed=0)
    agent = factory(env)
    for wrong in (obs[:-1], np.append(obs, 0.0), np.stack([np.append(obs, 0.0)] * 2), obs[None, None], obs[0]):
        with pytest.raises(ValueError, match=re.escape(f"unexpected observation shape {np.shape(wrong)}")):
            agent.predict(wrong)
    for bad in (np.nan, np.inf):
        with pytest.raises(ValueError, match="NaN or inf"):
            agent.predict(np.where(np.arange(obs.size) == 0, bad, obs))
    with pytest.raises(ValueError, match=re.escape("got a tuple (observation, info)")):
        agent.predict((obs, info))
    action, _ = agent.predict(obs)
    assert action.shape == env.action_space.shape and action.dtype == np.float32
    if name != "oracle":  # it acts for its one env
        empty, _ = agent.predict(np.empty((0, *obs.shape), np.float32))
        assert empty.shape == (0, *env.action_space.shape) and empty.dtype == np.float32


def test_controller_for_refuses_other_envs_and_wrappers_that_change_the_spaces_it_reads() -> None:
    env_id = "vegym/Projectile-v0"
    kept = gym.wrappers.RecordEpisodeStatistics(gym.make(env_id))
    assert type(controller_for(kept)).__name__ == "ProjectileFiringSolution"
    vector = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    assert type(controller_for(gym.wrappers.vector.RecordEpisodeStatistics(vector))).__name__ == (
        "ProjectileFiringSolution"
    )
    # ClipAction (the README's advice for exploration noise) widens the action space to +-inf only to clip into it
    for clipped in (gym.wrappers.ClipAction(kept), gym.wrappers.vector.ClipAction(vector)):
        assert type(controller_for(clipped)).__name__ == "ProjectileFiringSolution"
    for changed in (
        gym.wrappers.NormalizeObservation(gym.make(env_id)),
        gym.wrappers.RescaleAction(gym.make(env_id), np.float32(-2.0), np.float32(2.0)),
        gym.wrappers.ClipAction(gym.wrappers.RescaleAction(gym.make(env_id), np.float32(-2.0), np.float32(2.0))),
        gym.wrappers.vector.NormalizeObservation(vector),
    ):
        with pytest.raises(ValueError, match="a wrapper changed them"):
            controller_for(changed)
    for other in (gym.make("CartPole-v1"), gym.make_vec(env_id, num_envs=2, vectorization_mode="sync")):
        with pytest.raises(ValueError, match="controller_for needs a vegym env"):
            controller_for(other)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_vector_env_matches_single_envs_including_mixed_resets(env_id: str) -> None:
    n, steps, seed = 4, 80, 11
    limit = min(gym.spec(env_id).max_episode_steps, 25)
    vec = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", max_episode_steps=limit)
    singles = [gym.make(env_id, max_episode_steps=limit) for _ in range(n)]
    actions = random_actions(env_id, steps * n, seed=5).reshape(steps, n, -1)
    obs, _ = vec.reset(seed=seed)
    for i, env in enumerate(singles):
        assert_same(env.reset(seed=seed + i)[0], obs[i])
    needs_reset = np.zeros(n, dtype=bool)
    mixed_steps = 0
    for t, step_actions in enumerate(actions):
        if t == 7:  # stagger the episodes: a masked reset of sub-env 0 equals the single env's reset()
            obs, _ = vec.reset(options={"reset_mask": np.arange(n) == 0})
            assert_same(singles[0].reset()[0], obs[0])
            needs_reset[0] = False
        mixed_steps += int(0 < needs_reset.sum() < n)
        obs, reward, terminated, truncated, info = vec.step(step_actions)
        for i, env in enumerate(singles):
            if needs_reset[i]:
                single_obs, _ = env.reset()
                assert_same(single_obs, obs[i])
                assert reward[i] == 0.0 and not terminated[i] and not truncated[i]
                assert not info.get("_reward_terms", np.zeros(n, dtype=bool))[i]
                continue
            s_obs, s_reward, s_terminated, s_truncated, s_info = env.step(step_actions[i])
            assert_same(s_obs, obs[i])
            assert (s_reward, s_terminated, s_truncated) == (reward[i], terminated[i], truncated[i])
            for key, value in s_info.items():
                if isinstance(value, dict):
                    for term, term_value in value.items():
                        np.testing.assert_array_equal(term_value, info[key][term][i])
                else:
                    np.testing.assert_array_equal(value, info[key][i])
        needs_reset = terminated | truncated
    if limit > 1:
        assert mixed_steps > 0, "no step had some sub-envs resetting and others not"
    obs, _ = vec.reset()  # unseeded: every sub-env's next episode, as each single env's reset()
    for i, env in enumerate(singles):
        assert_same(env.reset()[0], obs[i])
    listed = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    listed.reset(seed=[seed + i for i in range(n)])
    obs, _ = listed.reset()  # the same after seeds given as a list (which leave np_random unseeded)
    for i in range(n):
        fresh = gym.make(env_id)
        fresh.reset(seed=seed + i)
        assert_same(fresh.reset()[0], obs[i])


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_a_seeded_vector_reset_drops_the_autoresets_that_were_due(env_id: str) -> None:
    """After every sub-env's episode has ended, ``reset(seed=s)`` starts sub-env i's episode of seed s + i and the
    next step steps it, as a single env's, rather than spending the step on the autoreset that was due."""
    n = 3
    vec = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", max_episode_steps=1)
    first, then = random_actions(env_id, 2 * n, seed=4).reshape(2, n, -1)
    vec.reset(seed=0)
    _, _, terminated, truncated, _ = vec.step(first)
    assert (terminated | truncated).all()
    obs, _ = vec.reset(seed=10)
    stepped = vec.step(then)
    for i in range(n):
        single = gym.make(env_id, max_episode_steps=1)
        assert_same(single.reset(seed=10 + i)[0], obs[i])
        s_obs, s_reward, s_terminated, s_truncated, _ = single.step(then[i])
        assert_same(s_obs, stepped[0][i])
        assert (s_reward, s_terminated, s_truncated) == (stepped[1][i], stepped[2][i], stepped[3][i])


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_returned_arrays_are_never_written_by_later_steps(env_id: str) -> None:
    """The envs update their state in place; what step and reset returned must stay as it was."""
    limit = min(gym.spec(env_id).max_episode_steps, 5)
    vec = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", max_episode_steps=limit)
    single = gym.make(env_id, max_episode_steps=limit)
    actions = random_actions(env_id, 30 * 3, seed=6).reshape(30, 3, -1)
    kept_vec, kept_single = [vec.reset(seed=0)], [single.reset(seed=0)]
    for step_actions in actions:
        kept_vec.append(vec.step(step_actions))
        kept_single.append(single.step(step_actions[0]))
        if kept_single[-1][2] or kept_single[-1][3]:
            kept_single.append(single.reset())
    copies = copy.deepcopy((kept_vec, kept_single))
    for step_actions in actions:
        vec.step(step_actions)
        single.step(step_actions[0])
        single.reset()
    assert_same(copies, (kept_vec, kept_single))


@pytest.mark.parametrize("copied", [False, True], ids=["env", "deep copy of the env"])
def test_vector_info_constants_are_one_read_only_array_shared_by_the_steps(copied: bool) -> None:
    vec = gym.make_vec("vegym/BouncingBall-v0", num_envs=4, vectorization_mode="vector_entry_point")
    vec.reset(seed=0)
    actions = np.zeros((4, 1), np.float32)
    vec.step(actions)
    if copied:
        vec = copy.deepcopy(vec)
    first, second = vec.step(actions)[4]["gravity"], vec.step(actions)[4]["gravity"]
    assert first is second
    assert not first.flags.writeable
    np.testing.assert_array_equal(first, np.full(4, vec.unwrapped.params.gravity))


def leaves(info: dict, prefix: str = "") -> list[tuple[str, np.ndarray]]:
    """The arrays of a (nested) info dict, with their paths."""
    found = []
    for name, value in info.items():
        if isinstance(value, dict):
            found += leaves(value, f"{prefix}{name}/")
        else:
            found.append((prefix + name, value))
    return found


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_vector_info_arrays_that_share_the_state_are_read_only(env_id: str) -> None:
    """Writing into an info array must not change the env (the episode constants are shared, not copied)."""
    limit = min(gym.spec(env_id).max_episode_steps, 4)
    vec = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", max_episode_steps=limit)
    vec.reset(seed=0)
    shared = 0
    for step_actions in random_actions(env_id, 10 * 3, seed=4).reshape(10, 3, -1):
        info = vec.step(step_actions)[4]
        state = vec.unwrapped.state.values()
        for path, value in leaves(info):
            if any(np.shares_memory(value, array) for array in state):
                assert not value.flags.writeable, path
                shared += 1
    assert shared > 0 or not vec.unwrapped.task.episode_constants


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_vector_env_frames_are_the_single_envs_frames_through_autoresets(env_id: str) -> None:
    n, limit = 3, 3
    vec = gym.make_vec(
        env_id, num_envs=n, vectorization_mode="vector_entry_point", render_mode="rgb_array", max_episode_steps=limit
    )
    singles = [gym.make(env_id, render_mode="rgb_array", max_episode_steps=limit) for _ in range(n)]
    vec.reset(seed=10)
    for i, env in enumerate(singles):
        env.reset(seed=10 + i)
    autoreset = np.zeros(n, dtype=bool)
    for actions in random_actions(env_id, 7 * n, seed=2).reshape(7, n, -1):
        frames = vec.render()
        assert isinstance(frames, tuple) and len(frames) == n
        for frame, env in zip(frames, singles, strict=True):
            np.testing.assert_array_equal(frame, env.render())
        _, _, terminated, truncated, _ = vec.step(actions)
        for i, env in enumerate(singles):
            env.reset() if autoreset[i] else env.step(actions[i])
        autoreset = terminated | truncated


def test_vector_env_render_modes_and_calls() -> None:
    def make(render_mode: str | None) -> gym.vector.VectorEnv:
        return gym.make_vec("vegym/GearTrain-v0", 2, vectorization_mode="vector_entry_point", render_mode=render_mode)

    with pytest.raises(ValueError, match=r"render_mode='human' is not one of \['rgb_array'\]"):
        make("human")
    with pytest.raises(gym.error.ResetNeeded):
        make("rgb_array").render()
    plain = make(None)
    plain.reset(seed=0)
    with pytest.warns(UserWarning, match="without a render_mode"):
        assert plain.render() is None


def test_vector_info_masks_are_one_read_only_array() -> None:
    """Every ``_name`` mask of a step is the same array: writing into one would change them all."""
    vec = gym.make_vec("vegym/BouncingBall-v0", num_envs=3, vectorization_mode="vector_entry_point")
    vec.reset(seed=0)
    info = vec.step(np.zeros((3, 1), np.float32))[4]
    masks = [value for path, value in leaves(info) if path.rsplit("/", 1)[-1].startswith("_")]
    assert len(masks) > 5 and all(mask is masks[0] for mask in masks)
    with pytest.raises(ValueError, match="read-only"):
        masks[0][0] = False


def test_vector_seeds_span_uint64_and_none_leaves_a_sub_env_unseeded() -> None:
    """As SyncVectorEnv: any seed in [0, 2**64), and a list entry None leaves that sub-env unseeded: its next
    episode, as the single env's reset() starts it, or a random one before any seed."""
    env_id = "vegym/BouncingBall-v0"
    vec = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point")
    single = gym.make(env_id)
    first, _ = vec.reset(seed=[5, None, 2**64 - 1])
    np.testing.assert_array_equal(first[0], single.reset(seed=5)[0])
    np.testing.assert_array_equal(first[2], single.reset(seed=2**64 - 1)[0])
    fresh = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point")
    assert not np.array_equal(fresh.reset(seed=[5, None, 2**64 - 1])[0][1], first[1])  # equal with probability ~0
    obs, _ = vec.reset(seed=2**63)
    np.testing.assert_array_equal(obs[1], single.reset(seed=2**63 + 1)[0])
    for options in ({}, {"reset_mask": np.array([False, True, False])}):
        vec.reset(seed=2**63)
        again, _ = vec.reset(seed=[5, None, 7], options=options)
        np.testing.assert_array_equal(again[1], single.reset()[0])
        single.reset(seed=2**63 + 1)
    for bad in (2**64 - 2, [1, 2, 2**64], [1, -1, 2], [1.5, 2, 3], [True, 1, 2]):
        with pytest.raises(ValueError, match="seed"):
            vec.reset(seed=bad)
    np.testing.assert_array_equal(vec.reset(seed=np.int64(6))[0], vec.reset(seed=6)[0])  # numpy integers too
    vec.reset(seed=np.int64(5))
    assert vec.np_random_seed == 5
    for bad in ("5", 5.0, True):
        with pytest.raises(TypeError, match="expected an int or a list"):
            vec.reset(seed=bad)


def test_a_single_env_pickled_before_the_terminal_step_warning_still_steps() -> None:
    env = gym.make("vegym/Projectile-v0").unwrapped
    env.reset(seed=0)
    old = env.__getstate__()
    del old["_terminated_at"]  # as pickled before 4547fcb
    clone = type(env).__new__(type(env))
    clone.__setstate__(old)
    assert clone.step(np.zeros(3, np.float32))[2]


def test_a_single_env_takes_numpy_integer_seeds_as_the_vector_env_does_and_refuses_other_types() -> None:
    """A seed from a numpy array (sub-env i's seed + i) raised gymnasium.error.Error in the single env, which the
    vector env takes; a bool was taken as 1, which the vector env refuses (a helper's review)."""
    single, vec = (
        gym.make("vegym/Aircraft-v0"),
        gym.make_vec("vegym/Aircraft-v0", num_envs=2, vectorization_mode="vector_entry_point"),
    )
    seeds = np.arange(3, 5, dtype=np.int64)
    np.testing.assert_array_equal(single.reset(seed=seeds[1])[0], vec.reset(seed=seeds[0])[0][1])
    assert single.unwrapped.np_random_seed == 4
    for bad in ("5", 5.0, True, np.bool_(True)):
        with pytest.raises(TypeError, match="expected an int"):
            single.reset(seed=bad)


def test_a_seed_outside_uint64_raises_before_the_env_changes() -> None:
    """Episode keys come from seeds in [0, 2**64); a larger or negative one raises, and the env (its np_random, its
    episode) is as it was: the next step is the one it would have taken."""
    env_id = "vegym/Aircraft-v0"
    action = np.full(3, 0.3, np.float32)
    single, vec = gym.make(env_id), gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    for env, bad_seeds in ((single, (2**64, -1)), (vec, (2**64 - 1, -1, [0, 2**64]))):
        env.reset(seed=3)
        reference = copy.deepcopy(env)
        for bad in bad_seeds:
            with pytest.raises(ValueError, match="seed"):
                env.reset(seed=bad)
        assert env.np_random_seed == reference.np_random_seed == 3
        assert_same(
            env.step(np.broadcast_to(action, env.action_space.shape)),
            reference.step(np.broadcast_to(action, env.action_space.shape)),
        )
        assert_same(env.reset(), reference.reset())


def test_vector_reset_mask_is_held_to_sync_vector_env_rules() -> None:
    """A reset mask that SyncVectorEnv refuses is refused alike, so code written against one runs on the other."""
    env_id = "vegym/BouncingBall-v0"
    bad_masks = (
        ([True, False, False], TypeError),
        (np.array([1, 0, 0]), TypeError),
        (np.array([True, False]), ValueError),
        (np.zeros(3, dtype=bool), ValueError),
    )
    for mode in ("sync", "vector_entry_point"):
        vec = gym.make_vec(env_id, num_envs=3, vectorization_mode=mode)
        vec.reset(seed=1)
        for mask, error in bad_masks:
            with pytest.raises(error, match="reset_mask"):
                vec.reset(options={"reset_mask": mask})
        vec.reset(options={"reset_mask": np.array([False, True, False])})


def test_a_reset_option_the_env_does_not_take_raises_before_the_env_changes() -> None:
    """A misspelled ``reset_mask`` or CartPole's ``low``/``high`` is refused, not ignored; the env is as it was.
    SyncVectorEnv passes its sub-envs the options left after ``reset_mask``: they refuse them."""
    env_id = "vegym/BouncingBall-v0"
    single = gym.make(env_id)
    vectors = [gym.make_vec(env_id, num_envs=3, vectorization_mode=mode) for mode in ("vector_entry_point", "sync")]
    for env, allowed in ((single, "no options"), (vectors[0], "only 'reset_mask'"), (vectors[1], "no options")):
        env.reset(seed=4)
        reference = copy.deepcopy(env)
        for options in ({"low": -0.1, "high": 0.1}, {"reset_mask": np.ones(3, bool), "resetmask": True}):
            if env is single:
                options.pop("reset_mask", None)
            with pytest.raises(ValueError, match=re.escape(f"takes {allowed}")) as error:
                env.reset(options=options)
            assert str(sorted(set(options) - {"reset_mask"})) in str(error.value)
        assert_same(env.reset(options={}), reference.reset())
    reference = copy.deepcopy(vectors[0])
    assert_same(vectors[0].reset(options={"reset_mask": np.ones(3, bool)}), reference.reset())


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_threaded_chunks_step_exactly_as_one_chunk(env_id: str, monkeypatch: pytest.MonkeyPatch) -> None:
    n = 64
    limit = min(gym.spec(env_id).max_episode_steps, 7)
    actions = random_actions(env_id, 20 * n, seed=8).reshape(20, n, -1)

    def run() -> list[tuple]:
        vec = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", max_episode_steps=limit)
        return [vec.reset(seed=3)] + [vec.step(step_actions) for step_actions in actions]

    one_chunk = run()
    monkeypatch.setattr(base, "PARALLEL_MIN_ENVS", 8)
    monkeypatch.setattr(base, "_thread_count", lambda: 3)
    assert_same(one_chunk, run())
    monkeypatch.setattr(base, "PARALLEL_MIN_ENVS", 2)  # chunks of a single row
    monkeypatch.setattr(base, "_thread_count", lambda: 64)
    assert_same(one_chunk, run())


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_transition_is_the_env_step_as_a_pure_function(env_id: str) -> None:
    env = gym.make(env_id)
    env.reset(seed=9)
    task = env.unwrapped.task
    state = {name: value.copy() for name, value in env.unwrapped.state.items()}
    for action in random_actions(env_id, 40, seed=10):
        given = state
        before = copy.deepcopy(given)
        state, out, info = task.transition(given, action[None].astype(np.float64))
        obs, reward, terminated, _, env_info = env.step(action)
        for name, value in before.items():  # the argument is left as it was
            np.testing.assert_array_equal(given[name], value)
        assert_same((obs, reward, terminated), (out["obs"][0], out["reward"].item(0), out["terminated"].item(0)))
        assert_same(env_info, base.row_reader(info)())
        if terminated:
            break


def info_arrays(tree: dict) -> list[np.ndarray]:
    """The arrays among the values of a (nested) info dict."""
    arrays = []
    for value in tree.values():
        if isinstance(value, dict):
            arrays += info_arrays(value)
        elif isinstance(value, np.ndarray):
            arrays.append(value)
    return arrays


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_single_env_infos_are_row_zero_in_arrays_that_share_memory_with_nothing(env_id: str) -> None:
    """The info reader slices some entries from one copy of an output's row (Billiards's 2-vectors): each entry
    must still equal its row, and writing into one must change neither the env nor another entry."""
    env = gym.make(env_id)
    env.reset(seed=4)
    unwrapped = env.unwrapped

    def row_zero(tree: dict) -> dict:
        return {
            name: row_zero(value)
            if isinstance(value, dict)
            else (value.item(0) if value.ndim == 1 else value[0].copy())
            if isinstance(value, np.ndarray)
            else value
            for name, value in tree.items()
        }

    env_arrays = [*unwrapped.state.values(), *unwrapped._out.values()]
    for action in random_actions(env_id, 6, seed=5):
        _, _, terminated, truncated, info = env.step(action)
        assert_same(info, row_zero(unwrapped.task.info(unwrapped.state, unwrapped._out)))
        arrays = info_arrays(info)
        for i, array in enumerate(arrays):
            assert not any(np.shares_memory(array, other) for other in [*arrays[i + 1 :], *env_arrays])
        if terminated or truncated:
            env.reset()


def test_info_reader_slices_only_columns_that_no_other_entry_shares() -> None:
    """The columns of an output array whose entries repeat one view or overlap get copies of their own (slices of
    one row copy would alias); disjoint columns of another are slices of one copy."""
    shot, other = np.arange(12.0).reshape(1, 12).copy(), np.arange(4.0).reshape(1, 4).copy()  # arrays of their own
    same = shot[:, 0:2]
    info = {"a": same, "b": same, "c": shot[:, 1:3], "d": other[:, 0:2], "e": other[:, 2:4], "f": shot[:, 8]}
    read = base.row_reader(info)()
    arrays = info_arrays(read)
    assert not any(np.shares_memory(x, y) for i, x in enumerate(arrays) for y in arrays[i + 1 :])
    assert [read[k].base is None for k in "abcde"] == [True, True, True, False, False]
    assert read["d"].base is read["e"].base
    expected = {"a": [0.0, 1.0], "b": [0.0, 1.0], "c": [1.0, 2.0], "d": [0.0, 1.0], "e": [2.0, 3.0]}
    assert_same(read, {**{k: np.array(v) for k, v in expected.items()}, "f": 8.0})


def test_putting_a_state_back_compiles_no_reader_again() -> None:
    """A state put back (or an unpickled or deep-copied env) binds its readers again: from compiled code kept
    per generated source, since compiling it took 0.1-0.3 ms, more than the state's copy and a step."""
    env = gym.make("vegym/Billiards-v0").unwrapped
    env.reset(seed=0)
    snapshot = {name: value.copy() for name, value in env.state.items()}
    compiled = base._compiled.cache_info().misses
    for _ in range(3):
        env.state = {name: value.copy() for name, value in snapshot.items()}
        env.step(np.zeros(2, np.float32))
        copy.deepcopy(env)
    assert base._compiled.cache_info().misses == compiled


def test_a_single_env_without_action_numbers_keeps_the_general_loader() -> None:
    loader = base.ActionLoader(1, (0,), single=True)
    assert base.single_action_loader(loader) is loader  # the generated code would unpack nothing (a SyntaxError)


EPISODE_CONSTANT_ENV_IDS = [
    env_id for env_id in ENV_IDS if base.load_object(gym.spec(env_id).entry_point).task_cls.episode_constants
]


@pytest.mark.parametrize("env_id", EPISODE_CONSTANT_ENV_IDS)
def test_restarting_every_row_writes_all_of_the_episode_constants(env_id: str) -> None:
    """The vector env hands a restart of every row uninitialised arrays for them."""
    vec = gym.make_vec(env_id, num_envs=6, vectorization_mode="vector_entry_point")
    vec.reset(seed=2)
    task, state = vec.unwrapped.task, vec.unwrapped.state
    for name in task.episode_constants:
        state[name].fill(np.nan)
    task.restart(state, np.arange(6), np.empty((6, *task.observation_space.shape), np.float32))
    for name in task.episode_constants:
        assert np.isfinite(state[name]).all(), name


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_observing_some_rows_writes_those_rows_of_the_full_observation_only(env_id: str) -> None:
    vec = gym.make_vec(env_id, num_envs=12, vectorization_mode="vector_entry_point")
    vec.reset(seed=4)
    for _ in range(5):
        vec.step(vec.action_space.sample())
    task, state = vec.unwrapped.task, vec.unwrapped.state
    rows = np.array([0, 3, 4, 11])
    obs = np.full((12, *task.observation_space.shape), -7.0, np.float32)
    task.observe_rows(state, rows, obs)
    others = np.setdiff1d(np.arange(12), rows)
    np.testing.assert_array_equal(obs[rows], task.observation(state)[rows])
    assert (obs[others] == -7.0).all()


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize(
    "rows",
    [np.arange(12), np.arange(12)[::-1].copy(), np.array([0, 3, 4, 11]), np.array([11, 4, 0, 3])],
    ids=["all rows", "all rows reversed", "some rows", "some rows out of order"],
)
def test_restart_starts_the_next_episodes_of_its_rows_as_start_and_observe_do(env_id: str, rows: np.ndarray) -> None:
    """Tasks restart by one kernel (``restart_call``); it must equal ``restart_by_parts`` (advance, start, observe),
    and leave the other rows alone."""
    vec = gym.make_vec(env_id, num_envs=12, vectorization_mode="vector_entry_point")
    vec.reset(seed=6)
    for _ in range(3):
        vec.step(vec.action_space.sample())
    task, before = vec.unwrapped.task, vec.unwrapped.state
    fused, default = copy.deepcopy(before), copy.deepcopy(before)
    fused_obs, default_obs = (np.full((12, *task.observation_space.shape), -7.0, np.float32) for _ in range(2))
    task.restart(fused, rows, fused_obs)
    task.restart_by_parts(default, rows, default_obs)
    others = np.setdiff1d(np.arange(12), rows)
    assert (fused["key"][rows] != before["key"][rows]).all()
    assert fused.keys() == default.keys()
    for name in fused:  # NaN-aware (a shot not yet fired)
        np.testing.assert_array_equal(fused[name], default[name], err_msg=name)
        np.testing.assert_array_equal(fused[name][others], before[name][others], err_msg=name)
    np.testing.assert_array_equal(fused_obs, default_obs)
    assert (fused_obs[others] == -7.0).all()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_start_writes_into_its_rows_what_initial_state_draws_from_the_same_keys(env_id: str) -> None:
    """Tasks whose episodes restart often start them by a kernel of their own (autoresets, masked and seedless
    resets), beside ``initial_state`` (the first reset): both must draw the same episodes from the same keys."""
    vec = gym.make_vec(env_id, num_envs=12, vectorization_mode="vector_entry_point")
    vec.reset(seed=6)
    for _ in range(3):
        vec.step(vec.action_space.sample())
    task, state = vec.unwrapped.task, copy.deepcopy(vec.unwrapped.state)
    rows, keys = np.array([11, 0, 4, 3]), rng.seed_keys([100, 101, 102, 103])
    task.start(state, keys, rows)
    fresh = task.initial_state(keys)
    for name in fresh.keys() - {"key", "step"}:
        np.testing.assert_array_equal(state[name][rows], fresh[name], err_msg=name)


_FAULTS_PER_STEP = """
import resource, gymnasium as gym, vegym
for env_id in ("CartPole-v1", "vegym/Projectile-v0", "vegym/ProjectileAdjust-v0"):  # the benchmark's order
    vec = gym.make_vec(env_id, num_envs=8192, vectorization_mode="vector_entry_point")
    vec.reset(seed=0)
    actions = vec.action_space.sample()
    for _ in range(4):
        vec.step(actions)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(20):
        vec.step(actions)
    print((resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 20)
"""


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's malloc thresholds")
def test_vector_steps_reuse_heap_memory_instead_of_faulting_in_fresh_pages() -> None:
    """A vector step allocates its outputs and info copies afresh (1-2 MB at 8,192 envs); after other envs'
    allocations glibc kept trimming and re-mapping them (90-256 page faults per step, a third of the step's time)
    until the reset raised its thresholds. In a fresh interpreter, after CartPole's steps, as the benchmark runs."""
    result = subprocess.run([sys.executable, "-c", _FAULTS_PER_STEP], capture_output=True, text=True, check=True)
    faults_per_step = [float(line) for line in result.stdout.split()]
    assert max(faults_per_step[1:]) < 8, result.stdout  # the vegym envs


def test_a_forked_child_steps_a_threaded_vector_env(monkeypatch: pytest.MonkeyPatch) -> None:
    """The thread pool does not survive a fork; the child must start its own instead of waiting forever."""
    monkeypatch.setattr(base, "PARALLEL_MIN_ENVS", 8)
    monkeypatch.setattr(base, "_thread_count", lambda: 2)
    vec = gym.make_vec("vegym/GearTrain-v0", num_envs=64, vectorization_mode="vector_entry_point")
    vec.reset(seed=0)
    actions = np.zeros((64, 1), np.float32)
    vec.step(actions)
    pid = os.fork()
    if pid == 0:  # the child: step, then leave without running the parent's test teardown
        vec.step(actions)
        os._exit(0)
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            assert os.waitstatus_to_exitcode(status) == 0
            return
        time.sleep(0.05)
    os.kill(pid, signal.SIGKILL)
    os.waitpid(pid, 0)
    pytest.fail("the forked child hung on its first threaded step")


def test_actions_of_any_numeric_dtype_are_taken_and_other_shapes_raise() -> None:
    env = gym.make("vegym/SteerableWheel-v0")
    env.reset(seed=0)
    reference = copy.deepcopy(env)
    expected = reference.step(np.array([0.5, -0.25]))
    for action in (
        np.array([0.5, -0.25], np.float32),
        np.array([0.5, -0.25], np.float16),
        np.array([0.5, -0.25], ">f8"),
        np.array([[0.5, -0.25]]),
        [0.5, -0.25],
    ):
        assert_same(copy.deepcopy(env).step(action), expected)
    for bad in (np.zeros(3), np.zeros((2, 1)), np.array(["a", "b"])):
        with pytest.raises(ValueError, match="action"):
            env.step(bad)
    with pytest.raises(
        ValueError, match=r"action has shape \(3,\); expected \(2,\)$"
    ):  # the env's shape, not a batch's
        env.step(np.zeros(3))
    one_number = gym.make("vegym/BouncingBall-v0")
    one_number.reset(seed=0)
    zero_d = np.empty(1, object)
    zero_d[0] = np.array(0.5 + 3j)  # a 0-d array inside an object array
    for bad in (None, [None], np.array([None]), 0.5 + 3j, [0.5 + 3j], np.array([0.5 + 0j]), zero_d, "0.5", ["0.5"]):
        with pytest.raises(ValueError, match="is not an array of real numbers"):
            one_number.step(bad)
    vec = gym.make_vec("vegym/SteerableWheel-v0", num_envs=3, vectorization_mode="vector_entry_point")
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        vec.step(np.zeros((2, 3)))  # transposed: the same number of values, in the wrong layout
    one = gym.make_vec("vegym/SteerableWheel-v0", num_envs=1, vectorization_mode="vector_entry_point")
    one.reset(seed=0)
    with pytest.raises(ValueError, match=r"expected \(1, 2\)$"):  # a vector env's own shape, even for one sub-env
        one.step(np.zeros((2, 3)))


@pytest.mark.parametrize(("n", "dim"), [(1, 3), (1, 1), (5, 1), (5, 2)])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_action_loader_short_paths_load_as_check_actions_does(n: int, dim: int, dtype: type) -> None:
    """Float arrays of an env's own shapes skip the general checks (a single env's, of its action's shape, even
    numba's copy); they must load (clip within the tolerance, keep -0.0 and the bounds) and fail exactly as
    check_actions does."""
    rng = np.random.default_rng(n * dim)
    edges = [1.0, -1.0, -0.0, 1.0 + base.ACTION_TOLERANCE / 2, -1.0 - base.ACTION_TOLERANCE / 2]
    for values in (rng.uniform(-1.0, 1.0, (n, dim)), *(np.full((n, dim), edge) for edge in edges)):
        shapes = {(n, dim), *([(dim,)] if n == 1 else []), *([(n,)] if dim == 1 else [])}
        loaders = [base.ActionLoader(n, (dim,))]
        if n == 1:
            loaders.append(base.single_action_loader(base.ActionLoader(1, (dim,), single=True)))
        for shape, loader in itertools.product(shapes, loaders):
            action = values.astype(dtype).reshape(shape)
            expected = base.check_actions(action, np.empty((n, dim)))
            assert loader(action).tobytes() == expected.tobytes()  # bit for bit: -0.0 too
            for position, (bad, message) in itertools.product((0, -1), ((np.nan, "NaN"), (1.5, "outside"))):
                broken = action.copy()
                broken.flat[position] = bad
                with pytest.raises(ValueError, match=message):
                    loader(broken)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_non_finite_and_out_of_range_actions_raise(env_id: str) -> None:
    env = gym.make(env_id)
    env.reset(seed=0)
    shape = env.action_space.shape
    for bad in (np.nan, np.inf, -np.inf, 1.5):
        action = np.zeros(shape, dtype=np.float32)
        action[0] = bad
        with pytest.raises(ValueError, match="action"):
            env.step(action)
    vec = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point")
    vec.reset(seed=0)
    actions = np.zeros((3, *shape), dtype=np.float32)
    actions[1, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        vec.step(actions)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_unknown_keyword_raises_a_type_error_listing_the_parameters(env_id: str) -> None:
    names = [f.name for f in dataclasses.fields(gym.make(env_id).unwrapped.params)]
    listed = rf"has no parameter 'no_such_parameter'; its parameters: {re.escape(', '.join(names))}"
    with pytest.raises(TypeError, match=listed):
        gym.make(env_id, no_such_parameter=1.0)
    with pytest.raises(TypeError, match=listed):
        gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", no_such_parameter=1.0)
    misspelt = names[0] + names[0][-1]
    with pytest.raises(TypeError, match=rf"has no parameter {misspelt!r} \(did you mean {names[0]!r}\?\)"):
        gym.make(env_id, **{misspelt: 1.0})


def test_a_physics_subset_takes_the_fields_of_its_names_and_refuses_a_missing_unknown_or_doubled_one() -> None:
    task = AircraftEnvParams(max_turn_rate=0.2, wind_x=3.0)
    physics = task.subset(AircraftParams, book_faithful=True)
    assert (physics.max_turn_rate, physics.wind_x, physics.book_faithful) == (0.2, 3.0, True)
    assert task.physics == dataclasses.replace(physics, book_faithful=False)
    with pytest.raises(TypeError, match="AircraftEnvParams has no parameter 'book_faithful' of AircraftParams"):
        task.subset(AircraftParams)
    with pytest.raises(TypeError, match="AircraftParams has no parameter 'book_faithfull'"):
        task.subset(AircraftParams, book_faithful=False, book_faithfull=True)
    with pytest.raises(TypeError, match="AircraftEnvParams has no parameter 'length' of PendulumParams"):
        task.subset(PendulumParams)
    with pytest.raises(TypeError, match="'wind_x' is a parameter of AircraftEnvParams: its value is taken"):
        task.subset(AircraftParams, book_faithful=False, wind_x=-1.0)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_every_parameter_is_a_keyword_that_lands_in_the_spec_and_is_range_checked(env_id: str) -> None:
    params_cls = gym.make(env_id).unwrapped.task.params_cls
    for f in dataclasses.fields(params_cls):
        env = gym.make(env_id, **{f.name: f.default})
        assert env.spec.kwargs[f.name] == f.default
        low = f.metadata.get("low", -math.inf)
        if low > -math.inf:
            bad = low - 1 if isinstance(f.default, int) and not isinstance(f.default, bool) else low - 1.0
            with pytest.raises(ValueError, match=f.name):
                gym.make(env_id, **{f.name: bad})
        if isinstance(f.default, float):
            with pytest.raises(ValueError, match=f.name):
                gym.make(env_id, **{f.name: float("nan")})


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_infinite_and_oversized_parameters_raise_value_errors_naming_them(env_id: str) -> None:
    params_cls = gym.make(env_id).unwrapped.task.params_cls
    for f in dataclasses.fields(params_cls):
        if isinstance(f.default, bool):
            continue
        if isinstance(f.default, int):
            ranged = rf"{f.name}=\d+ is outside the allowed range [\[(].*, \d+[\])] \(of the kernels' 64-bit"
            with pytest.raises(ValueError, match=ranged):  # the field's range, its open end the largest int64
                params_cls(**{f.name: 2**63})
            continue
        for infinite in (math.inf, -math.inf, 10**400):
            with pytest.raises(ValueError, match=f"{f.name}=.* allowed range"):
                params_cls(**{f.name: infinite})


EMPTIED_RANGES = [
    ("Aircraft-v0", {"floor_altitude": 2000.0}, "altitude_min=1000.0", "[floor_altitude=2000.0, altitude_max=1600.0]",
     "floor_altitude must not exceed altitude_max"),
    ("Aircraft-v0", {"min_speed": 160.0}, "speed_demand_min=90.0", "[min_speed=160.0, speed_demand_max=150.0]",
     "min_speed must not exceed speed_demand_max"),
    ("Aircraft-v0", {"max_speed": 80.0}, "speed_demand_max=150.0", "[speed_demand_min=90.0, max_speed=80.0]",
     "speed_demand_min must not exceed max_speed"),
    ("AircraftGusty-v0", {"change_interval_max": 0.5}, "change_interval_min=45.0",
     "[dt=1.0, change_interval_max=0.5]", "dt must not exceed change_interval_max"),
    ("BouncingBall-v0", {"radius": 3.0}, "target_min=0.5", "(radius=3.0, target_max=2.5]",
     "radius must be below target_max"),
    ("BouncingBall-v0", {"drop_height": 0.4}, "target_max=2.5", "[target_min=0.5, drop_height=0.4]",
     "target_min must not exceed drop_height"),
    ("Projectile-v0", {"radius": 30.0}, "launch_height_min=1.0", "[radius=30.0, launch_height_max=20.0]",
     "radius must not exceed launch_height_max"),
    ("Billiards-v0", {"radius_a": 1.5}, "ball_distance_min=0.3",
     "(radius_a + radius_b = 1.52858, ball_distance_max=1.2]", "radius_a + radius_b must be below ball_distance_max"),
    ("Suspension-v0", {"mass": 1e9}, "modulus=8000.0", "(mass * gravity = 1e+09 * 9.81 = 9.81e+09, 1e+09]",
     "mass * gravity must be below 1e+09"),
    ("PendulumPump-v0", {"dt": 30.0}, "change_interval_min=10.0", "[dt=30.0, change_interval_max=20.0]",
     "dt must not exceed change_interval_max"),
]  # fmt: skip


@pytest.mark.parametrize(("env_id", "params", "blamed", "allowed", "conflict"), EMPTIED_RANGES)
def test_a_range_that_the_changed_parameter_leaves_empty_says_which_bounds_conflict(
    env_id: str, params: dict[str, float], blamed: str, allowed: str, conflict: str
) -> None:
    """A parameter that bounds another one's range (floor_altitude, altitude_min's lower end) can leave that range
    empty: the error names the other parameter, as the first check that fails, so it also says that no value of it
    fits and which of the bounds, the parameters to change, conflict (it showed an empty range without saying so,
    and some bounds without their values)."""
    with pytest.raises(ValueError) as error:
        gym.make(f"vegym/{env_id}", **params)
    assert str(error.value).startswith(f"{blamed} is outside the allowed range {allowed} (an empty range: {conflict})")


def test_a_range_that_other_parameters_leave_open_to_a_value_says_nothing_of_conflicts() -> None:
    with pytest.raises(ValueError) as error:
        gym.make("vegym/Aircraft-v0", altitude_min=1700.0)
    assert str(error.value) == (
        "altitude_min=1700.0 is outside the allowed range [floor_altitude=0.0, altitude_max=1600.0]"
    )


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_float_parameters_lie_within_the_magnitudes_the_models_compute_with(env_id: str) -> None:
    """Every float parameter's range ends by 1e9 in magnitude and a positive one's starts at 1e-9: beyond them the
    models overflowed or underflowed into inf or NaN observations (gravity 1e-200, speeds 1e155, a yaw rate of
    1e25 rad/s; a helper's fuzzing)."""
    params_cls = gym.make(env_id).unwrapped.task.params_cls
    for f in dataclasses.fields(params_cls):
        if isinstance(f.default, float):
            low, high = f.metadata["low"], f.metadata["high"]
            assert -LARGEST <= low and high <= LARGEST, f.name
            assert low >= SMALLEST or (low <= 0.0 and not f.metadata["low_open"]), f.name
            for beyond in (2 * LARGEST, -2 * LARGEST, 0.5 * SMALLEST):
                if not low <= beyond <= high:
                    with pytest.raises(ValueError, match=rf"{f.name}=.* is outside the allowed range \["):
                        params_cls(**{f.name: beyond})


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_each_float_parameter_at_an_end_of_its_range_keeps_observations_finite_and_in_the_box(env_id: str) -> None:
    """Each float parameter alone at each end of its range (1e-9 and 1e9 where no other bound applies; the
    values a cross-field check refuses are skipped): 50 steps of full and random actions observe finite values
    inside the observation space and finite rewards, without a warning."""
    params_cls = gym.make(env_id).unwrapped.task.params_cls
    registered = gym.spec(env_id).kwargs
    rng_actions = np.random.default_rng(0)
    tried = 0
    for f in dataclasses.fields(params_cls):
        if not isinstance(f.default, float):
            continue
        for end in (f.metadata["low"], f.metadata["high"]):
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                try:
                    env = gym.make(env_id, **{**registered, f.name: end})
                except ValueError:
                    continue  # another parameter's range depends on this one
                tried += 1
                obs, _ = env.reset(seed=0)
                for t in range(50):
                    sign = (1.0, -1.0, None)[t % 3]
                    shape = env.action_space.shape
                    action = rng_actions.uniform(-1, 1, shape) if sign is None else np.full(shape, sign)
                    obs, reward, terminated, truncated, _ = env.step(action.astype(np.float32))
                    assert env.observation_space.contains(obs) and math.isfinite(reward), (f.name, end, t, obs)
                    if terminated or truncated:
                        obs, _ = env.reset()
                        assert env.observation_space.contains(obs), (f.name, end, obs)
    assert tried > 0


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_numpy_numbers_are_taken_as_parameters_and_stored_as_python_numbers(env_id: str) -> None:
    params_cls = gym.make(env_id).unwrapped.task.params_cls
    numpy_types = {bool: np.bool_, int: np.int64, float: np.float32}
    defaults = {f.name: f.default for f in dataclasses.fields(params_cls)}
    given = {name: numpy_types[type(value)](value) for name, value in defaults.items()}
    params = params_cls(**given)
    for name, value in defaults.items():
        assert type(getattr(params, name)) is type(value)
        assert getattr(params, name) == pytest.approx(value, rel=1e-7)  # float32 rounds the floats


def test_vector_env_takes_numpy_counts_and_refuses_non_integer_ones() -> None:
    vector_cls = type(gym.make_vec(ENV_IDS[0], num_envs=1, vectorization_mode="vector_entry_point"))
    vec = vector_cls(num_envs=np.int64(3), max_episode_steps=np.int32(5))
    assert (vec.num_envs, vec.max_episode_steps) == (3, 5) and type(vec.num_envs) is int
    for name, bad in [("num_envs", 2.0), ("num_envs", True), ("max_episode_steps", 2.5), ("max_episode_steps", "3")]:
        with pytest.raises(ValueError, match=f"{name}="):
            vector_cls(**{"num_envs": 2, name: bad})


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_every_parameter_is_listed_with_its_default_in_the_env_docstrings_arguments(env_id: str) -> None:
    env_cls = type(gym.make(env_id).unwrapped)
    arguments = env_cls.__doc__.split("## Arguments")[1].split("## Version History")[0]
    for field in dataclasses.fields(env_cls.task_cls.params_cls):
        assert f"* {field.name} (default {field.default!r} in " in arguments, field.name


def test_infinite_bounds_are_allowed_only_where_a_parameter_says_so() -> None:
    from vegym.physics.aircraft import AircraftParams

    assert AircraftParams(floor_altitude=-math.inf).floor_altitude == -math.inf
    assert AircraftParams().ceiling_altitude == math.inf
    assert "ceiling_altitude (default inf in [-inf, inf])" in AircraftParams.describe()
    with pytest.raises(ValueError, match=r"wind_x=inf is outside the allowed range \[-1e\+09, 1e\+09\]"):
        AircraftParams(wind_x=math.inf)


ONE_FRAME_PER_SECOND = {"vegym/Projectile-v0", "vegym/ProjectileAdjust-v0", "vegym/Billiards-v0"}
"""Envs whose step is a whole shot or strike: no control rate, shown at 1 frame per second."""


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_render_fps_is_the_steps_per_simulated_second(env_id: str) -> None:
    """Fixed-step envs: 1 / dt. BouncingBall steps once per bounce: its rate is that of a bounce to the middle
    target, within 10% of the reference controller's average over 20 episodes (simulated time from the state)."""
    env = gym.make(env_id)
    fps = env.metadata["render_fps"]
    if env_id in ONE_FRAME_PER_SECOND:
        assert fps == 1.0
    elif env_id == "vegym/BouncingBall-v0":
        controller, steps, seconds = controller_for(env), 0, 0.0
        for seed in range(20):
            obs, _ = env.reset(seed=seed)
            done = False
            while not done:
                obs, _, terminated, truncated, _ = env.step(controller.predict(obs)[0])
                steps, done = steps + 1, terminated or truncated
            seconds += float(env.unwrapped.state["time"][0])
        assert fps == pytest.approx(steps / seconds, rel=0.1)
    else:
        assert fps == 1.0 / env.unwrapped.params.dt


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_rgb_array_frames_are_uint8_images(env_id: str) -> None:
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    frames = [env.render()]
    for action in random_actions(env_id, 3, seed=6):
        _, _, terminated, truncated, _ = env.step(action)
        frames.append(env.render())
        if terminated or truncated:
            break
    for frame in frames:
        assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
        assert frame.min() < frame.max()
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(env)).render(), frames[-1])


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_info_carries_reward_terms_that_sum_to_the_reward(env_id: str) -> None:
    env = gym.make(env_id)
    env.reset(seed=0)
    for action in random_actions(env_id, 20, seed=7):
        _, reward, terminated, truncated, info = env.step(action)
        assert "is_success" in info and isinstance(info["is_success"], bool)
        assert math.isclose(sum(info["reward_terms"].values()), reward, rel_tol=1e-9, abs_tol=1e-12)
        if terminated or truncated:
            env.reset()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_only_human_mode_initialises_a_display(env_id: str) -> None:
    import pygame

    pygame.display.quit()
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    env.render()
    assert not pygame.display.get_init()
    human = gym.make(env_id, render_mode="human")
    human.reset(seed=0)
    assert pygame.display.get_init()
    human.close()
    assert not pygame.display.get_init()


def test_registration_works_in_spawned_subprocess_workers() -> None:
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv

    env_id = f"vegym:{ENV_IDS[0]}"
    vec = make_vec_env(env_id, n_envs=2, seed=0, vec_env_cls=SubprocVecEnv, vec_env_kwargs={"start_method": "spawn"})
    try:
        obs = vec.reset()
        assert obs.shape == (2, *gym.spec(ENV_IDS[0]).make().observation_space.shape)
        vec.step(np.zeros((2, *vec.action_space.shape), dtype=np.float32))
    finally:
        vec.close()
