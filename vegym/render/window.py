"""An on-screen window for ``render_mode="human"``; the only place vegym initialises a display."""

from __future__ import annotations

import os
import weakref

import gymnasium as gym
import numpy as np
import pygame

LONGEST_FRAME = 1.0
"""Seconds a frame stays at most: an env whose steps last longer (BouncingBall with little gravity, say) is shown
faster than real time rather than holding the window, which cannot be interrupted while it waits."""
HEADLESS_VIDEO_DRIVERS = ("offscreen", "dummy")
"""SDL's video drivers that show nothing, which it falls back to where no display is found."""
_SHOWING: weakref.WeakSet[Window] = weakref.WeakSet()
"""The windows that have shown a frame and are not closed nor collected: they share pygame's one display."""


def start_display() -> str | None:
    """Start pygame's display; the driver that shows nothing that SDL fell back to where it found no display, or
    None (a display found, or ``SDL_VIDEODRIVER`` chose the driver)."""
    pygame.display.init()
    driver = pygame.display.get_driver()
    return driver if driver in HEADLESS_VIDEO_DRIVERS and "SDL_VIDEODRIVER" not in os.environ else None


class Window:
    """Shows RGB frames at ``fps`` frames per second, at least one per :data:`LONGEST_FRAME` seconds
    (``pygame.display.init()`` on the first frame; a warning, once, where there is no display to show them on).

    pygame has one display per process: windows of several envs take turns in it (the display takes each one's
    size and title when it shows a frame), and it is closed with the last of them. A display stopped elsewhere
    (``pygame.quit()``) is started again at the next frame."""

    def __init__(self, title: str, fps: float) -> None:
        self.title = title
        self.fps = fps
        self._clock: pygame.time.Clock | None = None
        self._warned = False

    def show(self, frame: np.ndarray) -> None:
        """Display a uint8 (height, width, 3) frame and keep the frame rate."""
        size = (frame.shape[1], frame.shape[0])
        if not pygame.display.get_init():
            fallback = start_display()
            if fallback is not None and not self._warned:
                self._warned = True
                gym.logger.warn(
                    f"{self.title}: no display to show render_mode='human' on (SDL fell back to {fallback!r}), so "
                    "nothing is shown; render_mode='rgb_array' returns the frames"
                )
        screen = pygame.display.get_surface()
        if screen is None or screen.get_size() != size or pygame.display.get_caption()[0] != self.title:
            pygame.display.set_caption(self.title)
            screen = pygame.display.set_mode(size)
        if self._clock is None:
            self._clock = pygame.time.Clock()
        _SHOWING.add(self)
        pygame.event.pump()
        screen.blit(pygame.surfarray.make_surface(np.transpose(frame, (1, 0, 2))), (0, 0))
        pygame.display.flip()
        self._clock.tick(max(self.fps, 1.0 / LONGEST_FRAME))

    def close(self) -> None:
        """Leave the display; the last window showing closes it."""
        if self in _SHOWING:
            _SHOWING.discard(self)
            if not _SHOWING and pygame.display.get_init():
                pygame.display.quit()
