"""Suspension-v0: side view of the quarter-car on its terrain, strip charts of acceleration and travel, numbers."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from vegym.envs.suspension import SuspensionParams
from vegym.physics import suspension
from vegym.render import canvas, clock

WIDTH, HEIGHT = 900, 520
WINDOW = 4.0
"""Half-width (m) of the road shown around the wheel."""
WHEEL_PIXELS = 22
"""Drawn wheel radius (pixels); the model's wheel follows the terrain with its axle, radius aside."""
BODY_HEIGHT = 0.15
"""Drawn height of the body block (m) on top of the spring."""
HISTORY = 5.0
"""Seconds shown by the strip charts."""


class SuspensionRenderer:
    """Records a single env's drive and draws the car (vertical scale exaggerated) with recent history."""

    def __init__(self, params: SuspensionParams) -> None:
        self.params = params
        self.state: dict[str, np.ndarray] = {}
        self.times: deque[float] = canvas.history()
        self.accelerations: deque[float] = canvas.history()
        self.travels: deque[float] = canvas.history()
        self.last: dict[str, Any] = {}
        self.total_reward = 0.0

    def reset(self, state: dict[str, np.ndarray]) -> None:
        self.state = {k: v[:1].copy() for k, v in state.items()}
        self.times, self.accelerations, self.travels = canvas.history(0.0), canvas.history(0.0), canvas.history(0.0)
        self.last = {}
        self.total_reward = 0.0

    def record(self, state: dict[str, np.ndarray], info: dict[str, Any]) -> None:
        self.state = {k: v[:1].copy() for k, v in state.items()}
        self.times.append(self.times[-1] + info["dt"])
        self.accelerations.append(info["body_acceleration"])
        self.travels.append(info["travel"])
        self.last = info
        self.total_reward += sum(info["reward_terms"].values())

    def draw(self) -> np.ndarray:
        surface = canvas.new_surface(WIDTH, HEIGHT)
        self._car(surface)
        self._strips(surface)
        self._numbers(surface)
        clock.draw_clock(surface, self.times[-1], (WIDTH - clock.CORNER, clock.CORNER), clock.RADIUS)
        return canvas.to_array(surface)

    def _car(self, surface: Any) -> None:
        p, s = self.params, self.state
        x = float(s["distance"][0])
        base = float(s["base"][0])
        height = float(s["height"][0])
        world = (x - WINDOW, x + WINDOW, base - 0.25, base + p.static_length + BODY_HEIGHT + 0.2)
        panel = canvas.Panel(surface, (15, 90, 470, 400), world)
        panel.frame(canvas.LIGHT)
        wheel_radius = WHEEL_PIXELS / panel.scale[1]
        road = np.linspace(x - WINDOW, x + WINDOW, 241)
        terrain, _ = suspension.terrain(road, s["amplitude"], s["wavenumber"], s["phase"])  # one row: every x
        ground = np.stack([road, terrain - s["offset"][0] - wheel_radius], -1)
        panel.polygon(np.concatenate([ground, [[road[-1], world[2]], [road[0], world[2]]]]), canvas.LIGHT)
        panel.polyline(ground, canvas.BLACK, 2)
        arm = 0.5
        panel.line((x - arm, base), (x + arm, base), canvas.BLACK, 4)
        canvas.pygame.draw.circle(surface, canvas.BLACK, panel.to_px(x, base), WHEEL_PIXELS, 4)
        panel.dot((x, base), 4, canvas.BLACK)
        self._spring(panel, x - arm + 0.1, base, height)
        self._damper(panel, x + arm - 0.1, base, height)
        for sign in (-1.0, 1.0):
            stop = base + p.static_length + sign * p.travel_limit
            panel.line((x - 1.35, stop), (x - 1.05, stop), canvas.RED, 3)
        top = height + BODY_HEIGHT
        panel.polygon(np.array([[x - 1.0, height], [x + 1.0, height], [x + 1.0, top], [x - 1.0, top]]), canvas.BLUE)
        canvas.text(surface, ["side view (vertical scale exaggerated)", "red: bump stops"], (19, 94), 16, canvas.GREY)

    @staticmethod
    def _spring(panel: canvas.Panel, x: float, bottom: float, top: float) -> None:
        ys = np.linspace(bottom, top, 26)
        xs = np.full_like(ys, x)
        xs[2:-2] += 0.12 * np.where(np.arange(2, 24) % 2 == 0, 1.0, -1.0)
        panel.polyline(np.stack([xs, ys], -1), canvas.BLACK, 2)

    @staticmethod
    def _damper(panel: canvas.Panel, x: float, bottom: float, top: float) -> None:
        middle = 0.5 * (bottom + top)
        panel.line((x, bottom), (x, middle + 0.05), canvas.BLACK, 3)
        body = np.array([[x - 0.1, middle - 0.06], [x + 0.1, middle - 0.06], [x + 0.1, middle + 0.08]])
        panel.polygon(np.concatenate([body, [[x - 0.1, middle + 0.08]]]), canvas.ORANGE)
        panel.line((x, middle + 0.02), (x, top), canvas.BLACK, 3)

    def _strips(self, surface: Any) -> None:
        p = self.params
        t = np.array(self.times)
        keep = t >= t[-1] - HISTORY
        start = max(t[-1] - HISTORY, 0.0)
        charts = [
            (
                "body acceleration (m/s^2); orange: +-comfort_rms",
                np.array(self.accelerations),
                2.0 * p.accel_scale,
                p.comfort_rms,
            ),
            (
                "suspension travel (cm); red: bump stops",
                100.0 * np.array(self.travels),
                150.0 * p.travel_limit,
                100.0 * p.travel_limit,
            ),
        ]
        for k, (label, values, scale, mark) in enumerate(charts):
            panel = canvas.Panel(surface, (505, 100 + 200 * k, 380, 160), (start, start + HISTORY, -scale, scale))
            panel.frame(canvas.LIGHT)
            panel.line((start, 0.0), (start + HISTORY, 0.0), canvas.LIGHT)
            color = canvas.ORANGE if k == 0 else canvas.RED
            panel.dashed((start, mark), (start + HISTORY, mark), color)
            panel.dashed((start, -mark), (start + HISTORY, -mark), color)
            panel.polyline(np.stack([t[keep], np.clip(values[keep], -scale, scale)], -1), canvas.BLUE, 2)
            canvas.text(surface, [label], (505, 80 + 200 * k), 16, canvas.GREY)
            canvas.text(surface, [f"{scale:+.3g}"], (509, 103 + 200 * k), 15, canvas.GREY)
            canvas.text(surface, [f"{-scale:+.3g}"], (509, 245 + 200 * k), 15, canvas.GREY)
        canvas.axis_ticks(surface, panel, start, start + HISTORY, -scale, 1.0)
        canvas.text(surface, [f"time (s), the last {HISTORY:.0f} s"], (505, 482), 16, canvas.GREY)

    def _numbers(self, surface: Any) -> None:
        p = self.params
        distance = float(self.state["distance"][0])
        lines = [f"t = {self.times[-1]:.2f} s   {distance:.1f} m at {p.speed:g} m/s   return {self.total_reward:+.3f}"]
        if self.last:
            span = p.damping_max - p.damping_min  # 0 for a fixed damper
            share = f" ({(self.last['damping'] - p.damping_min) / span:.0%} of the range)" if span > 0.0 else ""
            if abs(self.last["travel"]) > p.travel_limit:
                verdict = "bump stop hit"
            else:
                verdict = "comfortable so far" if self.last["is_success"] else "too uncomfortable"
            lines.append(
                f"damper c = {self.last['damping']:.0f} N s/m{share}   "
                f"RMS acceleration {self.last['rms_acceleration']:.2f} m/s^2: {verdict}"
            )
        canvas.text(surface, lines, (12, 10), 22)
