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
        table = self._table(surface, np.array(shown))
        surface.fill(CLOTH, table.rect)
        for mark in np.arange(-5.0, 5.0, 0.25):
            table.line((mark, -5.0), (mark, 5.0), CLOTH_LINE)
            table.line((-5.0, mark), (5.0, mark), CLOTH_LINE)
        table.line(a, b, CLOTH_LINE)
        table.circle(target, p.target_radius, TARGET, 2)
        table.dot(target, 2, TARGET)
        lines = [
            f"A-B {float(distance[0]):.2f} m   B-target {np.linalg.norm(target - b):.2f} m   e = {p.restitution:g}"
        ]
        if self.shot:
            self._draw_shot(table, frame, a, b)
            lines.append(self._shot_text())
        else:
            table.circle(a, p.radius_a, BALL_A)
            table.circle(b, p.radius_b, BALL_B)
        canvas.text(surface, lines, (12, 8), 20)
        canvas.text(
            surface,
            ["top view, line A-B to the right; white: A (struck), red: B, yellow ring: target, grid 0.25 m"],
            (20, HEIGHT - 34),
            16,
            canvas.GREY,
        )
        duration = float(self.shot["duration"]) if self.shot else 0.0
        clock.draw_clock(surface, duration, (WIDTH - clock.CORNER, clock.CORNER), clock.RADIUS)
        return canvas.to_array(surface)

    @staticmethod
    def _table(surface: Any, points: np.ndarray) -> canvas.Panel:
        """The panel showing ``points`` (k, 2) with a 0.25 m margin, at equal scales, filling its rectangle."""
        rect = (20, 70, WIDTH - 40, HEIGHT - 110)
        low, high = points.min(axis=0) - 0.25, points.max(axis=0) + 0.25
        centre, span = 0.5 * (low + high), high - low
        span = np.maximum(span, span[::-1] * np.array([rect[2] / rect[3], rect[3] / rect[2]]))
        box = (centre[0] - span[0] / 2, centre[0] + span[0] / 2, centre[1] - span[1] / 2, centre[1] + span[1] / 2)
        return canvas.Panel(surface, rect, box, equal_aspect=True)

    def _draw_shot(self, table: canvas.Panel, frame: Any, a: np.ndarray, b: np.ndarray) -> None:
        p = self.params
        s = self.shot
        rest_a, rest_b = frame(s["rest_a"]), frame(s["rest_b"])
        table.circle(a, p.radius_a, BALL_A, 1)
        table.circle(b, p.radius_b, BALL_B, 1)
        if s["contact"]:
            contact = frame(s["contact_point"])
            table.dashed(a, contact, BALL_A, dashes=10)
            table.dashed(contact, rest_a, BALL_A, dashes=10)
            table.line(b, rest_b, BALL_B, 2)
            table.circle(contact, p.radius_a, BALL_A, 1)
        else:
            table.dashed(a, rest_a, BALL_A, dashes=10)
        table.circle(rest_a, p.radius_a, BALL_A)
        table.circle(rest_b, p.radius_b, BALL_B)

    def _shot_text(self) -> str:
        s = self.shot
        speed = float(np.linalg.norm(s["strike_velocity"]))
        if not s["contact"]:
            return f"strike {speed:.2f} m/s: A stops short of B   miss {s['miss_distance']:.3f} m"
        verdict = "HIT" if s["is_success"] else "miss"
        return (
            f"strike {speed:.2f} m/s   impact w = {s['closing_speed']:.2f} m/s   "
            f"B leaves at {np.linalg.norm(s['velocity_b']):.2f} m/s   lost {s['energy_lost'] * 1000:.1f} mJ   "
            f"{verdict} by {s['miss_distance']:.3f} m"
        )
