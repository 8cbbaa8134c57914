"""Side view of BouncingBall-v0: height over time, the flights so far, the targets, the numbers."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from vegym.envs.bouncing_ball import BouncingBallParams
from vegym.render import canvas, clock

WIDTH, HEIGHT = 640, 400
SHOWN_FLIGHTS = 30
"""The flights drawn: the latest ones (a long episode's whole history would fill the panel)."""
AHEAD = 0.3
"""Share of the time axis ahead of the ball, where the shown targets are marked."""


class BouncingBallRenderer:
    """Records each bounce of a single env and draws the episode so far: its latest :data:`SHOWN_FLIGHTS` flights."""

    def __init__(self, params: BouncingBallParams) -> None:
        self.params = params
        # (t_impact, rebound speed, apex, target) of the latest flights: one more than shown, to tell whether the
        # first one shown is the episode's
        self.flights: deque[tuple[float, float, float, float]] = deque(maxlen=SHOWN_FLIGHTS + 1)
        self.bounces = 0
        self.first_impact = 0.0
        self.time = 0.0
        self.targets: np.ndarray = np.zeros(0)
        self.last: dict[str, Any] = {}

    def reset(self, state: dict[str, np.ndarray]) -> None:
        self.flights = deque(maxlen=SHOWN_FLIGHTS + 1)
        self.bounces = 0
        self.first_impact = self.time = float(state["time"][0])
        self.targets = state["targets"][0].copy()
        self.last = {}

    def record(self, state: dict[str, np.ndarray], info: dict[str, Any]) -> None:
        rebound = info["restitution"] * info["impact_speed"]
        self.flights.append((self.time, rebound, info["apex_height"], info["target_height"]))
        self.bounces += 1
        self.time = float(state["time"][0])
        self.targets = state["targets"][0].copy()
        self.last = info

    def draw(self) -> np.ndarray:
        p = self.params
        g, r = p.gravity, p.radius
        surface = canvas.new_surface(WIDTH, HEIGHT)
        shown = list(self.flights)[-SHOWN_FLIGHTS:]
        start_time = shown[0][0] if len(self.flights) > SHOWN_FLIGHTS else 0.0
        span = max((self.time - start_time) / (1.0 - AHEAD), 4.0)
        resting = bool(self.flights) and self.flights[-1][1] < p.rest_speed  # the episode has terminated
        world = (start_time, start_time + span, 0.0, p.drop_height * 1.08)
        panel = canvas.Panel(surface, (50, 60, WIDTH - 70, HEIGHT - 90), world)
        panel.frame(canvas.LIGHT)
        panel.line((start_time, 0), (start_time + span, 0), canvas.BLACK, 2)
        if start_time == 0.0:  # the drop, before the first impact, while it is in view
            drop = np.linspace(0.0, self.first_impact, 30)
            panel.polyline(np.stack([drop, p.drop_height - 0.5 * g * drop**2], -1), canvas.BLUE)
        for start, speed, apex, target in shown:
            duration = 2.0 * speed / g
            if duration > 0:
                t = np.linspace(0.0, duration, 40)
                panel.polyline(np.stack([start + t, r + speed * t - 0.5 * g * t * t], -1), canvas.BLUE)
            end = start + max(duration, 0.15)
            panel.dashed((start, target), (end, target), canvas.ORANGE, dashes=4)
            panel.dot((start + 0.5 * duration, apex), 3, canvas.BLUE)
        spacing = AHEAD * span / (len(self.targets) + 0.5)  # the shown targets fill the view ahead of the ball
        for k, target in enumerate([] if resting else self.targets):
            x0 = self.time + spacing * k
            panel.line(
                (x0, target), (x0 + 0.8 * spacing, target), canvas.RED if k == 0 else canvas.ORANGE, 3 if k == 0 else 1
            )
        panel.dot((self.time, r), max(3, round(panel.scale[1] * r)), canvas.BLUE)  # sized on the height axis
        for h in np.arange(0.0, p.drop_height * 1.05, canvas.tick_step(p.drop_height, 0.5, 12)):
            x, y = panel.to_px(start_time, h)
            canvas.text(surface, [f"{h:.1f}"], (x - 34, y - 6), 16, canvas.GREY)
        bounce = self.bounces
        if resting:
            ahead = "at rest: episode over"
        else:
            past = ", past the planned bounces" if bounce >= p.episode_bounces else ""
            ahead = f"next target {self.targets[0]:.2f} m (red{past})"
        lines = [f"bounce {bounce} of {p.episode_bounces} planned   t = {self.time:.2f} s   {ahead}"]
        if self.last:
            lines.append(
                f"e = {self.last['restitution']:.3f}   apex {self.last['apex_height']:.3f} m   "
                f"target {self.last['target_height']:.3f} m   impact {self.last['impact_speed']:.2f} m/s"
            )
        canvas.text(surface, lines, (12, 10), 20)
        clock.draw_clock(surface, self.time, (WIDTH - clock.CORNER, clock.CORNER), clock.RADIUS)
        canvas.text(
            surface, ["height of centre (m) over time (s); dashes: targets"], (12, HEIGHT - 24), 16, canvas.GREY
        )
        return canvas.to_array(surface)
