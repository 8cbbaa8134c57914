"""Aircraft-v0: top-down track, and altitude, airspeed and heading strip charts with the demands and the numbers."""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from vegym.envs.aircraft import AircraftEnvParams
from vegym.render import canvas, clock

WIDTH, HEIGHT = 900, 520
_MIN_SPAN = 4000.0
"""Smallest side of the top view (m): about a standard-rate circle at 100 m/s."""
_HALF = np.array(
    [[2.0, 0.0], [1.0, 0.2], [0.3, 0.2], [-0.2, 1.5], [-0.55, 1.5], [-0.35, 0.2], [-1.1, 0.15], [-1.4, 0.65],
     [-1.65, 0.65], [-1.55, 0.0]]
)  # fmt: skip
_SILHOUETTE = np.concatenate([_HALF, _HALF[-2:0:-1] * [1.0, -1.0]])
"""The aircraft's outline (k, 2) in lengths along (nose ahead) and left of its heading: fuselage, wings, tail."""


class AircraftRenderer:
    """Records the flight of a single env and draws the episode so far (its latest :data:`~vegym.render.canvas.HISTORY`
    steps)."""

    def __init__(self, params: AircraftEnvParams) -> None:
        self.params = params
        self.times: deque[float] = canvas.history()
        self.positions: deque[np.ndarray] = canvas.history()
        self.speeds: deque[float] = canvas.history()
        self.headings: deque[float] = canvas.history()
        self.demands: deque[np.ndarray] = canvas.history()
        self.state: dict[str, np.ndarray] = {}
        self.last: dict[str, Any] = {}

    def reset(self, state: dict[str, np.ndarray]) -> None:
        self.state = {k: v[0] for k, v in state.items()}
        self.times = canvas.history(0.0)
        self.positions = canvas.history(self.state["position"].copy())
        self.speeds = canvas.history(float(self.state["speed"]))
        self.headings = canvas.history(float(self.state["heading"]))
        self.demands = canvas.history(self.state["demand"].copy())
        self.last = {}

    def record(self, state: dict[str, np.ndarray], info: dict[str, Any]) -> None:
        self.state = {k: v[0] for k, v in state.items()}
        self.times.append(self.times[-1] + info["dt"])
        self.positions.append(np.asarray(info["position"]).copy())
        self.speeds.append(info["speed"])
        self.headings.append(info["heading"])
        self.demands.append(np.asarray(info["demand"]).copy())
        self.last = info

    def draw(self) -> np.ndarray:
        surface = canvas.new_surface(WIDTH, HEIGHT)
        self._top_view(surface)
        self._strips(surface)
        self._numbers(surface)
        return canvas.to_array(surface)

    def _top_view(self, surface: Any) -> None:
        track = np.array(self.positions)
        # Seen from above (+y): screen right is -x, screen up is +z, so a positive (left) turn is anticlockwise.
        plan = np.stack([-track[:, 0], track[:, 2]], axis=-1)
        low, high = plan.min(axis=0), plan.max(axis=0)
        centre, span = 0.5 * (low + high), max(float(np.max(high - low)) * 1.15, _MIN_SPAN)
        world = (centre[0] - span / 2, centre[0] + span / 2, centre[1] - span / 2, centre[1] + span / 2)
        panel = canvas.Panel(surface, (15, 85, 400, 400), world, equal_aspect=True)
        panel.frame(canvas.LIGHT)
        surface.set_clip(panel.rect)
        panel.polyline(plan, canvas.BLUE, 2)
        panel.dot(plan[0], 4, canvas.GREEN)
        heading = float(self.state["heading"])
        forward = np.array([-np.sin(heading), np.cos(heading)])
        left = np.array([-forward[1], forward[0]])
        outline = plan[-1] + (span / 45) * (_SILHOUETTE[:, :1] * forward + _SILHOUETTE[:, 1:] * left)
        demand = float(self.state["demand"][2])
        wanted = np.array([-np.sin(demand), np.cos(demand)])
        panel.dashed(plan[-1], plan[-1] + 0.25 * span * wanted, canvas.ORANGE, dashes=6)
        panel.polygon(outline, canvas.RED)
        wind = np.array([-self.params.wind_x, self.params.wind_z])  # in the view's coordinates
        if wind.any():
            strength = math.hypot(*wind)  # np.linalg.norm underflows to 0 below about 1e-154 m/s
            tail = np.array([world[0] + 0.12 * span, world[3] - 0.2 * span])
            panel.arrow(tail, 0.08 * span * wind / strength, canvas.GREEN)
            label_x, label_y = panel.to_px(*(tail - [0.07 * span, 0.13 * span]))
            canvas.text(surface, [f"wind {strength:.1f} m/s"], (label_x, label_y), 16, canvas.GREEN)
        bar = 1000.0 if span < 12000.0 else 5000.0
        x0, y0 = world[0] + 0.05 * span, world[2] + 0.05 * span
        panel.line((x0, y0), (x0 + bar, y0), canvas.BLACK, 3)
        label_x, label_y = panel.to_px(x0, y0)
        canvas.text(surface, [f"{bar / 1000:.0f} km"], (label_x, label_y - 18), 16)
        panel.arrow((world[1] - 0.07 * span, world[2] + 0.05 * span), (0.0, 0.08 * span), canvas.GREY)
        canvas.text(surface, ["+z"], panel.to_px(world[1] - 0.1 * span, world[2] + 0.16 * span), 16, canvas.GREY)
        surface.set_clip(None)
        canvas.text(
            surface,
            ["top view (right: -x, up: +z); green: start, wind; orange: demand"],
            (19, 88),
            16,
            canvas.GREY,
        )

    def _strips(self, surface: Any) -> None:
        p = self.params
        t = np.array(self.times)
        demands = np.array(self.demands)
        horizon = max(p.episode_steps * p.dt, t[-1])
        series = [
            ("altitude (m)", np.array([q[1] for q in self.positions]), demands[:, 0], (p.altitude_min, p.altitude_max)),
            ("airspeed (m/s)", np.array(self.speeds), demands[:, 1], (p.speed_demand_min, p.speed_demand_max)),
            ("heading (deg)", np.degrees(self.headings), np.degrees(demands[:, 2]), (-180.0, 180.0)),
        ]
        for k, (label, value, demand, (lo, hi)) in enumerate(series):
            if k < 2:
                lo = min(lo, float(value.min()), float(demand.min()))
                hi = max(hi, float(value.max()), float(demand.max()))
            pad = 0.08 * (hi - lo) if k < 2 else 0.0
            panel = canvas.Panel(surface, (490, 85 + 140 * k, 395, 112), (0.0, horizon, lo - pad, hi + pad))
            panel.frame(canvas.LIGHT)
            for segment in self._unwrapped_segments(t, demand, k == 2):
                panel.polyline(segment, canvas.ORANGE, 2)
            for segment in self._unwrapped_segments(t, value, k == 2):
                panel.polyline(segment, canvas.BLUE, 2)
            canvas.text(surface, [label], (490, 67 + 140 * k), 16, canvas.GREY)  # above the panel: lines reach its top
            canvas.text(surface, [f"{hi + pad:.0f}"], (448, 80 + 140 * k), 15, canvas.GREY)
            canvas.text(surface, [f"{lo - pad:.0f}"], (448, 187 + 140 * k), 15, canvas.GREY)
        canvas.axis_ticks(surface, panel, 0.0, horizon, lo - pad, 1.0)
        canvas.text(surface, ["time (s); blue: flown, orange: demand"], (490, 498), 16, canvas.GREY)

    @staticmethod
    def _unwrapped_segments(t: np.ndarray, value: np.ndarray, angular: bool) -> list[np.ndarray]:
        """Polylines (k, 2) of ``value`` over ``t``, split where a heading in degrees wraps around."""
        cuts = np.flatnonzero(np.abs(np.diff(value)) > 180.0) + 1 if angular else np.zeros(0, dtype=int)
        points = np.stack([t, value], axis=-1)
        return [s for s in np.split(points, cuts) if len(s) >= 2]

    def _numbers(self, surface: Any) -> None:
        s = self.state
        demand = s["demand"]
        lines = [
            f"t = {self.times[-1]:.0f} s   altitude {s['position'][1]:.0f} m (demand {demand[0]:.0f})   "
            f"airspeed {s['speed']:.1f} m/s (demand {demand[1]:.1f})",
            f"heading {np.degrees(s['heading']):.1f} deg (demand {np.degrees(demand[2]):.1f})   "
            f"vertical speed {s['vertical_speed']:+.1f} m/s   steady vertical wind {s['draft'] + 0.0:+.1f} m/s",
        ]
        if self.last:
            verdict = "within tolerance" if self.last["is_success"] else "not within tolerance"
            lines.append(f"reward {sum(self.last['reward_terms'].values()):+.3f}   {verdict} of the demand flown")
        canvas.text(surface, lines, (12, 8), 20)
        clock.draw_clock(surface, self.times[-1], (WIDTH - clock.CORNER, clock.CORNER), clock.RADIUS)
