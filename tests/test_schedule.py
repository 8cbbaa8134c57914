"""The demand schedule (vegym.envs.schedule) and the step kernels that hand out its demands as their last work."""

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
    np.testing.assert_array_equal(schedule.next_change(keys, 2, 5), reference_change_steps(schedule, keys, 2, 5))


@pytest.mark.parametrize(("interval", "steps"), [(2.5, 2), (3.5, 4), (4.5, 4)])
def test_an_interval_half_way_between_steps_rounds_to_the_even_step(interval: float, steps: int) -> None:
    schedule = ChangeSchedule.planned(interval, interval, 1.0, episode_steps=100, final_hold=0.0, stream=3)
    keys = rng.seed_keys(np.arange(10))
    np.testing.assert_array_equal(schedule.next_change(keys, np.arange(10), 7), 7 + steps)


def test_counters_of_another_length_than_the_keys_are_refused() -> None:
    schedule = ChangeSchedule.planned(1.0, 2.0, 0.1, episode_steps=60, final_hold=1.0, stream=3)
    with pytest.raises(ValueError, match="broadcast"):
        schedule.next_change(rng.seed_keys(np.arange(20)), np.arange(5), 0)


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
def test_changes_come_when_due_and_each_episode_holds_the_demand_of_its_number_and_awaits_the_next(
    env_id: str, name: str, reference: Callable[[Any, np.ndarray, np.ndarray], np.ndarray]
) -> None:
    env = gym.make_vec(env_id, num_envs=300, vectorization_mode="vector_entry_point")
    env.action_space.seed(0)
    env.reset(seed=4)
    task, state = env.unwrapped.task, env.unwrapped.state
    changed = 0
    for _ in range(task.params.episode_steps + 5):  # past the end: the restarts draw demand 0 again
        before, due = state["changes"].copy(), state["next_change"].copy()
        env.step(env.action_space.sample())
        now = state["step"]
        going_on = now > 0  # not restarted by this step
        changing = going_on & (due <= now)  # a change exactly when due, to the next demand number, handed out now
        np.testing.assert_array_equal(state["changes"][going_on], (before + changing)[going_on])
        np.testing.assert_array_equal(state["last_change"][changing], now[changing])
        changed += int(np.sum(changing))
        index = state["changes"]
        np.testing.assert_array_equal(state[name], reference(task, state["key"], index))
        np.testing.assert_array_equal(
            state["next_change"], reference_change_steps(task.schedule, state["key"], index, state["last_change"])
        )
    assert changed > 300


def test_a_schedule_holds_its_demand_through_final_hold_rounded_up_to_whole_steps() -> None:
    """final_hold = 1 s at dt = 0.7 s covers the last two steps (1.4 s): changes stop after step 98 of 100."""
    assert ChangeSchedule.planned(5.0, 10.0, 0.7, 100, 1.0, stream=3).last_step == 98
    assert ChangeSchedule.planned(5.0, 10.0, 0.5, 100, 1.0, stream=3).last_step == 98


def test_a_change_interval_shorter_than_a_step_is_refused() -> None:
    with pytest.raises(ValueError, match=r"change_interval_min=5.0 is outside the allowed range \[dt=10.0"):
        ChangeSchedule.planned(5.0, 20.0, 10.0, 100, 0.0, stream=3)
