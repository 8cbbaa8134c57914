"""Projectile-v0: side view along the line of fire and a top view, with the trajectory and the numbers."""

from __future__ import annotations

from typing import Any

import numpy as np

from vegym.envs.projectile import ProjectileEnvParams, ProjectileTask
from vegym.physics import projectile
from vegym.render import canvas, clock

WIDTH, HEIGHT = 640, 480
MARGIN = 0.05
"""Space around the drawn scene, as a fraction of the view's span."""


def shot_path(p0: np.ndarray, shot: dict[str, Any], physics: projectile.ProjectileParams) -> np.ndarray:
    """Points (80, 3) of ``shot``'s flight (an env's step info) relative to the launch point ``p0`` (m)."""
    t = np.linspace(0.0, shot["flight_time"], 80)
    return projectile.position_at(p0[None], shot["launch_velocity"][None], shot["wind"][None], t, physics) - p0


def side_world(
    reach: float, launch_height: float, launch_height_max: float, paths: list[np.ndarray], along: np.ndarray
) -> tuple[float, float, float, float]:
    """The side view's world box (along the line of fire ``along``, height; m): the launcher, ``reach`` and at
    least 1.6 times the highest launch or a seventh of ``reach`` (a view in proportion to the scene, whatever its
    size), widened to take in every path (k, 3) relative to the launcher, which stands ``launch_height`` high."""
    x = [0.0, reach, *(float(v) for path in paths for v in (np.min(path @ along), np.max(path @ along)))]
    lowest_top = max(launch_height_max, reach / 7.0) * 1.6
    top = max([lowest_top, *(1.05 * (launch_height + np.max(path[:, 1])) for path in paths)])
    x_span = max(x) - min(x)
    return min(x) - MARGIN * x_span, max(x) + MARGIN * x_span, -MARGIN * top, top


class ProjectileRenderer:
    """Draws the launcher, the target, the wind and the last shot of a single env.

    The top view is seen from above (+y) with the line of fire to the right, so "across" (increasing azimuth)
    points down, as in the other top views (x right, z down); the wind arrow spans the view's half width at
    ``wind_speed_max``.
    """

    def __init__(self, params: ProjectileEnvParams) -> None:
        self.params = params
        self.state: dict[str, np.ndarray] = {}
        self.shot: dict[str, Any] = {}

    def reset(self, state: dict[str, np.ndarray]) -> None:
        self.state = {k: v[0] for k, v in state.items()}
        self.shot = {}

    def record(self, state: dict[str, np.ndarray], info: dict[str, Any]) -> None:
        self.shot = info

    def draw(self) -> np.ndarray:
        p = self.params
        s = self.state
        distance, _, (along, across) = ProjectileTask.target_frame({k: v[None] for k, v in s.items()})
        along, across, distance = along[0], across[0], float(distance[0])
        p0 = s["launch_position"]
        surface = canvas.new_surface(WIDTH, HEIGHT)
        reach = p.target_distance_max * 1.15
        path = shot_path(p0, self.shot, p.physics) if self.shot else None
        paths = [] if path is None else [path]
        left, right, bottom, top_height = side_world(reach, float(p0[1]), p.launch_height_max, paths, along)
        half_width = max([reach / 8, *((1.0 + MARGIN) * np.max(np.abs(path @ across)) for path in paths)])  # m
        side = canvas.Panel(surface, (40, 50, WIDTH - 60, 250), (left, right, bottom, top_height))
        top = canvas.Panel(surface, (40, 320, WIDTH - 60, 140), (left, right, -half_width, half_width))

        def top_view(points: np.ndarray) -> np.ndarray:
            """Points (..., 3) relative to the launcher in the top view's coordinates: along, minus across."""
            return np.stack([points @ along, -(points @ across)], axis=-1)

        for panel in (side, top):
            panel.frame(canvas.LIGHT)
        side.line((left, 0.0), (right, 0.0), canvas.BLACK, 2)
        canvas.axis_ticks(surface, side, left, right, 0.0, 1.0)  # m from the launcher
        side.line((0.0, 0.0), (0.0, p0[1]), canvas.BLACK, 4)
        top.line((left, 0.0), (right, 0.0), canvas.LIGHT)
        for panel in (side, top):
            panel.line((distance - p.hit_radius, 0.0), (distance + p.hit_radius, 0.0), canvas.RED, 5)
            panel.dot((distance, 0.0), 4, canvas.RED)
        wind = s["wind"]
        w_along, w_across = float(wind @ along), float(wind @ across)
        top.arrow((reach * 0.8, 0.0), top_view(wind) * 0.9 * half_width / max(p.wind_speed_max, 1e-9), canvas.GREEN)
        lines = [
            f"target {distance:.1f} m   launch height {p0[1]:.1f} m   "
            f"wind {w_along:+.1f} along, {w_across:+.1f} across m/s"
        ]
        if path is not None:
            v0 = self.shot["launch_velocity"]
            side.polyline(np.stack([path @ along, path[:, 1] + p0[1]], -1), canvas.BLUE)
            landing = self.shot["landing_point"] - p0
            side.dot((float(landing @ along), p.radius), 4, canvas.BLUE)
            top.polyline(top_view(path), canvas.BLUE)
            top.dot(tuple(top_view(landing)), 4, canvas.BLUE)
            speed = float(np.linalg.norm(v0))
            elevation = np.degrees(np.arcsin(v0[1] / speed)) if speed > 0 else 0.0
            verdict = "HIT" if self.shot["is_success"] else "miss"
            lines.append(
                f"elevation {elevation:.1f} deg   speed {speed:.1f} m/s   flight {self.shot['flight_time']:.2f} s   "
                f"{verdict} by {self.shot['miss_distance']:.2f} m"
            )
        canvas.text(surface, lines, (12, 8), 19)
        canvas.text(surface, ["side view along the line of fire (m)"], (44, 52), 16, canvas.GREY)
        canvas.text(surface, ["top view; green arrow: wind"], (44, 322), 16, canvas.GREY)
        flight_time = float(self.shot["flight_time"]) if self.shot else 0.0
        clock.draw_clock(surface, flight_time, (WIDTH - 25, 25), 22)  # above the side view's frame
        return canvas.to_array(surface)
