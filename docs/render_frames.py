"""Render the README's env pictures (``docs/<env>.png``): each env's analytic controller from seed 0, the frame
after a set number of steps (or the episode's last). Run: ``python docs/render_frames.py [--out DIR]``."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pygame

import vegym
from agents.analytic import controller_for

STEPS = {
    "vegym/BouncingBall-v0": 6,
    "vegym/SteerableWheel-v0": 120,
    "vegym/Aircraft-v0": 200,
    "vegym/Suspension-v0": 300,
    "vegym/PendulumPump-v0": 400,
    "vegym/Thread-v0": 20,
    "vegym/GearTrain-v0": 60,
    "vegym/ProjectileAdjust-v0": 3,
}
"""Steps before the frame, where the default (the whole episode) shows less; AircraftGusty-v0 looks as Aircraft."""


def render_frame(env_id: str, seed: int = 0) -> np.ndarray:
    """The frame of ``env_id`` under its analytic controller after ``STEPS[env_id]`` steps or the episode's end."""
    env = gym.make(env_id, render_mode="rgb_array")
    controller = controller_for(env)
    obs, _ = env.reset(seed=seed)
    for _ in range(STEPS.get(env_id, 1)):
        obs, _, terminated, truncated, _ = env.step(controller.predict(obs)[0])
        if terminated or truncated:
            break
    frame = env.render()
    env.close()
    return frame


def file_name(env_id: str) -> str:
    """``vegym/SteerableWheel-v0`` -> ``steerable_wheel.png``."""
    name = env_id.split("/")[1].removesuffix("-v0")
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower() + ".png"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).parent, help="directory of the pictures")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for env_id in vegym.ENVS:
        if env_id != "vegym/AircraftGusty-v0":
            frame = render_frame(env_id)
            pygame.image.save(pygame.surfarray.make_surface(frame.transpose(1, 0, 2)), args.out / file_name(env_id))


if __name__ == "__main__":
    main()
