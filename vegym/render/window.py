"""An on-screen window for ``render_mode="human"``; the only place vegym initialises a display."""

from __future__ import annotations

import numpy as np
import pygame


class Window:
    """Shows RGB frames at ``fps`` frames per second (``pygame.display.init()`` on the first frame)."""

    def __init__(self, title: str, fps: float) -> None:
        self.title = title
        self.fps = fps
        self._screen: pygame.Surface | None = None
        self._clock: pygame.time.Clock | None = None

    def show(self, frame: np.ndarray) -> None:
        """Display a uint8 (height, width, 3) frame and keep the frame rate."""
        if self._screen is None:
            pygame.display.init()
            pygame.display.set_caption(self.title)
            self._screen = pygame.display.set_mode((frame.shape[1], frame.shape[0]))
            self._clock = pygame.time.Clock()
        pygame.event.pump()
        self._screen.blit(pygame.surfarray.make_surface(np.transpose(frame, (1, 0, 2))), (0, 0))
        pygame.display.flip()
        assert self._clock is not None
        self._clock.tick(self.fps)

    def close(self) -> None:
        if self._screen is not None:
            pygame.display.quit()
            self._screen = None
