"""GearTrain-v0: the chain of gears turning, the output's pointer and target, and the output error over time."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from vegym.envs.gear_train import GearTrainParams, GearTrainTask
from vegym.render import canvas, clock
from vegym.render.canvas import pygame

WIDTH, HEIGHT = 800, 520
SPOKES = 3
TOOTH_PITCH = 0.012
"""Arc length (m) per tooth of the drawn gears (the teeth are schematic: the model uses pitch radii)."""
MOST_TEETH = 120
"""Teeth of the largest drawn gears (a larger one gets a coarser pitch: finer teeth would not show)."""


def gear_outline(radius: float, angle: float, depth: float) -> np.ndarray:
    """Outline (k, 2) of a toothed gear of pitch ``radius`` centred at the origin, turned by ``angle`` (rad)."""
    teeth = min(max(8, round(2.0 * np.pi * radius / TOOTH_PITCH)), MOST_TEETH)
    phase = np.linspace(0.0, 2.0 * np.pi, 4 * teeth, endpoint=False)
    profile = radius + depth * np.array([1.0, 1.0, -1.0, -1.0])[np.arange(4 * teeth) % 4]
    turn = phase + angle + np.pi / (4 * teeth)
    return np.stack([profile * np.cos(turn), profile * np.sin(turn)], axis=-1)


LABEL_SIZE = 16
"""Font size (px) of the gears' labels."""


