"""A small drawing surface in world coordinates (pygame, offscreen): shared by every renderer.

Nothing here opens a window; :mod:`vegym.render.window` does that for ``render_mode="human"``.
"""

from __future__ import annotations

import collections
import functools
import itertools
import math
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import numpy as np

try:
    import pygame
except ImportError as exc:  # pragma: no cover - pygame is a dependency; a broken install
    raise ImportError("rendering needs pygame, a dependency of vegym: pip install pygame") from exc

Color = tuple[int, int, int]
WHITE: Color = (255, 255, 255)
BLACK: Color = (20, 20, 20)
GREY: Color = (150, 150, 150)
LIGHT: Color = (225, 225, 225)
BLUE: Color = (40, 90, 200)
RED: Color = (210, 50, 40)
GREEN: Color = (30, 150, 60)
ORANGE: Color = (235, 140, 20)

HISTORY = 10_000
"""Steps of an episode a renderer keeps (its latest): the longest registered episode has 1,000, and one without a
time limit draws in bounded time and memory (every step kept, Aircraft-v0 took 54 ms a frame after 50,000)."""

_FONTS: dict[int, pygame.font.Font] = {}
_Draw = TypeVar("_Draw", bound=Callable[..., Any])


def history(*first: Any) -> collections.deque:
    """A renderer's record of an episode's latest :data:`HISTORY` steps, starting with ``first``."""
    return collections.deque(first, maxlen=HISTORY)


def tick_step(extent: float, finest: float, most: int) -> float:
    """Spacing of ticks, labels or grid lines over ``extent``: ``finest``, or its smallest 1-2-5 multiple (2, 5,
    10, 20, ... times) that leaves at most ``most`` of them (so that a huge scene draws a few, not millions)."""
    for power in itertools.count():
        for multiple in (1, 2, 5):
            step = finest * multiple * 10**power
            if extent / step <= most:
                return step
    raise AssertionError("unreachable")  # pragma: no cover


def multiples(low: float, high: float, step: float) -> np.ndarray:
    """The multiples of ``step`` in ``[low, high]``, ascending: where ticks or grid lines of that spacing go."""
    return np.arange(np.ceil(low / step), np.floor(high / step) + 1) * step


def font(size: int) -> pygame.font.Font:
    """pygame's default font at ``size`` pixels (cached; needs no display). The font module is started again,
    and the cache emptied, when it is not running: never started, or stopped by a ``pygame.quit()`` elsewhere
    (Gymnasium's ``HumanRendering.close()`` and classic-control envs call it), which leaves old fonts unusable;
    ``pygame.quit()`` also empties the cache itself, for code that starts pygame again before the next frame."""
    if not pygame.font.get_init():
        pygame.font.init()
        _FONTS.clear()
    if size not in _FONTS:
        if not _FONTS:  # pygame.quit() calls its registered functions once and forgets them
            pygame.register_quit(_FONTS.clear)
        _FONTS[size] = pygame.font.Font(None, size)
    return _FONTS[size]


def _inside_panel(draw: _Draw) -> _Draw:
    """``draw`` clipped to its panel's rectangle (within the surface's clip), so that no scene, however far its
    parameters push it, draws over the text or the other panels."""

    @functools.wraps(draw)
    def clipped(panel: Panel, *args: Any, **kwargs: Any) -> Any:
        surface = panel.surface
        previous = surface.get_clip()
        surface.set_clip(panel.rect.clip(previous))
        try:
            return draw(panel, *args, **kwargs)
        finally:
            surface.set_clip(previous)

    return clipped  # type: ignore[return-value]


CLIP_MARGIN = 16
"""Pixels beyond a panel to which a polygon is cut (:meth:`Panel.polygon`): more than any outline's width, so
that the cut's own edges lie outside the panel, where nothing is drawn."""


