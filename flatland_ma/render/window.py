"""The human window (pygame). Imported only when ``render_mode="human"`` draws."""

from __future__ import annotations

import numpy as np

try:
    import pygame
except ImportError as err:  # pragma: no cover - depends on the install
    raise ImportError(
        'render_mode="human" needs pygame: pip install "flatland-ma[render]"'
    ) from err


class Window:
    def __init__(self, size: tuple[int, int], title: str):
        pygame.display.init()
        self.screen = pygame.display.set_mode(size)
        pygame.display.set_caption(title)
        self.clock = pygame.time.Clock()
        self.closed_by_user = False

    def show(self, frame: np.ndarray, fps: int) -> None:
        for event in pygame.event.get():
            if event.type == pygame.QUIT:
                self.closed_by_user = True
        surface = pygame.surfarray.make_surface(frame.swapaxes(0, 1))
        self.screen.blit(surface, (0, 0))
        pygame.display.flip()
        self.clock.tick(fps)

    def close(self) -> None:
        pygame.display.quit()
