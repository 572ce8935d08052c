"""An episode's WebSocket: messages in (``studio.socket_messages``), frames and state out.

Each connection holds at most one episode, and the studio at most ``limits.episodes`` at
once: a connection takes a slot with its first episode (one more is told so and closed,
``CLOSE_BUSY``). Frames go out at the speed asked for, never above ``limits.fps``: a JSON
``state`` text message, then the picture as a binary message (JPEG, or PNG). The world is
stepped and drawn in a worker thread, so the server goes on answering others meanwhile.

A bad message, scenario or policy is answered with an ``error`` message and the
connection stays open, the episode running before still running (a refused policy's
error names its ``agent``). When the connection must end, the page is told why first: an
``error`` message with ``"fatal": true``, then the close with the same reason, and the
page may connect again. It ends when the page has said nothing (``alive`` every 20
seconds) for ``limits.idle_episode_seconds`` (``CLOSE_IDLE``), or when stepping or
drawing the episode fails (``CLOSE_FAILED``). What a page can make the server keep is
bounded: keys are those of the key table only, and only while playing.
"""

from __future__ import annotations

import asyncio
import collections
import json
import secrets
import time
from dataclasses import dataclass, field

import anyio
from pydantic import ValidationError
from starlette.websockets import WebSocket, WebSocketDisconnect

from flatland_ma.play.keys import SCRIPT_KEYS, Keys
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.studio import socket_messages as messages
from flatland_ma.studio.episodes import Play, PolicyRefused, Watch, resolve_policy
from flatland_ma.studio.folders import FolderError
from flatland_ma.studio.scenarios import encode, problem_json
from flatland_ma.studio.workspace import Workspace

CLOSE_BUSY = 1013
"""WebSocket close code: try again later (every episode slot is taken)."""
CLOSE_TOO_BIG = 1009
CLOSE_FAILED = 1011
"""The episode failed while it was stepped or drawn."""
CLOSE_IDLE = 4000
"""The page said nothing for ``limits.idle_episode_seconds``."""
MAX_REASON = 120
"""Bytes of a close frame's reason (the protocol allows 123)."""


@dataclass
class Recording:
    """The latest frames an episode sent (encoded), each with the frame rate the page
    asked for when it was sent, for its GIF."""

    image: str
    frames: collections.deque = field(default_factory=collections.deque)


class Hub:
    """The studio's episodes: slots, and each one's recording while it is open."""

    def __init__(self, workspace: Workspace):
        self.workspace = workspace
        self.limits = workspace.config.limits
        self.running = 0
        self.recordings: dict[str, Recording] = {}
        self.connections: set[Connection] = set()
        """The open connections (each one's state is bounded; see the module)."""

    async def serve(self, ws: WebSocket) -> None:
        await ws.accept()
        key = secrets.token_urlsafe(12)
        connection = Connection(self, ws, key)
        self.connections.add(connection)
        try:
            await connection.run()
        except WebSocketDisconnect:  # the page left while a frame was on its way
            pass
        finally:
            self.connections.discard(connection)
            if connection.slot:
                self.running -= 1
            self.recordings.pop(key, None)

    def take_slot(self) -> bool:
        """An episode slot, if one is free."""
        if self.running >= self.limits.episodes:
            return False
        self.running += 1
        return True


async def _send_error(
    ws: WebSocket, message: str, problems: list | None = None, **more: object
) -> None:
    error = {"type": "error", "message": message, "problems": problems, **more}
    await ws.send_text(json.dumps(error))


async def _end(ws: WebSocket, code: int, message: str) -> None:
    """Tell the page why, then close with the same reason."""
    try:
        await _send_error(ws, message, fatal=True, code=code)
        reason = message.encode()[:MAX_REASON].decode(errors="ignore")
        await ws.close(code, reason)
    except (WebSocketDisconnect, RuntimeError, OSError):
        pass


