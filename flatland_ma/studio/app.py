"""The studio as an ASGI app (Starlette): the API, the episode socket, the built pages,
and the guards every request passes first.

Guards, in order:

- the token, when the studio has one (it listens beyond the loopback): a request must
  carry it as the header ``X-Studio-Token``, the query ``?token=``, or the cookie the
  first page load sets; otherwise 403 (a WebSocket is closed with 1008);
- the ``Origin`` of a WebSocket or a POST, when sent, must be the studio's own address,
  so another site open in the same browser can drive nothing;
- bound to the loopback, the ``Host`` must be a loopback name (no DNS rebinding);
- at most ``limits.requests`` requests that passed the checks above are answered at
  once (503 past it); refused ones are answered at once and never counted, so clients
  without the token cannot crowd out the one with it (``serving`` closes connections
  that never send a request).
"""

from __future__ import annotations

import secrets
from importlib import resources
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.types import ASGIApp, Receive, Scope, Send

from flatland_ma.studio.api import Api, Quiet, Refused
from flatland_ma.studio.config import LOOPBACK, StudioConfig
from flatland_ma.studio.sockets import Hub
from flatland_ma.studio.workspace import Workspace

TOKEN_HEADER = "x-studio-token"
TOKEN_COOKIE = "flatland_studio_token"
CLOSE_POLICY = 1008


def static_dir() -> Path:
    """The built pages, shipped as package data."""
    return Path(str(resources.files("flatland_ma.studio"))) / "static"


class Guard:
    """ASGI middleware: the token, the origin and the host (see the module's docstring)."""

    def __init__(self, app: ASGIApp, token: str | None, local: bool, requests: int = 64):
        self.app, self.token, self.local = app, token, local
        self.requests = requests
        self.answering = 0
        """Requests that passed the checks being answered now (WebSockets not counted:
        the episode slots bound them)."""

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        headers = {k.decode("latin-1"): v.decode("latin-1") for k, v in scope["headers"]}
        problem = self._problem(scope, headers)
        if problem is None and scope["type"] == "websocket":
            return await self.app(scope, receive, send)
        if problem is None:
            if self.answering >= self.requests:
                busy = {"error": f"busy: {self.requests} requests are being answered"}
                return await JSONResponse(busy, status_code=503)(scope, receive, send)
            self.answering += 1
            try:
                return await self.app(scope, receive, send)
            finally:
                self.answering -= 1
        if scope["type"] == "websocket":
            await receive()  # the connect event
            await send({"type": "websocket.close", "code": CLOSE_POLICY, "reason": problem})
            return
        await JSONResponse({"error": problem}, status_code=403)(scope, receive, send)

    def _problem(self, scope: Scope, headers: dict[str, str]) -> str | None:
        host = headers.get("host", "")
        if self.local and _hostname(host) not in LOOPBACK:
            return f"this studio answers on the loopback only, not as {host!r}"
        origin = headers.get("origin")
        unsafe = scope["type"] == "websocket" or scope.get("method") not in ("GET", "HEAD")
        if origin is not None and unsafe and urlsplit(origin).netloc != host:
            return f"requests from {origin!r} are refused: open the studio at its own address"
        if self.token is None:
            return None
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        given = [headers.get(TOKEN_HEADER, ""), *query.get("token", [])]
        given.append(_cookie(headers.get("cookie", ""), TOKEN_COOKIE))
        if any(g and secrets.compare_digest(g, self.token) for g in given):
            return None
        return "this studio needs its token (printed when it started): open the URL it printed"


def _hostname(host: str) -> str:
    if host.startswith("["):
        return host[1:].partition("]")[0]
    return host.rpartition(":")[0] if host.count(":") == 1 else host


def _cookie(header: str, name: str) -> str:
    for part in header.split(";"):
        key, _, value = part.strip().partition("=")
        if key == name:
            return value
    return ""


def create_app(config: StudioConfig, local: bool = True) -> Starlette:
    """The studio over ``config``; ``local``: it listens on the loopback only."""
    workspace = Workspace(config)
    hub = Hub(workspace)
    api = Api(workspace, hub)

    async def index(request: Request) -> Response:
        page = static_dir() / "index.html"
        if not page.is_file():
            return JSONResponse({"error": "the pages are not built (make studio-assets)"}, 500)
        response = FileResponse(page, headers={"Cache-Control": "no-cache"})
        if config.token is not None:
            response.set_cookie(TOKEN_COOKIE, config.token, httponly=True, samesite="strict")
        return response

    async def refused(request: Request, exc: Exception) -> Response:
        assert isinstance(exc, Refused)
        return exc.response()

    async def quiet(request: Request, exc: Exception) -> Response:
        return Response(status_code=400)  # the client has gone: nobody reads it

    routes = [
        Route("/", index),
        Route("/api/info", api.info),
        Route("/api/gallery", api.gallery),
        Route("/api/picture", api.picture),
        Route("/api/scenario", api.scenario),
        Route("/api/schema", api.schema),
        Route("/api/policies", api.policies),
        Route("/api/validate", api.validate, methods=["POST"]),
        Route("/api/preview", api.preview, methods=["POST"]),
        Route("/api/save", api.save, methods=["POST"]),
        Route("/api/episodes/{key}/gif", api.gif, methods=["POST"]),
        Route("/api/gifs/{job}", api.gif_progress),
        Route("/api/gifs/{job}/file", api.gif_file),
        WebSocketRoute("/api/episode", hub.serve),
    ]
    assets = static_dir() / "assets"
    if assets.is_dir():
        routes.append(Mount("/assets", StaticFiles(directory=assets), name="assets"))
    app = Starlette(routes=routes, exception_handlers={Refused: refused, Quiet: quiet})
    app.add_middleware(Guard, token=config.token, local=local, requests=config.limits.requests)
    app.state.workspace, app.state.hub, app.state.api = workspace, hub, api
    return app
