"""Billiards-v0: top view of the table in the frame of the line A-B, the strike, the impact and the rest points."""

from __future__ import annotations

from typing import Any

import numpy as np

from vegym.envs.billiards import BilliardsParams, BilliardsTask
from vegym.render import canvas, clock

WIDTH, HEIGHT = 720, 500
CLOTH: canvas.Color = (46, 125, 80)
CLOTH_LINE: canvas.Color = (70, 150, 100)
BALL_A: canvas.Color = (250, 250, 240)
BALL_B: canvas.Color = (215, 45, 35)
TARGET: canvas.Color = (250, 215, 60)
SMALLEST_BALL = 4.0
"""Radius (px) under which balls and the target ring are drawn no smaller, so that a zoomed-out table shows them."""


def ball(table: canvas.Panel, centre: np.ndarray, radius: float, color: canvas.Color, width: int = 0) -> None:
    """A ball (or ring, ``width`` px) of ``radius`` (m), drawn at least :data:`SMALLEST_BALL` pixels in radius."""
    table.circle(centre, max(radius, SMALLEST_BALL / table.scale[0]), color, width)


class BilliardsRenderer:
    """Draws the start of a single env's episode and, after the strike, both balls' paths to rest (the view
    then takes in their rest points too).

    Seen from above (+y) with the line A-B pointing right: bearings increase clockwise on screen, as in the other
    top views (x right, z down).
    """

    def __init__(self, params: BilliardsParams) -> None:
        self.params = params
        self.state: dict[str, np.ndarray] = {}
        self.shot: dict[str, Any] = {}

    def reset(self, state: dict[str, np.ndarray]) -> None:
        self.state = {k: v[:1] for k, v in state.items()}
        self.shot = {}

    def record(self, state: dict[str, np.ndarray], info: dict[str, Any]) -> None:
        self.shot = info

    def draw(self) -> np.ndarray:
        p = self.params
        distance, along, across = BilliardsTask.line_frame(self.state)
        origin, along, across = self.state["ball_a"][0], along[0], across[0]

        def frame(points: np.ndarray) -> np.ndarray:
            """Table points (..., 2) in screen-world coordinates: along A-B to the right, bearing clockwise."""
            offset = np.asarray(points, dtype=np.float64) - origin
            return np.stack([offset @ along, -(offset @ across)], axis=-1)

        surface = canvas.new_surface(WIDTH, HEIGHT)
        a, b, target = (frame(self.state[k][0]) for k in ("ball_a", "ball_b", "target"))
        shown = [a, b, target, *(frame(self.shot[k]) for k in ("rest_a", "rest_b") if self.shot)]
        table, (x0, x1, y0, y1) = self._table(surface, np.array(shown))
        surface.fill(CLOTH, table.rect)
        grid = canvas.tick_step(max(x1 - x0, y1 - y0), 0.25, 40)
        for x in canvas.multiples(x0, x1, grid):
            table.line((x, y0), (x, y1), CLOTH_LINE)
        for y in canvas.multiples(y0, y1, grid):
            table.line((x0, y), (x1, y), CLOTH_LINE)
        table.line(a, b, CLOTH_LINE)
        ball(table, target, p.target_radius, TARGET, 2)
        table.dot(target, 2, TARGET)
        lines = [
            f"A-B {float(distance[0]):.2f} m   B-target {np.linalg.norm(target - b):.2f} m   e = {p.restitution:g}"
        ]
        if self.shot:
            self._draw_shot(table, frame, a, b)
            lines.append(self._shot_text())
        else:
            ball(table, a, p.radius_a, BALL_A)
            ball(table, b, p.radius_b, BALL_B)
        canvas.text(surface, lines, (12, 8), 20)
        canvas.text(
            surface,
            [f"top view, line A-B to the right; white: A (struck), red: B, yellow ring: target, grid {grid:g} m"],
            (20, HEIGHT - 34),
            16,
            canvas.GREY,
        )
        duration = float(self.shot["duration"]) if self.shot else 0.0
        clock.draw_clock(surface, duration, (WIDTH - clock.CORNER, clock.CORNER), clock.RADIUS)
        return canvas.to_array(surface)

    @staticmethod
    def _table(surface: Any, points: np.ndarray) -> tuple[canvas.Panel, tuple[float, float, float, float]]:
        """The panel showing ``points`` (k, 2) with a 0.25 m margin, at equal scales, filling its rectangle, and
        its world box (m)."""
        rect = (20, 70, WIDTH - 40, HEIGHT - 110)
        low, high = points.min(axis=0) - 0.25, points.max(axis=0) + 0.25
        centre, span = 0.5 * (low + high), high - low
        span = np.maximum(span, span[::-1] * np.array([rect[2] / rect[3], rect[3] / rect[2]]))
        box = (centre[0] - span[0] / 2, centre[0] + span[0] / 2, centre[1] - span[1] / 2, centre[1] + span[1] / 2)
        return canvas.Panel(surface, rect, box, equal_aspect=True), box

    def _draw_shot(self, table: canvas.Panel, frame: Any, a: np.ndarray, b: np.ndarray) -> None:
        p = self.params
        s = self.shot
        rest_a, rest_b = frame(s["rest_a"]), frame(s["rest_b"])
        ball(table, a, p.radius_a, BALL_A, 1)
        ball(table, b, p.radius_b, BALL_B, 1)
        if s["contact"]:
            contact = frame(s["contact_point"])
            table.dashed(a, contact, BALL_A, dashes=10)
            table.dashed(contact, rest_a, BALL_A, dashes=10)
            table.line(b, rest_b, BALL_B, 2)
            ball(table, contact, p.radius_a, BALL_A, 1)
        else:
            table.dashed(a, rest_a, BALL_A, dashes=10)
        ball(table, rest_a, p.radius_a, BALL_A)
        ball(table, rest_b, p.radius_b, BALL_B)

    def _shot_text(self) -> str:
        s = self.shot
        speed = float(np.linalg.norm(s["strike_velocity"]))
        if not s["contact"]:
            start, heading = self.state["ball_a"][0], s["strike_velocity"] / max(speed, 1e-300)
            nearest_b = float(np.dot(self.state["ball_b"][0] - start, heading))  # A's run to its point nearest B
            how = "passes beside B" if float(np.dot(s["rest_a"] - start, heading)) > nearest_b else "stops short of B"
            return f"strike {speed:.2f} m/s: A {how}   miss {s['miss_distance']:.3f} m"
        verdict = "HIT" if s["is_success"] else "miss"
        return (
            f"strike {speed:.2f} m/s   impact w = {s['closing_speed']:.2f} m/s   "
            f"B leaves at {np.linalg.norm(s['velocity_b']):.2f} m/s   lost {s['energy_lost'] * 1000:.1f} mJ   "
            f"{verdict} by {s['miss_distance']:.3f} m"
        )
