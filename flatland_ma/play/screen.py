"""What the play window shows: the rendered world with the driven agent ringed and its
block framed, and beneath it a status bar (the agent, your score, the episode, the keys)."""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from flatland_ma.play.keys import NEXT_AGENT, QUIT
from flatland_ma.play.session import Session
from flatland_ma.render.renderer import Renderer

LINE_HEIGHT = 15
PAD = 4
FONT_SIZE = 12
SEPARATOR = "   "
BAR_COLOR = (15, 15, 15)
STATUS_COLOR = (255, 255, 255)
HELP_COLOR = (170, 170, 170)


class Screen:
    """Frames of a session, all of one size (the window's)."""

    def __init__(self, session: Session):
        self.session = session
        suite = session.env.running.sensors
        own = [[suite.cameras[k] for k in ks] for ks in suite.per_agent]
        self.renderer = Renderer(session.env.spec, own)
        self.font = ImageFont.load_default(FONT_SIZE)
        width = self.renderer.size[0]
        self.help = {a: self._wrap(self._help(a), width - 2 * PAD) for a in session.maps}
        lines = 1 + max(len(lines) for lines in self.help.values())
        self.bar_height = lines * LINE_HEIGHT + 2 * PAD
        self.size = (width, self.renderer.size[1] + self.bar_height)

    def _help(self, agent: str) -> list[str]:
        items = self.session.maps[agent].help()
        if len(self.session.env.possible_agents) > 1:
            items.append(f"{NEXT_AGENT}: switch agent")
        return [*items, f"{QUIT}: quit"]

    def _wrap(self, items: list[str], width: int) -> list[str]:
        """The items on as few lines as fit ``width`` pixels."""
        probe = ImageDraw.Draw(Image.new("RGB", (1, 1)))
        lines, line = [], ""
        for item in items:
            longer = f"{line}{SEPARATOR}{item}" if line else item
            if line and probe.textlength(longer, font=self.font) > width:
                lines.append(line)
                longer = item
            line = longer
        return [*lines, line] if line else lines

    def status(self) -> str:
        """One line: the driven agent, your score with it, its return, the episode."""
        s = self.session
        tally = s.tallies.get(s.agent)
        score = tally.score if tally else 0.0
        episode = min(s.episode + 1, s.episodes)
        said = s.maps[s.agent].said
        saying = f"{SEPARATOR}saying {' '.join(map(str, said))}" if said else ""
        return (
            f"{s.agent}{SEPARATOR}your score {score:g} (its return "
            f"{s.returns.get(s.agent, 0.0):g}){SEPARATOR}episode {episode}/{s.episodes}"
            f"{SEPARATOR}step {s.env.num_steps}{saying}"
        )

    def title(self) -> str:
        return f"flatland-ma play {self.session.scenario}: {self.status()}"

    def frame(self) -> np.ndarray:
        """The picture for the window, uint8 of shape (H, W, 3)."""
        s = self.session
        world = self.renderer.frame(s.env, focus=s.controlled)
        picture = Image.new("RGB", self.size, BAR_COLOR)
        picture.paste(Image.fromarray(world), (0, 0))
        draw = ImageDraw.Draw(picture)
        y = self.renderer.size[1] + PAD
        draw.text((PAD, y), self.status(), fill=STATUS_COLOR, font=self.font)
        for line in self.help[s.agent]:
            y += LINE_HEIGHT
            draw.text((PAD, y), line, fill=HELP_COLOR, font=self.font)
        return np.asarray(picture, np.uint8).copy()