def clip_polygon(points: np.ndarray, box: tuple[float, float, float, float]) -> np.ndarray:
    """The polygon ``points`` (k, 2) cut to the box ``(left, top, right, bottom)`` (Sutherland-Hodgman): the
    same area inside the box, new vertices where its edges cross the box's sides. (0, 2) where none of it is in
    the box."""
    left, top, right, bottom = box
    vertices = [tuple(point) for point in np.asarray(points, dtype=float)]
    for axis, limit, side in ((0, left, 1.0), (0, right, -1.0), (1, top, 1.0), (1, bottom, -1.0)):
        cut: list[tuple[float, ...]] = []  # the vertices on the box's side of this line: side * (v - limit) >= 0
        for k, current in enumerate(vertices):
            previous = vertices[k - 1]
            current_in = side * (current[axis] - limit) >= 0.0
            if current_in != (side * (previous[axis] - limit) >= 0.0):
                t = (limit - previous[axis]) / (current[axis] - previous[axis])
                cut.append(tuple(p + t * (c - p) for p, c in zip(previous, current, strict=True)))
            if current_in:
                cut.append(current)
        vertices = cut
    return np.array(vertices, dtype=float).reshape(-1, 2)


class Panel:
    """A rectangle of a surface mapped to a world box ``[x0, x1] x [y0, y1]`` (y up), equal scales if asked. Its
    drawing methods draw inside the rectangle only."""

    def __init__(
        self,
        surface: pygame.Surface,
        rect: tuple[int, int, int, int],
        world: tuple[float, float, float, float],
        equal_aspect: bool = False,
    ) -> None:
        self.surface = surface
        self.rect = pygame.Rect(rect)
        x0, x1, y0, y1 = world
        sx = self.rect.width / max(x1 - x0, 1e-9)
        sy = self.rect.height / max(y1 - y0, 1e-9)
        if equal_aspect:
            sx = sy = min(sx, sy)
        self.scale = (sx, sy)
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        self.origin = (self.rect.centerx - sx * cx, self.rect.centery + sy * cy)

    def to_px(self, x: float, y: float) -> tuple[int, int]:
        """Pixel of the world point (x, y)."""
        return int(round(self.origin[0] + self.scale[0] * x)), int(round(self.origin[1] - self.scale[1] * y))

    def pixels(self, points: np.ndarray) -> list[list[int]]:
        """Pixels of world points (k, 2), as :meth:`to_px` gives them one by one."""
        return np.rint(self._pixel_points(points)).astype(np.int64).tolist()

    def _pixel_points(self, points: np.ndarray) -> np.ndarray:
        """Unrounded pixel coordinates (k, 2) of world points (k, 2)."""
        return np.asarray(self.origin) + np.asarray(points, dtype=float) * (self.scale[0], -self.scale[1])

    def length_px(self, length: float) -> int:
        """Pixels of a world length along x."""
        return max(1, int(round(self.scale[0] * length)))

    def frame(self, color: Color = GREY) -> None:
        pygame.draw.rect(self.surface, color, self.rect, 1)

    @_inside_panel
    def polyline(self, points: np.ndarray, color: Color, width: int = 2) -> None:
        """Connect world points (k, 2). A long line is thinned to evenly spaced points, about four per pixel of
        the panel's width and height, its first and last kept (an episode's whole history stays quick to draw)."""
        points = np.asarray(points, dtype=float)
        most = 4 * (self.rect.width + self.rect.height)
        if len(points) > most:
            points = points[np.linspace(0, len(points) - 1, most).round().astype(np.int64)]
        if len(points) >= 2:
            pygame.draw.lines(self.surface, color, False, self.pixels(points), width)

    @_inside_panel
    def line(self, a: Sequence[float], b: Sequence[float], color: Color, width: int = 1) -> None:
        pygame.draw.line(self.surface, color, self.to_px(*a), self.to_px(*b), width)

    def dashed(self, a: Sequence[float], b: Sequence[float], color: Color, dashes: int = 12) -> None:
        """A dashed segment from world point a to b."""
        p = np.linspace(np.asarray(a, float), np.asarray(b, float), 2 * dashes + 1)
        for i in range(0, 2 * dashes, 2):
            self.line(p[i], p[i + 1], color)

    @_inside_panel
    def circle(self, center: Sequence[float], radius: float, color: Color, width: int = 0) -> None:
        """A disc, or a ring ``width`` pixels wide inside ``radius`` (``radius`` measured along x). One around the
        whole visible area is drawn as what shows of it (pygame walks every row of a circle: seconds for millions
        of pixels)."""
        px, py = self.to_px(*center)
        pixels = self.length_px(radius)
        area = self.surface.get_clip()
        farthest_corner = math.hypot(max(px - area.left, area.right - px), max(py - area.top, area.bottom - py))
        if pixels > farthest_corner + 1:  # the visible area lies inside the circle
            if width <= 0:
                self.surface.fill(color, area)
                return
            if pixels - width > farthest_corner + 1:  # and inside the ring's hole
                return
        pygame.draw.circle(self.surface, color, (px, py), pixels, width)

    @_inside_panel
    def dot(self, center: Sequence[float], pixels: int, color: Color) -> None:
        pygame.draw.circle(self.surface, color, self.to_px(*center), pixels)

    @_inside_panel
    def polygon(self, points: np.ndarray, color: Color, width: int = 0) -> None:
        """A filled polygon of world points (k, 2), or its outline ``width`` pixels wide. One that reaches far
        beyond the panel is first cut to the panel and a margin of ``CLIP_MARGIN`` pixels (pygame fills every row
        between its lowest and highest vertex: a road of slope 1e4 took 4 s a frame, of 1e6 minutes)."""
        pixels = self._pixel_points(points)
        box = self.rect.inflate(2 * CLIP_MARGIN, 2 * CLIP_MARGIN)
        if not ((pixels >= box.topleft).all() and (pixels <= box.bottomright).all()):
            pixels = clip_polygon(pixels, (box.left, box.top, box.right, box.bottom))
            if len(pixels) < 3:
                return
        pygame.draw.polygon(self.surface, color, np.rint(pixels).astype(np.int64).tolist(), width)

    @_inside_panel
    def arrow(self, start: Sequence[float], vector: Sequence[float], color: Color, width: int = 2) -> None:
        """An arrow from ``start`` along the world ``vector``."""
        a = np.asarray(start, float)
        b = a + np.asarray(vector, float)
        pa, pb = np.array(self.to_px(*a), float), np.array(self.to_px(*b), float)
        pygame.draw.line(self.surface, color, pa, pb, width)
        d = pb - pa
        if np.hypot(*d) > 1:
            d /= np.hypot(*d)
            side = np.array([-d[1], d[0]])
            pygame.draw.polygon(self.surface, color, [pb, pb - 8 * d + 4 * side, pb - 8 * d - 4 * side])