class Connection:
    """One page's episode: a reader of messages and a loop that sends frames."""

    def __init__(self, hub: Hub, ws: WebSocket, key: str):
        self.hub, self.ws, self.key = hub, ws, key
        self.limits = hub.limits
        self.episode: Watch | Play | None = None
        self.start: messages.Start | None = None
        self.fps = 10.0
        self.running = False
        self.steps_asked = 0
        self.held: set[str] = set()
        self.pressed: set[str] = set()
        self.inbox: asyncio.Queue = asyncio.Queue(maxsize=64)
        self.slot = False
        """Whether this connection holds one of the hub's episode slots."""
        self.heard = 0.0
        """When the page last sent a message (the event loop's clock)."""

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        self.heard = loop.time()
        reader = asyncio.create_task(self._read())
        next_tick = loop.time()
        idle = self.limits.idle_episode_seconds
        try:
            while True:
                ticking = self.episode is not None and (
                    self.running or self.steps_asked or self.episode.mode == "play"
                )
                now = loop.time()
                wake = self.heard + idle
                if ticking:
                    wake = min(wake, next_tick)
                try:  # a message waiting goes first, even when frames are late
                    if self.inbox.empty():
                        message = await asyncio.wait_for(self.inbox.get(), max(0.0, wake - now))
                    else:
                        message = self.inbox.get_nowait()
                except asyncio.TimeoutError:
                    if loop.time() - self.heard >= idle:
                        await _end(
                            self.ws, CLOSE_IDLE, f"closed: the page said nothing for {idle:g} s"
                        )
                        return
                    if ticking:
                        next_tick = loop.time() + 1.0 / self.fps
                        if not await self._tick_or_end():
                            return
                    continue
                if message is None:
                    return
                await self._handle(message)
        finally:
            reader.cancel()
            if self.episode is not None:
                self.episode.close()

    async def _tick_or_end(self) -> bool:
        """One tick; if stepping or drawing fails, the page is told why and the
        connection ends (False)."""
        try:
            await self._tick()
        except (WebSocketDisconnect, asyncio.CancelledError):
            raise
        except Exception as err:  # the episode is lost; the server and the page go on
            detail = self.hub.workspace.public(str(err).splitlines()[0] if str(err) else "")
            message = f"the episode stopped: {type(err).__name__}: {detail}"[:400]
            await _end(self.ws, CLOSE_FAILED, message)
            return False
        return True

    async def _read(self) -> None:
        """Messages into the inbox (None when the page leaves); a bad one is answered."""
        try:
            while True:
                event = await self.ws.receive()
                if event["type"] == "websocket.disconnect":
                    break
                self.heard = asyncio.get_running_loop().time()
                text = event.get("text")
                if text is None:
                    await _send_error(self.ws, "messages are JSON text, not binary")
                    continue
                size, small = len(text.encode()), self.limits.message_bytes
                too_big = (
                    f"{size:,} bytes: a message holds {small:,} (a start, with its text, more)"
                )
                try:
                    if size > small + self.limits.file_bytes:
                        raise ValueError(too_big)
                    message = messages.parse(text)
                    if size > small and not isinstance(message, messages.Start):
                        raise ValueError(too_big)
                except (ValidationError, ValueError) as err:
                    await _send_error(
                        self.ws, too_big if size > small else messages.error_text(err)
                    )
                    continue
                if isinstance(message, messages.KeysMessage):  # at once: keys are not queued
                    if isinstance(self.episode, Play):  # known keys only: a bounded set
                        self.held = set(message.held) & SCRIPT_KEYS
                        self.pressed |= set(message.pressed) & SCRIPT_KEYS
                    continue
                if message.type == "alive":
                    continue
                await self.inbox.put(message)
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            await self.inbox.put(None)

    async def _handle(self, message) -> None:
        if isinstance(message, messages.Start):
            await self._start(message, message.seed)
        elif isinstance(message, messages.Reset):
            if self.start is None:
                await _send_error(self.ws, "reset before start: send a start message first")
            else:
                await self._start(self.start, message.seed)
        elif isinstance(message, messages.Speed):
            self.fps = min(message.fps, self.limits.fps)
        elif self.episode is None:
            await _send_error(self.ws, f"{message.type} before start: send start first")
        elif message.type == "play":
            self.running = True
        elif message.type == "pause":
            self.running, self.steps_asked = False, 0
        elif message.type == "step":
            self.running = False
            self.steps_asked = min(self.steps_asked + 1, 1000)

    async def _start(self, start: messages.Start, seed: int) -> None:
        """A new episode; the old one, if any, is closed once the new one is made (a
        refused start leaves it running)."""
        if not self.slot:
            if not self.hub.take_slot():
                await _end(
                    self.ws, CLOSE_BUSY, f"busy: {self.limits.episodes} episodes run at once"
                )
                raise WebSocketDisconnect(CLOSE_BUSY)
            self.slot = True
        public = self.hub.workspace.public
        try:
            episode = await anyio.to_thread.run_sync(self._make, start, seed)
        except ScenarioError as err:
            problems = [problem_json(p) for p in err.problems]
            for problem in problems:
                problem["source"] = public(str(problem["source"]))
                problem["message"] = public(str(problem["message"]))
            await _send_error(self.ws, "the scenario cannot be used", problems)
            return
        except PolicyRefused as err:
            await _send_error(self.ws, public(str(err)), agent=err.agent)
            return
        except (FolderError, ValueError, TypeError) as err:
            await _send_error(self.ws, public(str(err)))
            return
        if self.episode is not None:
            self.episode.close()
        self.running, self.steps_asked = False, 0
        self.held, self.pressed = set(), set()
        self.episode, self.start = episode, start
        self.fps = min(start.fps, self.limits.fps)
        recording = Recording(start.image)
        recording.frames = collections.deque(maxlen=self.limits.recorded_frames)
        self.hub.recordings[self.key] = recording
        ready = {
            "type": "ready",
            "episode": self.key,
            "mode": episode.mode,
            "agents": episode.env.possible_agents,
            "keys": episode.keys() if isinstance(episode, Play) else {},
            "fps": self.fps,
            "max_fps": self.limits.fps,
        }
        await self.ws.send_text(json.dumps(ready))
        await self._send_frame()

    def _make(self, start: messages.Start, seed: int) -> Watch | Play:
        workspace = self.hub.workspace
        if start.text is not None:
            folder = workspace.folder(start.folder) if start.folder is not None else None
            spec = workspace.spec_of_text(start.text, "<editor>", folder)
            label = "<editor>"
        elif start.scenario is not None:
            spec = workspace.spec(start.scenario)
            label = start.scenario
        else:
            raise ValueError("start names a scenario (a reference) or gives its text")
        checkpoints = workspace.config.checkpoints
        if start.mode == "play":
            others = None if start.others is None else resolve_policy(start.others, checkpoints)
            return Play(spec, seed, others, label, workspace.config.scores)
        unknown = sorted(set(start.policies) - set(spec.agent_names))
        if unknown:
            raise ValueError(f"no agent {unknown[0]!r}; agents: {', '.join(spec.agent_names)}")
        policies = {}
        for agent, name in start.policies.items():
            try:
                policies[agent] = resolve_policy(name, checkpoints)
            except ValueError as err:
                raise PolicyRefused(agent, str(err)) from None
        return Watch(spec, seed, policies)

    async def _tick(self) -> None:
        episode = self.episode
        assert episode is not None
        began = time.time()
        if isinstance(episode, Play):
            keys = Keys(frozenset(self.pressed), frozenset(self.held))
            self.pressed = set()
            if await anyio.to_thread.run_sync(episode.advance, keys):
                await self._send_frame(began)
            return
        if self.steps_asked:
            self.steps_asked -= 1
        if await anyio.to_thread.run_sync(episode.advance):
            await self._send_frame(began)
        if episode.done:
            self.running, self.steps_asked = False, 0

    async def _send_frame(self, began: float | None = None) -> None:
        """The state (``began``: the wall-clock time its step began, for latency) and
        the picture."""
        began = time.time() if began is None else began
        episode = self.episode
        assert episode is not None
        recording = self.hub.recordings[self.key]

        def draw() -> tuple[dict, bytes]:
            return episode.state(), encode(episode.frame(), recording.image)

        state, picture = await anyio.to_thread.run_sync(draw)
        recording.frames.append((picture, self.fps))
        await self.ws.send_text(json.dumps({"type": "state", **state, "began": began}))
        await self.ws.send_bytes(picture)
