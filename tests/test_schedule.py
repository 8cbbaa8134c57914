"""The demand schedule (vegym.envs.schedule) and the after-step kernels that hand out its demands."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import vegym  # noqa: F401  (registers the envs)
from vegym import rng
from vegym.envs import aircraft, pendulum_pump
from vegym.envs.schedule import NO_CHANGE, ChangeSchedule


def reference_change_steps(
    schedule: ChangeSchedule, keys: np.ndarray, index: np.ndarray, now: np.ndarray
) -> np.ndarray:
    """The documented rule in numpy: an interval uniform in [interval_min, interval_max] s from the key's schedule
    stream at counter ``index``, rounded (half to even) to at least one step; no change after ``last_step``."""
    seconds = rng.uniform_in(keys, schedule.stream, schedule.interval_min, schedule.interval_max, counter=index)
    at = now + np.maximum(np.round(seconds[:, 0] / schedule.dt).astype(np.int64), 1)
    return np.where(at <= schedule.last_step, at, NO_CHANGE)


def test_change_steps_are_the_seeded_intervals_rounded_to_steps() -> None:
    schedule = ChangeSchedule.planned(0.3, 2.0, 0.1, episode_steps=60, final_hold=1.0, stream=3)
    n = 4000
    keys = rng.seed_keys(np.arange(n))
    index = np.arange(n) % 7
    now = np.arange(n) % 55
    steps = schedule.next_change(keys, index, now)
    np.testing.assert_array_equal(steps, reference_change_steps(schedule, keys, index, now))
    assert np.any(steps == NO_CHANGE) and np.any(steps != NO_CHANGE)


def aircraft_demands(task: aircraft.AircraftTask, keys: np.ndarray, index: np.ndarray) -> np.ndarray:
    p = task.params
    u = rng.uniform(keys, aircraft._DEMAND_STREAM, 3, counter=index)
    return np.stack(
        [
            p.altitude_min + (p.altitude_max - p.altitude_min) * u[:, 0],
            p.speed_demand_min + (p.speed_demand_max - p.speed_demand_min) * u[:, 1],
            np.pi * (2.0 * u[:, 2] - 1.0),
        ],
        axis=-1,
    )


def pendulum_targets(task: pendulum_pump.PendulumPumpTask, keys: np.ndarray, index: np.ndarray) -> np.ndarray:
    p = task.params
    return rng.uniform_in(keys, pendulum_pump._TARGET_STREAM, p.target_min, p.target_max, counter=index)[:, 0]


@pytest.mark.parametrize(
    ("env_id", "name", "reference"),
    [
        ("vegym/Aircraft-v0", "demand", aircraft_demands),
        ("vegym/AircraftGusty-v0", "demand", aircraft_demands),
        ("vegym/PendulumPump-v0", "target", pendulum_targets),
    ],
)
def test_every_episode_holds_the_demand_of_its_number_and_awaits_the_change_after_it(
    env_id: str, name: str, reference: Callable[[Any, np.ndarray, np.ndarray], np.ndarray]
) -> None:
    env = gym.make_vec(env_id, num_envs=300, vectorization_mode="vector_entry_point")
    env.action_space.seed(0)
    env.reset(seed=4)
    task, state = env.unwrapped.task, env.unwrapped.state
    changed = 0
    for _ in range(task.params.episode_steps + 5):  # past the end: the restarts draw demand 0 again
        before = state["changes"].copy()
        env.step(env.action_space.sample())
        changed += int(np.sum(state["changes"] > before))
        index = state["changes"]
        np.testing.assert_array_equal(state[name], reference(task, state["key"], index))
        np.testing.assert_array_equal(
            state["next_change"], reference_change_steps(task.schedule, state["key"], index, state["last_change"])
        )
    assert changed > 300