def _label(surface: Any, lines: list[str], below: tuple[int, int], placed: list[Any]) -> None:
    """Write ``lines`` centred under the pixel ``below``, a row of text further down for each earlier label
    (``placed``, their rectangles, to which this one's is added) it would overlap: small neighbouring gears."""
    width, height = canvas.text_size(lines, LABEL_SIZE)
    box = pygame.Rect(below[0] - width // 2 - 3, below[1] + 6, width + 6, height)
    while box.collidelist(placed) >= 0:
        box.move_ip(0, height)
    placed.append(box)
    canvas.text(surface, lines, (box.x + 3, box.y), LABEL_SIZE, canvas.GREY)


class GearTrainRenderer:
    """Records the output error of a single env and draws the train (seen from the front, angles anticlockwise)."""

    def __init__(self, params: GearTrainParams) -> None:
        self.params = params
        self.task = GearTrainTask(params)
        self.state: dict[str, np.ndarray] = {}
        self.errors: deque[float] = canvas.history()
        self.last: dict[str, Any] = {}

    def reset(self, state: dict[str, np.ndarray]) -> None:
        self.state = {k: v[:1].copy() for k, v in state.items()}
        self.errors = canvas.history()
        self.last = {}

    def record(self, state: dict[str, np.ndarray], info: dict[str, Any]) -> None:
        self.state = {k: v[:1].copy() for k, v in state.items()}
        self.errors.append(float(info["error"]))
        self.last = info

    def draw(self) -> np.ndarray:
        p = self.params
        s = self.state
        surface = canvas.new_surface(WIDTH, HEIGHT)
        gears = int(s["gears"][0])
        radii, angles = s["radii"][0, :gears], s["angles"][0, :gears]
        centres = np.concatenate([[0.0], np.cumsum(radii[:-1] + radii[1:])])
        depth = min(0.25 * TOOTH_PITCH, 0.1 * float(radii.min()))  # teeth in proportion to small gears
        left, right = -radii[0] - depth, centres[-1] + radii[-1] + depth
        pad = 0.08 * (right - left)
        world = (left - pad, right + pad, -p.radius_max - pad, p.radius_max + pad)
        panel = canvas.Panel(surface, (20, 70, WIDTH - 40, 260), world, equal_aspect=True)
        panel.frame(canvas.LIGHT)
        upcoming = float(self.task.target(s["key"], s["step"])[0])  # what the observation now shows
        target = float(self.last["target_angle"]) if self.last else upcoming  # that of the error in the text
        placed: list[Any] = []
        for k, (x, radius, angle) in enumerate(zip(centres, radii, angles, strict=True)):
            body = canvas.ORANGE if k == 0 else canvas.BLUE if k == gears - 1 else canvas.GREY
            panel.polygon(gear_outline(radius, angle, depth) + [x, 0.0], body)
            panel.circle((x, 0.0), radius - 1.5 * depth, canvas.WHITE)
            for j in range(SPOKES):
                spoke = angle + 2.0 * np.pi * j / SPOKES
                end = (x + (radius - 2 * depth) * np.cos(spoke), (radius - 2 * depth) * np.sin(spoke))
                panel.line((x, 0.0), end, canvas.RED if j == 0 else body, 3 if j == 0 else 2)
            panel.dot((x, 0.0), 3, canvas.BLACK)
            label = "motor" if k == 0 else "output" if k == gears - 1 else f"idler {k}"
            _label(surface, [label, f"r = {radius * 100:.3g} cm"], panel.to_px(x, -radius - depth), placed)
        reach = radii[-1] * 1.35
        out = centres[-1]
        if upcoming != target:  # a new target from the next step on
            end = (out + reach * np.cos(upcoming), reach * np.sin(upcoming))
            panel.dashed((out, 0.0), end, canvas.BLACK, dashes=5)
            panel.dot(end, 5, canvas.BLACK)
        panel.dashed((out, 0.0), (out + reach * np.cos(target), reach * np.sin(target)), canvas.GREEN, dashes=5)
        panel.dot((out + reach * np.cos(target), reach * np.sin(target)), 5, canvas.GREEN)
        self._strip(surface)
        self._numbers(surface, gears, changing=upcoming != target)
        clock.draw_clock(surface, float(s["step"][0]) * p.dt, (WIDTH - clock.CORNER, clock.CORNER), clock.RADIUS)
        return canvas.to_array(surface)

    def _strip(self, surface: Any) -> None:
        p = self.params
        # one error recorded per step: the strip shows the steps whose errors are kept (from the start until
        # canvas.HISTORY steps), and at least two target intervals
        steps = int(self.state["step"][0]) if self.state else 0
        first = steps - len(self.errors)
        start = first * p.dt
        end = start + max(steps - first, 2 * p.interval_steps) * p.dt
        panel = canvas.Panel(surface, (60, 365, WIDTH - 80, 110), (start, end, -180.0, 180.0))
        panel.frame(canvas.LIGHT)
        panel.line((start, 0.0), (end, 0.0), canvas.LIGHT)
        first_change = (first // p.interval_steps + 1) * p.interval_steps
        for change in np.arange(first_change, end / p.dt, p.interval_steps) * p.dt:
            panel.dashed((change, -180.0), (change, 180.0), canvas.LIGHT, dashes=8)
        if self.errors:
            t = p.dt * np.arange(first + 1, steps + 1)
            panel.polyline(np.stack([t, np.degrees(self.errors)], axis=-1), canvas.BLUE, 2)
        canvas.text(surface, ["+180"], (20, 360), 15, canvas.GREY)
        canvas.text(surface, ["-180"], (22, 465), 15, canvas.GREY)
        canvas.axis_ticks(surface, panel, start, end, -180.0, 1.0)
        canvas.text(surface, ["output error (deg) over time (s); dashes: target changes"], (60, 496), 16, canvas.GREY)

    def _numbers(self, surface: Any, gears: int, changing: bool) -> None:
        s = self.state
        ratio = float(GearTrainTask.ratio(s)[0])
        output = float(GearTrainTask.output_angle(s)[0])
        lines = [
            f"{gears} gears, ratio omega_out / omega_in = {ratio:+.3f}   "
            f"output {np.degrees(output):+.1f} deg (red spoke), target green" + (", next black" if changing else ""),
        ]
        if self.last:
            verdict = "on target" if self.last["is_success"] else "off target"
            lines.append(
                f"motor {self.last['input_speed']:+.2f} rad/s   output {self.last['output_speed']:+.2f} rad/s   "
                f"error {np.degrees(self.last['error']):+.2f} deg   {verdict}"
            )
        canvas.text(surface, lines, (12, 8), 20)
