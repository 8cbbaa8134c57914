"""Renderers: scene decorations (grid lines, labels, gear teeth) stay few however large the scene."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vegym  # noqa: F401
from vegym.render import canvas
from vegym.render.gear_train import MOST_TEETH, TOOTH_PITCH, gear_outline


def test_tick_step_keeps_the_finest_spacing_when_few_and_steps_1_2_5_otherwise() -> None:
    assert canvas.tick_step(20.0, 5.0, 20) == 5.0
    assert canvas.tick_step(3.0, 0.5, 12) == 0.5
    assert [canvas.tick_step(extent, 1.0, 10) for extent in (15.0, 45.0, 95.0, 150.0)] == [2.0, 5.0, 10.0, 20.0]
    for extent in (1e3, 1e7, 1e12):
        step = canvas.tick_step(extent, 0.5, 12)
        assert extent / step <= 12 < extent / (step / 2.0)


def test_gear_teeth_keep_their_pitch_up_to_a_cap() -> None:
    radius = 0.08
    assert len(gear_outline(radius, 0.0, 0.004)) == 4 * round(2.0 * np.pi * radius / TOOTH_PITCH)
    assert len(gear_outline(1000.0, 0.0, 1.0)) == 4 * MOST_TEETH


@pytest.mark.parametrize(
    ("env_id", "params"),
    [
        ("vegym/GearTrain-v0", {"radius_min": 1000.0, "radius_max": 1000.0}),
        ("vegym/SteerableWheel-v0", {"arena_size": 1e7}),
        ("vegym/BouncingBall-v0", {"drop_height": 1e7}),
    ],
)
def test_huge_scenes_draw_their_frames(env_id: str, params: dict) -> None:
    env = gym.make(env_id, render_mode="rgb_array", **params)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
