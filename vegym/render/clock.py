"""A small analogue clock showing the simulation time in a corner of every frame (the clock of 8.2.4).

Every renderer calls, on its pygame surface, with its simulation time in seconds::

    clock.draw_clock(surface, seconds, (surface.get_width() - CORNER, CORNER), RADIUS)

The hands follow :mod:`vegym.physics.clock` (the chapter's angles, anticlockwise ``R_z(+theta)``, a sweeping
second hand); 0 s reads 12:00:00. A digital ``m:ss.s`` readout sits in the lower half of the face.
"""

from __future__ import annotations

import numpy as np

from vegym.physics import clock
from vegym.render import canvas
from vegym.render.canvas import pygame

RADIUS = 26
"""Default face radius (pixels)."""
CORNER = RADIUS + 6
"""Distance (pixels) of the default centre from the two edges of its corner."""
_HAND_LENGTHS = np.array([0.9, 0.8, 0.5])
"""Second, minute and hour hand lengths as fractions of the radius."""
_HAND_WIDTHS = (1, 3, 4)
_HAND_COLORS = (canvas.RED, canvas.BLACK, canvas.BLACK)


def _readout(seconds: float) -> str:
    minutes, sec = divmod(max(seconds, 0.0), 60.0)
    hours, minutes = divmod(int(minutes), 60)
    return f"{hours}:{minutes:02d}:{sec:02.0f}" if hours else f"{minutes}:{sec:04.1f}"


def draw_clock(surface: pygame.Surface, seconds: float, center: tuple[int, int], radius: int) -> None:
    """Draw a clock face of ``radius`` pixels at pixel ``center`` showing ``seconds`` of simulation time."""
    cx, cy = center
    pygame.draw.circle(surface, canvas.WHITE, center, radius)
    pygame.draw.circle(surface, canvas.GREY, center, radius, 2)
    marks = np.radians(90.0 - 30.0 * np.arange(12))
    for k, angle in enumerate(marks):
        inner = radius * (0.72 if k % 3 == 0 else 0.82)
        c, s = np.cos(angle), np.sin(angle)
        pygame.draw.line(
            surface, canvas.GREY, (cx + inner * c, cy - inner * s), (cx + 0.92 * radius * c, cy - 0.92 * radius * s)
        )
    if radius >= 18:
        label = canvas.font(max(10, radius // 2)).render(_readout(float(seconds)), True, canvas.GREY)
        surface.blit(label, label.get_rect(center=(cx, cy + radius // 2)))
    tips = clock.hand_tips(clock.hand_angles_at(float(seconds)), radius * _HAND_LENGTHS)
    for k in (2, 1, 0):
        tip = (cx + tips[k, 0], cy - tips[k, 1])  # the screen's y axis points down
        pygame.draw.line(surface, _HAND_COLORS[k], center, tip, _HAND_WIDTHS[k])
    pygame.draw.circle(surface, canvas.BLACK, center, 2)
