"""SteerableWheel-v0: top view of the arena with waypoints and trail, a side view of the rolling wheel, numbers."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from vegym.envs.steerable_wheel import SteerableWheelParams
from vegym.physics import wheel
from vegym.physics.wheel import Pose
from vegym.render import canvas, clock

WIDTH, HEIGHT = 880, 640
SPOKES = 6
_ANGLES = np.linspace(0.0, 2.0 * np.pi, 49)


def wheel_model(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Object-space rim (49, 3) and spoke ends (SPOKES, 3) of a wheel in its xy plane, spoke 0 along +x."""
    rim = radius * np.stack([np.cos(_ANGLES), np.sin(_ANGLES), np.zeros_like(_ANGLES)], axis=-1)
    spoke = 2.0 * np.pi * np.arange(SPOKES) / SPOKES
    return rim, radius * np.stack([np.cos(spoke), np.sin(spoke), np.zeros_like(spoke)], axis=-1)


class SteerableWheelRenderer:
    """Records the path of a single env and draws the arena, the waypoints and the wheel from its model matrix.

    Top view: world x to the right and z downward, so seen from +y (right-handed, y toward the viewer) and a
    left turn (positive heading change) is anticlockwise on screen. Side view: the wheel seen from its right
    side, forward to the right, drawn from the same model matrix, so its spokes turn with the roll angle.
    """

    def __init__(self, params: SteerableWheelParams) -> None:
        self.params = params
        self.state: dict[str, np.ndarray] = {}
        self.trail: deque[np.ndarray] = canvas.history()
        self.last: dict[str, Any] = {}
        self.total_reward = 0.0

    def reset(self, state: dict[str, np.ndarray]) -> None:
        self.state = {k: v[0].copy() for k, v in state.items()}
        self.trail = canvas.history(self.state["position"])
        self.last = {}
        self.total_reward = 0.0

    def record(self, state: dict[str, np.ndarray], info: dict[str, Any]) -> None:
        self.state = {k: v[0].copy() for k, v in state.items()}
        self.trail.append(self.state["position"])
        self.last = info
        self.total_reward += sum(info["reward_terms"].values())

    def draw(self) -> np.ndarray:
        p = self.params
        s = self.state
        surface = canvas.new_surface(WIDTH, HEIGHT)
        pad = max(0.04 * p.arena_size, 1.1 * (p.radius + p.max_speed * p.dt))  # room for a wheel a step outside
        h = p.half_size
        top = canvas.Panel(surface, (20, 70, 560, 560), (-h - pad, h + pad, -h - pad, h + pad), equal_aspect=True)
        self._draw_arena(top)
        pose = Pose(s["position"][None, 0], s["position"][None, 1], s["heading"][None], s["roll"][None])
        matrix = wheel.wheel_matrix(pose, p.wheel)
        self._draw_wheel_top(top, matrix, pose)
        side_world = (-2.6 * p.radius, 2.6 * p.radius, -0.6 * p.radius, 2.6 * p.radius)
        side = canvas.Panel(surface, (600, 70, 260, 200), side_world, equal_aspect=True)
        self._draw_wheel_side(side, matrix, pose)
        self._draw_text(surface)
        return canvas.to_array(surface)

    def _draw_arena(self, top: canvas.Panel) -> None:
        p = self.params
        h = p.half_size
        for g in np.arange(-h, h + 1e-9, canvas.tick_step(p.arena_size, 5.0 if p.arena_size >= 10 else 1.0, 20)):
            top.line((g, -h), (g, h), canvas.LIGHT)
            top.line((-h, g), (h, g), canvas.LIGHT)
        top.polygon(np.array([[-h, -h], [h, -h], [h, h], [-h, h]]), canvas.BLACK, 2)
        waypoints = self.state["waypoints"] * np.array([1.0, -1.0])
        index = int(self.state["index"])
        top.polyline(waypoints[max(index - 1, 0) :], canvas.LIGHT, 1)
        for k, (x, y) in enumerate(waypoints):
            color = canvas.GREY if k < index else canvas.RED if k == index else canvas.ORANGE
            if k >= index:
                top.circle((x, y), p.capture_radius, color, 2 if k == index else 1)
            top.dot((x, y), 4, color)
            px, py = top.to_px(x, y)
            canvas.text(top.surface, [str(k + 1)], (px + 8, py - 18), 20, color)
        trail = np.array(self.trail) * np.array([1.0, -1.0])
        top.polyline(trail, canvas.BLUE, 2)
        top.circle(trail[0], 0.15, canvas.BLUE, 2)

    def _draw_wheel_top(self, top: canvas.Panel, matrix: np.ndarray, pose: Pose) -> None:
        rim, spokes = wheel_model(self.params.radius)
        flip = np.array([1.0, -1.0])
        footprint = wheel.transform(matrix, rim)[0][:, [0, 2]] * flip
        marker = wheel.transform(matrix, spokes[:1])[0][0, [0, 2]] * flip
        top.polyline(footprint, canvas.BLACK, 6)
        top.dot(marker, 3, canvas.RED)
        centre = np.array([pose.x[0], -pose.z[0]])
        ahead = wheel.forward(pose.heading)[0][[0, 2]] * flip
        top.arrow(centre, ahead * 22.0 / top.scale[0], canvas.GREEN)

    def _draw_wheel_side(self, side: canvas.Panel, matrix: np.ndarray, pose: Pose) -> None:
        r = self.params.radius
        side.frame(canvas.LIGHT)
        side.line((-2.6 * r, 0.0), (2.6 * r, 0.0), canvas.BLACK, 2)
        travelled = float(pose.roll[0]) * r
        spacing = r / 2.0
        for mark in np.arange(-2.2 * r, 2.6 * r, spacing) - np.mod(travelled, spacing):
            side.line((mark, 0.0), (mark - 0.15 * r, -0.3 * r), canvas.GREY)
        ahead = wheel.forward(pose.heading)[0]
        centre = np.array([pose.x[0], r, pose.z[0]])
        rim, spokes = wheel_model(r)

        def project(points: np.ndarray) -> np.ndarray:
            world = wheel.transform(matrix, points)[0] - centre
            return np.stack([world @ ahead, world[:, 1] + r], axis=-1)

        hub = project(np.zeros((1, 3)))[0]
        for k, end in enumerate(project(spokes)):
            side.line(hub, end, canvas.RED if k == 0 else canvas.GREY, 3 if k == 0 else 2)
        side.polyline(project(rim), canvas.BLACK, 3)
        side.dot(hub, 3, canvas.BLACK)
        side.dot((0.0, 0.0), 3, canvas.BLUE)

    def _draw_text(self, surface: Any) -> None:
        p = self.params
        s = self.state
        index = int(s["index"])
        t = float(s["step"]) * p.dt
        header = f"t = {t:.1f} s   waypoint {min(index + 1, p.n_waypoints)} of {p.n_waypoints}   passed {index}"
        if self.last.get("is_success"):
            header = f"t = {t:.1f} s   all {p.n_waypoints} waypoints passed"
        canvas.text(surface, [f"{header}   return {self.total_reward:+.2f}"], (20, 12), 24)
        canvas.text(
            surface,
            ["top view (m): x right, z down; blue ring: start; waypoints grey: passed, red: next, orange: later"],
            (24, 44),
            18,
            canvas.GREY,
        )
        if index < p.n_waypoints:
            delta = s["waypoints"][index] - s["position"]
            to_next = f"{np.hypot(*delta):.2f} m"
        else:
            to_next = "-"
        lines = [
            "side view from the right",
            "",
            f"speed    {float(s['speed']):.2f} m/s",
            f"heading  {np.degrees(float(s['heading'])):+.1f} deg",
            f"roll     {float(s['roll']):.1f} rad",
            f"         ({float(s['roll']) / (2.0 * np.pi):.2f} rev)",
            f"path     {float(s['roll']) * p.radius:.2f} m",
            f"to next  {to_next}",
        ]
        if self.last:
            lines.append(f"phi      {np.degrees(self.last['steer_increment']):+.2f} deg/step")
            lines += ["", "reward terms (last step)"]
            lines += [f"  {name:9s}{value:+.3f}" for name, value in self.last["reward_terms"].items()]
        canvas.text(surface, lines, (604, 280), 20)
        clock.draw_clock(surface, t, (WIDTH - clock.CORNER, clock.CORNER), clock.RADIUS)
