"""ProjectileAdjust-v0: every shot's trajectory along the line of fire, the landings around the target, the numbers."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from vegym.envs.projectile import ProjectileTask
from vegym.envs.projectile_adjust import ProjectileAdjustParams
from vegym.render import canvas, clock
from vegym.render.projectile import shot_path, side_world

WIDTH, HEIGHT = 760, 440
_TEXT_LINES = 4
"""Shots listed under the side view (the most recent)."""
SHOT_COLORS: tuple[canvas.Color, ...] = (canvas.BLUE, canvas.ORANGE, canvas.GREEN, (140, 60, 170), canvas.BLACK)


KEPT_SHOTS = 100
"""Shots a renderer keeps and draws, the latest: an episode fires at most 16, and more come only from steps past
its end without a reset (10,000 shots took 1.9 s a frame)."""


def beside_clear_of_ring(
    dot: tuple[int, int], size: tuple[int, int], centre: tuple[int, int], radius: float
) -> tuple[int, int]:
    """Top-left pixel of a label of ``size`` (w, h) beside the pixel ``dot``: right of it, else left, above or
    below, the first whose box stays off the circle of ``radius`` px about ``centre`` (the hit ring); right of it
    if none does."""
    (x, y), (w, h) = dot, size
    places = [(x + 7, y - h // 2), (x - 7 - w, y - h // 2), (x - w // 2, y - 7 - h), (x - w // 2, y + 7)]
    for left, top in places:
        nearest = np.hypot(np.clip(centre[0], left, left + w) - centre[0], np.clip(centre[1], top, top + h) - centre[1])
        farthest = max(np.hypot(cx - centre[0], cy - centre[1]) for cx in (left, left + w) for cy in (top, top + h))
        if not nearest <= radius <= farthest:
            return left, top
    return places[0]


class ProjectileAdjustRenderer:
    """Draws the launcher, the target and the shots of a single env's episode (its latest :data:`KEPT_SHOTS`: steps
    past the end without a reset fire more); the hidden wind in grey."""

    def __init__(self, params: ProjectileAdjustParams) -> None:
        self.params = params
        self.state: dict[str, np.ndarray] = {}
        self.shots: deque[dict[str, Any]] = deque(maxlen=KEPT_SHOTS)
        self.fired = 0
        self.elapsed = 0.0

    def reset(self, state: dict[str, np.ndarray]) -> None:
        self.state = {k: v[:1] for k, v in state.items()}
        self.shots = deque(maxlen=KEPT_SHOTS)
        self.fired, self.elapsed = 0, 0.0

    def record(self, state: dict[str, np.ndarray], info: dict[str, Any]) -> None:
        self.shots.append(info)
        self.fired += 1
        self.elapsed += float(info["flight_time"])

    def draw(self) -> np.ndarray:
        p = self.params
        distance, _, (along, across) = ProjectileTask.target_frame(self.state)
        along, across, distance = along[0], across[0], float(distance[0])
        p0 = self.state["launch_position"][0]
        surface = canvas.new_surface(WIDTH, HEIGHT)
        reach = p.target_distance_max * 1.15
        paths = [shot_path(p0, shot, p.physics) for shot in self.shots]
        left, right, bottom, top_height = side_world(reach, float(p0[1]), p.launch_height_max, paths, along)
        side = canvas.Panel(surface, (40, 70, 420, 260), (left, right, bottom, top_height))
        misses = [abs(shot[k]) for shot in self.shots for k in ("miss_along", "miss_across")]
        zoom = float(np.clip(1.3 * max(misses, default=0.0), 3.0 * p.hit_radius, p.miss_scale))
        top = canvas.Panel(surface, (490, 70, 250, 260), (-zoom, zoom, -zoom, zoom), equal_aspect=True)
        side.frame(canvas.LIGHT)
        top.frame(canvas.LIGHT)
        side.line((left, 0.0), (right, 0.0), canvas.BLACK, 2)
        canvas.axis_ticks(surface, side, left, right, 0.0, 1.0)  # m from the launcher
        side.line((0.0, 0.0), (0.0, p0[1]), canvas.BLACK, 4)
        side.line((distance - p.hit_radius, 0.0), (distance + p.hit_radius, 0.0), canvas.RED, 5)
        top.line((-zoom, 0.0), (zoom, 0.0), canvas.LIGHT)
        top.line((0.0, -zoom), (0.0, zoom), canvas.LIGHT)
        top.circle((0.0, 0.0), p.hit_radius, canvas.RED, 2)
        wind = self.state["wind"][0]
        top.arrow(
            (-0.7 * zoom, -0.7 * zoom),
            np.array([wind @ across, wind @ along]) * 0.25 * zoom / p.wind_scale,
            canvas.GREY,
        )
        ring = top.length_px(p.hit_radius)
        lines = []
        for k, (shot, path) in enumerate(zip(self.shots, paths, strict=True), start=self.fired - len(self.shots)):
            color = SHOT_COLORS[k % len(SHOT_COLORS)]
            side.polyline(np.stack([path @ along, path[:, 1] + p0[1]], -1), color)
            landing = np.array([shot["miss_across"], shot["miss_along"]])
            edge = 0.92 * zoom  # a landing beyond the panel: a ring at its edge, in the landing's direction
            beyond = np.max(np.abs(landing)) > edge
            shown = landing * edge / np.max(np.abs(landing)) if beyond else landing
            surface.set_clip(top.rect)
            if beyond:
                top.circle(shown, 6.0 / top.scale[0], color, 2)  # 6 px
            else:
                top.dot(shown, 5, color)
            number = str(k + 1)
            xy = beside_clear_of_ring(top.to_px(*shown), canvas.text_size([number], 18), top.to_px(0.0, 0.0), ring)
            canvas.text(surface, [number], xy, 18, color)
            surface.set_clip(None)
            verdict = "HIT" if shot["is_success"] else "miss"
            lines.append(
                f"shot {k + 1}: {verdict} by {shot['miss_distance']:.2f} m "
                f"({shot['miss_along']:+.2f} along, {shot['miss_across']:+.2f} across)   "
                f"flight {shot['flight_time']:.2f} s"
            )
        header = f"target {distance:.1f} m   launch height {p0[1]:.1f} m   shot {self.fired} of {p.max_shots}"
        canvas.text(surface, [header], (12, 10), 20)
        for k, line in enumerate(lines[-_TEXT_LINES:]):
            index = self.fired - len(lines[-_TEXT_LINES:]) + k
            canvas.text(surface, [line], (40, 345 + 22 * k), 19, SHOT_COLORS[index % len(SHOT_COLORS)])
        canvas.text(surface, ["side view along the line of fire (m)"], (44, 72), 16, canvas.GREY)
        canvas.text(surface, [f"landings, +-{zoom:.1f} m"], (494, 72), 16, canvas.GREY)
        canvas.text(
            surface,
            [
                "top view: fire upward,",
                "bearing increasing to the right;",
                f"grey: hidden wind {np.linalg.norm(wind):.1f} m/s;",
                "ring: a landing beyond the edge",
            ],
            (490, 335),
            16,
            canvas.GREY,
        )
        clock.draw_clock(surface, self.elapsed, (WIDTH - clock.CORNER, clock.CORNER), clock.RADIUS)
        return canvas.to_array(surface)
