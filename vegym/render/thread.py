"""Thread-v0: the thread with its rest shape and actuator forces, and the energy left on a log scale."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from vegym.envs.thread import ThreadEnvParams
from vegym.physics import thread
from vegym.render import canvas, clock

WIDTH, HEIGHT = 880, 560
FORCE_LENGTH = 0.15
"""Drawn length (m) of an arrow for a force of ``max_force``."""
LOG_FLOOR = -4.0
"""Lowest log10 of the energy fraction shown."""
HORIZON = 2.0
"""Seconds the energy chart spans at first; it widens as the episode goes on."""


class ThreadRenderer:
    """Records a single env's thread and draws it to scale (x along the span, y up) with its energy history."""

    def __init__(self, params: ThreadEnvParams) -> None:
        self.params = params
        self.physics = params.physics
        self.rest = thread.static_equilibrium(self.physics)
        self.actuated = params.actuated
        self.state: dict[str, np.ndarray] = {}
        self.times: deque[float] = canvas.history()
        self.fractions: deque[float] = canvas.history()
        self.last: dict[str, Any] = {}
        self.total_reward = 0.0

    def reset(self, state: dict[str, np.ndarray]) -> None:
        self.state = {k: v[0].copy() for k, v in state.items()}
        self.times, self.fractions = canvas.history(0.0), canvas.history(1.0)
        self.last = {}
        self.total_reward = 0.0

    def record(self, state: dict[str, np.ndarray], info: dict[str, Any]) -> None:
        self.state = {k: v[0].copy() for k, v in state.items()}
        self.times.append(self.times[-1] + info["dt"])
        self.fractions.append(info["energy_fraction"])
        self.last = info
        self.total_reward += sum(info["reward_terms"].values())

    def draw(self) -> np.ndarray:
        surface = canvas.new_surface(WIDTH, HEIGHT)
        self._thread(surface)
        self._energy(surface)
        self._numbers(surface)
        clock.draw_clock(surface, self.times[-1], (WIDTH - clock.CORNER, clock.CORNER), clock.RADIUS)
        return canvas.to_array(surface)

    def _thread(self, surface: Any) -> None:
        p = self.params
        reach = p.pluck_max + FORCE_LENGTH
        low = min(float(self.rest[:, 1].min()), 0.0) - reach
        world = (-0.05 * p.span, 1.05 * p.span, low, reach)
        panel = canvas.Panel(surface, (15, 80, 850, 300), world, equal_aspect=True)
        panel.frame(canvas.LIGHT)
        ends = self.physics.ends
        rest = np.concatenate([ends[:1], self.rest, ends[1:]])
        panel.polyline(rest, canvas.LIGHT, 2)
        positions = self.state["positions"]
        chain = np.concatenate([ends[:1], positions, ends[1:]])
        _, lengths = thread.spring_forces(positions[None], self.physics)
        for j, length in enumerate(lengths[0]):
            stretched = length > p.natural_length
            panel.line(chain[j], chain[j + 1], canvas.BLACK if stretched else canvas.ORANGE, 3)
        for end in ends:
            panel.polygon(end + np.array([[0.0, 0.0], [-0.025, 0.04], [0.025, 0.04]]) * p.span, canvas.GREY)
        for i, point in enumerate(positions):
            panel.dot(point, 6 if i in self.actuated else 4, canvas.BLUE if i in self.actuated else canvas.BLACK)
        if self.last:
            for k, node in enumerate(self.actuated):
                force = np.asarray(self.last["forces"])[k]
                panel.arrow(positions[node], FORCE_LENGTH * force / p.max_force, canvas.GREEN, 3)
        canvas.text(
            surface,
            ["to scale (m); grey: rest shape; blue: actuated nodes; green: forces; orange: a slack spring"],
            (19, 84),
            16,
            canvas.GREY,
        )

    def _energy(self, surface: Any) -> None:
        p = self.params
        horizon = max(HORIZON, self.times[-1])
        t = np.array(self.times)
        logs = np.log10(np.clip(self.fractions, 10.0**LOG_FLOOR, None))
        panel = canvas.Panel(surface, (60, 420, 800, 100), (0.0, horizon, LOG_FLOOR, 0.5))
        panel.frame(canvas.LIGHT)
        for decade in range(int(LOG_FLOOR), 1):
            panel.line((0.0, decade), (horizon, decade), canvas.LIGHT)
        settle = np.log10(p.settle_fraction)
        panel.dashed((0.0, settle), (horizon, settle), canvas.GREEN)
        panel.polyline(np.stack([t, np.minimum(logs, 0.5)], -1), canvas.BLUE, 2)
        canvas.text(
            surface,
            [f"energy left (fraction of the initial excess, log scale); green: settled at {p.settle_fraction:g}"],
            (60, 398),
            16,
            canvas.GREY,
        )
        for decade in range(int(LOG_FLOOR), 1):
            _, y = panel.to_px(0.0, decade)
            canvas.text(surface, [f"1e{decade}" if decade else "1"], (22, y - 6), 15, canvas.GREY)
        canvas.axis_ticks(surface, panel, 0.0, horizon, LOG_FLOOR, 0.1)
        canvas.text(surface, ["time (s)"], (60, 538), 16, canvas.GREY)

    def _numbers(self, surface: Any) -> None:
        line = f"t = {self.times[-1]:.2f} s   energy left {self.fractions[-1]:.2%}   return {self.total_reward:+.3f}"
        if self.last and self.last["is_success"]:
            line += "   settled"
        canvas.text(surface, [line], (12, 10), 22)
        canvas.text(surface, [f"excess energy {float(self.state['excess']) * 1e3:.2f} mJ"], (12, 40), 18)
