"""PendulumPump-v0: the swinging pendulum with its target amplitude, an energy gauge, the amplitude over time."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from vegym.envs.pendulum_pump import PendulumPumpParams
from vegym.physics import pendulum
from vegym.render import canvas, clock

WIDTH, HEIGHT = 880, 480
TRAIL = 30
"""Bob positions kept for the trail (steps)."""


class PendulumPumpRenderer:
    """Records a single env's swing and draws the pendulum (theta from the downward vertical, anticlockwise)."""

    def __init__(self, params: PendulumPumpParams) -> None:
        self.params = params
        self.physics = params.physics
        self.state: dict[str, np.ndarray] = {}
        self.times: deque[float] = canvas.history()
        self.amplitudes: deque[float] = canvas.history()
        self.targets: deque[float] = canvas.history()
        self.bobs: list[np.ndarray] = []
        self.last: dict[str, Any] = {}
        self.total_reward = 0.0

    def reset(self, state: dict[str, np.ndarray]) -> None:
        self.state = {k: v[0].copy() for k, v in state.items()}
        theta, omega = self.state["theta"], self.state["omega"]
        self.times = canvas.history(0.0)
        self.amplitudes = canvas.history(
            float(pendulum.energy_amplitude(pendulum.energy(theta, omega, self.physics), self.physics))
        )
        self.targets = canvas.history(float(self.state["target"]))
        self.bobs = [self._bob(float(theta))]
        self.last = {}
        self.total_reward = 0.0

    def record(self, state: dict[str, np.ndarray], info: dict[str, Any]) -> None:
        self.state = {k: v[0].copy() for k, v in state.items()}
        self.times.append(self.times[-1] + info["dt"])
        self.amplitudes.append(info["amplitude"])
        self.targets.append(info["target_amplitude"])
        self.bobs = [*self.bobs[-TRAIL:], self._bob(info["angle"])]
        self.last = info
        self.total_reward += sum(info["reward_terms"].values())

    def _bob(self, theta: float) -> np.ndarray:
        return self.params.length * np.array([np.sin(theta), -np.cos(theta)])

    def draw(self) -> np.ndarray:
        surface = canvas.new_surface(WIDTH, HEIGHT)
        self._pendulum(surface)
        self._energy(surface)
        self._amplitude_chart(surface)
        self._numbers(surface)
        clock.draw_clock(surface, self.times[-1], (WIDTH - clock.CORNER, clock.CORNER), clock.RADIUS)
        return canvas.to_array(surface)

    def _pendulum(self, surface: Any) -> None:
        p = self.params
        length = p.length
        reach = 1.2 * length
        panel = canvas.Panel(surface, (15, 70, 390, 390), (-reach, reach, -reach, reach), equal_aspect=True)
        panel.frame(canvas.LIGHT)
        panel.circle((0.0, 0.0), length, canvas.LIGHT, 1)
        target = float(self.state["target"])
        arc = np.linspace(-target, target, 61)
        panel.polyline(0.85 * length * np.stack([np.sin(arc), -np.cos(arc)], -1), canvas.ORANGE, 3)
        for side in (-target, target):
            panel.dashed((0.0, 0.0), self._bob(side), canvas.ORANGE, dashes=8)
        amplitude = self.amplitudes[-1]
        arc = np.linspace(-amplitude, amplitude, 61)
        panel.polyline(0.75 * length * np.stack([np.sin(arc), -np.cos(arc)], -1), canvas.BLUE, 2)
        panel.polyline(np.array(self.bobs), canvas.GREY, 1)
        bob = self.bobs[-1]
        panel.line((0.0, 0.0), bob, canvas.BLACK, 3)
        panel.circle(bob, 0.07 * length, canvas.RED)
        panel.dot((0.0, 0.0), 5, canvas.BLACK)
        if self.last and self.last["torque"] != 0.0:
            share = self.last["torque"] / p.max_torque
            sweep = np.linspace(0.0, 2.2 * share, 30) - np.pi / 2
            curve = 0.25 * length * np.stack([np.cos(sweep), np.sin(sweep)], -1)
            panel.polyline(curve, canvas.GREEN, 3)
            tangent = (curve[-1] - curve[-2]) / np.hypot(*(curve[-1] - curve[-2]))
            panel.arrow(curve[-2], 0.05 * length * tangent, canvas.GREEN, 3)
        canvas.text(
            surface,
            ["orange: target amplitude", "blue: amplitude of the energy", "green: torque"],
            (19, 74),
            16,
            canvas.GREY,
        )

    def _energy(self, surface: Any) -> None:
        full = 2.0 * self.physics.weight_moment
        theta, omega = self.state["theta"], self.state["omega"]
        kinetic = float(0.5 * self.physics.inertia * omega * omega)
        potential = float(pendulum.energy(theta, 0.0, self.physics))
        target = float(pendulum.amplitude_energy(self.state["target"], self.physics))
        panel = canvas.Panel(surface, (440, 90, 60, 330), (0.0, 1.0, 0.0, full))
        panel.frame(canvas.GREY)
        panel.polygon(
            np.array([[0.1, 0.0], [0.9, 0.0], [0.9, min(potential, full)], [0.1, min(potential, full)]]), canvas.BLUE
        )
        top = min(potential + kinetic, full)
        panel.polygon(
            np.array([[0.1, min(potential, full)], [0.9, min(potential, full)], [0.9, top], [0.1, top]]), canvas.GREEN
        )
        panel.line((-0.1, target), (1.1, target), canvas.ORANGE, 3)
        canvas.text(surface, ["energy (J)", f"{full:.1f}"], (430, 50), 16, canvas.GREY)
        canvas.text(surface, ["0", "blue: potential", "green: kinetic", "orange: target"], (440, 425), 15, canvas.GREY)

    def _amplitude_chart(self, surface: Any) -> None:
        p = self.params
        horizon = max(p.episode_steps * p.dt, self.times[-1])
        t = np.array(self.times)
        panel = canvas.Panel(surface, (540, 90, 320, 330), (0.0, horizon, 0.0, 180.0))
        panel.frame(canvas.LIGHT)
        for degrees in (45.0, 90.0, 135.0):
            panel.line((0.0, degrees), (horizon, degrees), canvas.LIGHT)
            _, y = panel.to_px(0.0, degrees)
            canvas.text(surface, [f"{degrees:.0f}"], (544, y - 14), 15, canvas.GREY)
        panel.polyline(np.stack([t, np.degrees(self.targets)], -1), canvas.ORANGE, 2)
        panel.polyline(np.stack([t, np.degrees(self.amplitudes)], -1), canvas.BLUE, 2)
        canvas.text(surface, ["amplitude (deg): blue, target: orange", "180"], (540, 50), 16, canvas.GREY)
        canvas.axis_ticks(surface, panel, 0.0, horizon, 0.0, 1.0)
        canvas.text(surface, ["time (s)"], (540, 440), 16, canvas.GREY)

    def _numbers(self, surface: Any) -> None:
        lines = [
            f"t = {self.times[-1]:.2f} s   amplitude {np.degrees(self.amplitudes[-1]):.1f} deg"
            f"   target {np.degrees(float(self.state['target'])):.1f} deg   return {self.total_reward:+.3f}"
        ]
        if self.last:
            verdict = "on target" if self.last["is_success"] else "off target"
            lines[0] += f"   {verdict}"
        canvas.text(surface, lines, (12, 10), 22)
