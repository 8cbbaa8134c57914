"""An on-screen window for ``render_mode="human"``; the only place vegym initialises a display."""

from __future__ import annotations

import weakref

import numpy as np
import pygame

LONGEST_FRAME = 1.0
"""Seconds a frame stays at most: an env whose steps last longer (BouncingBall with little gravity, say) is shown
faster than real time rather than holding the window, which cannot be interrupted while it waits."""
_SHOWING: weakref.WeakSet[Window] = weakref.WeakSet()
"""The windows that have shown a frame and are not closed nor collected: they share pygame's one display."""


class Window:
    """Shows RGB frames at ``fps`` frames per second, at least one per :data:`LONGEST_FRAME` seconds
    (``pygame.display.init()`` on the first frame).

    pygame has one display per process: windows of several envs take turns in it (the display takes each one's
    size and title when it shows a frame), and it is closed with the last of them. A display stopped elsewhere
    (``pygame.quit()``) is started again at the next frame."""

    def __init__(self, title: str, fps: float) -> None:
        self.title = title
        self.fps = fps
        self._clock: pygame.time.Clock | None = None

    def show(self, frame: np.ndarray) -> None:
        """Display a uint8 (height, width, 3) frame and keep the frame rate."""
        size = (frame.shape[1], frame.shape[0])
        if not pygame.display.get_init():
            pygame.display.init()
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