def line_height(size: int) -> int:
    """Pixels from one line of :func:`text` of font ``size`` to the next."""
    return int(size * 0.95)


def text_size(lines: Sequence[str], size: int = 18) -> tuple[int, int]:
    """Width and height (px) of ``lines`` as :func:`text` writes them: the widest line's, the lines' together."""
    return max(font(size).size(line)[0] for line in lines), line_height(size) * len(lines)


def text(
    surface: pygame.Surface, lines: Sequence[str], xy: tuple[int, int], size: int = 18, color: Color = BLACK
) -> None:
    """Write lines of text downward from pixel ``xy``."""
    x, y = xy
    for line in lines:
        surface.blit(font(size).render(line, True, color), (x, y))
        y += line_height(size)


def new_surface(width: int, height: int) -> pygame.Surface:
    """A white offscreen surface."""
    surface = pygame.Surface((width, height))
    surface.fill(WHITE)
    return surface


def to_array(surface: pygame.Surface) -> np.ndarray:
    """The surface as a uint8 (height, width, 3) RGB array."""
    return np.ascontiguousarray(np.transpose(pygame.surfarray.pixels3d(surface), (1, 0, 2)), dtype=np.uint8)


TICK_LABEL_SIZE = 13
"""Font size (px) of the numbers under axis ticks."""


def axis_ticks(surface: pygame.Surface, panel: Panel, low: float, high: float, y: float, finest: float) -> None:
    """Ticks along ``panel``'s horizontal line at height ``y`` (world units) between ``low`` and ``high``: one
    every ``finest`` or 2, 5, 10, ... times it (at most 10 intervals), each with its number under it."""
    for x in multiples(low, high, tick_step(high - low, finest, 10)):
        px, py = panel.to_px(float(x), y)
        pygame.draw.line(surface, GREY, (px, py), (px, py + 4))
        label = f"{x + 0.0:.10g}"  # + 0.0: no "-0"; 10 digits: 1000000 beside 900000, not 1e+06
        width, _ = text_size([label], TICK_LABEL_SIZE)
        text(surface, [label], (px - width // 2, py + 2), TICK_LABEL_SIZE, GREY)
