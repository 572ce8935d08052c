"""The human window (pygame). Imported only when something is shown on screen:
``render_mode="human"``, or ``flatland-ma play``."""

from __future__ import annotations

import numpy as np

from flatland_ma.render.display import missing_display, no_window

try:
    import pygame
except ImportError as err:  # pragma: no cover - depends on the install
    raise ImportError(
        'render_mode="human" and play need pygame: pip install pygame (or, in a clone of '
        "flatland_ma, its render extra: pip install -e '.[render]')"
    ) from err


class Window:
    """One pygame window of a fixed size showing RGB frames."""

    def __init__(self, size: tuple[int, int], title: str):
        no_window(missing_display())  # the display may have gone since the env was made
        pygame.display.init()
        self.screen = pygame.display.set_mode(size)
        pygame.display.set_caption(title)
        self.clock = pygame.time.Clock()
        self.closed_by_user = False

    def events(self) -> list:
        """The events since the last call (pygame's); closing the window is noted in
        ``closed_by_user``."""
        events = pygame.event.get()
        if any(event.type == pygame.QUIT for event in events):
            self.closed_by_user = True
        return events

    def draw(self, frame: np.ndarray) -> None:
        """Put a frame (uint8, H x W x 3) on screen."""
        surface = pygame.surfarray.make_surface(frame.swapaxes(0, 1))
        self.screen.blit(surface, (0, 0))
        pygame.display.flip()

    def title(self, text: str) -> None:
        pygame.display.set_caption(text)

    def tick(self, fps: float) -> None:
        """Wait for the rest of this frame's time at ``fps`` frames a second (0: no wait)."""
        self.clock.tick(fps)

    def picture(self) -> np.ndarray:
        """What the window shows, uint8 of shape (H, W, 3)."""
        return pygame.surfarray.array3d(self.screen).swapaxes(0, 1).copy()

    def show(self, frame: np.ndarray, fps: float) -> None:
        """One frame of ``render_mode="human"``: handle events, draw, keep the pace."""
        self.events()
        self.draw(frame)
        self.tick(fps)

    def close(self) -> None:
        pygame.display.quit()
