"""The studio's HTTP endpoints (JSON in and out, pictures as PNG, episodes as GIF).

=================================  ===============================================
GET  /api/info                     folders, policies, limits
GET  /api/gallery                  every scenario's card (reference, description, id)
GET  /api/picture?ref=R&seed=S     PNG of a scenario's layout
GET  /api/scenario?ref=R           its YAML text
GET  /api/schema                   the JSON schema of scenario files
GET  /api/policies?ref=R           each agent's policies that suit it, and its default
POST /api/validate {text, folder}  {ok, problems: [{line, path, message}]}
POST /api/preview {text, seed}     PNG of the layout, or 422 with the problems
POST /api/save {text, folder,      writes FILE into folder N: {ref}
     name, overwrite}
POST /api/episodes/K/gif           starts a GIF of the open episode K's latest frames
GET  /api/gifs/J                   its progress: {done, total, ready, bytes}
GET  /api/gifs/J/file              the GIF, once ready
=================================  ===============================================

Every refusal is a JSON ``{"error": message}`` (with ``problems`` for a scenario) and a
4xx status, every number too (``whole_number``); no message shows the server's own
paths (``Workspace.public``). The work runs in worker threads: the pages' reads in a pool
of their own, heavy jobs (checks, previews, policies, GIFs) in ``lanes.Lanes``, one at a
time per client with stale requests superseded, so the reads never wait behind them.
"""

from __future__ import annotations

import json
from pathlib import Path

import anyio
from starlette.requests import ClientDisconnect, Request
from starlette.responses import JSONResponse, Response

from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.json_schema import file_schema
from flatland_ma.studio.config import MAX_SEED
from flatland_ma.studio.episodes import agent_policies, policy_names
from flatland_ma.studio.folders import FolderError
from flatland_ma.studio.gifs import Gifs
from flatland_ma.studio.lanes import Lanes, Superseded, client_of
from flatland_ma.studio.scenarios import encode, layout_picture, problem_json
from flatland_ma.studio.sockets import Hub
from flatland_ma.studio.workspace import Workspace

MAX_DIGITS = 10
"""Digits of a whole number a request may give (seeds, sizes)."""


class Quiet(Exception):
    """The client left while its request was read: nothing to answer, nothing to log."""


class Refused(Exception):
    """A request answered with ``status`` and ``message``."""

    def __init__(self, status: int, message: str, problems: list | None = None):
        super().__init__(message)
        self.status, self.message, self.problems = status, message, problems

    def response(self) -> JSONResponse:
        body: dict = {"error": self.message}
        if self.problems is not None:
            body["problems"] = self.problems
        return JSONResponse(body, status_code=self.status)


class Api:
    """The endpoints over one workspace and its episodes."""

    def __init__(self, workspace: Workspace, hub: Hub):
        self.workspace = workspace
        self.hub = hub
        self.limits = workspace.config.limits
        self.readers = anyio.CapacityLimiter(self.limits.work)
        """Threads for the pages' reads (gallery, pictures, info, texts)."""
        self.lanes = Lanes(self.limits.work, self.limits.clients)
        """Heavy jobs: one at a time per client, over threads of their own."""
        self.gifs = Gifs(self.limits.gifs, self.limits.gif_width, self.lanes.limiter)

    def refusal(self, err: Exception) -> Refused:
        """A fault of the input as a refusal, without the server's paths."""
        public = self.workspace.public
        if isinstance(err, ScenarioError):
            problems = [problem_json(p) for p in err.problems]
            for problem in problems:
                problem["source"] = public(str(problem["source"]))
                problem["message"] = public(str(problem["message"]))
            return Refused(422, "the scenario cannot be used", problems)
        return Refused(400, public(str(err)))

    async def work(self, function, *args):
        """A read: ``function(*args)`` in a reader thread; faults of the input become
        refusals."""
        try:
            return await anyio.to_thread.run_sync(function, *args, limiter=self.readers)
        except (ScenarioError, FolderError) as err:
            raise self.refusal(err) from None

    async def heavy(self, request: Request, kind: str, function, *args):
        """A heavy job of ``kind`` in the client's lane (409 if a newer one replaced it)."""
        client = client_of(request.headers, request.client) + "/" + kind

        async def wanted() -> bool:
            return not await request.is_disconnected()

        try:
            return await self.lanes.run(client, function, *args, wanted=wanted)
        except Superseded:
            raise Refused(409, "superseded by a newer request from the same page") from None
        except (ScenarioError, FolderError) as err:
            raise self.refusal(err) from None

    async def body(self, request: Request) -> dict:
        """The request's JSON object, refused past ``limits.request_bytes``."""
        limit = self.limits.request_bytes
        declared = whole_number(request.headers.get("content-length", "0"), "content-length")
        if declared > limit:
            raise Refused(413, f"a request's body holds at most {limit:,} bytes")
        data = bytearray()
        try:
            async for chunk in request.stream():
                data += chunk
                if len(data) > limit:
                    raise Refused(413, f"a request's body holds at most {limit:,} bytes")
        except ClientDisconnect:
            raise Quiet() from None
        try:
            value = json.loads(data)
        except (ValueError, RecursionError):
            raise Refused(400, "the body is not JSON") from None
        if not isinstance(value, dict):
            raise Refused(400, "the body is a JSON object")
        return value

    # -- endpoints --------------------------------------------------------------------

    async def info(self, request: Request) -> Response:
        checkpoints = await self.work(self.workspace.checkpoints)
        config = self.workspace.config
        return JSONResponse(
            {
                "folders": [f.name for f in config.folders],
                "policies": policy_names(checkpoints),
                "limits": self.limits.__dict__,
                "scores": config.scores.name if config.scores else None,
            }
        )

    async def gallery(self, request: Request) -> Response:
        def cards() -> list[dict]:
            return [self.workspace.entry(ref) for ref in self.workspace.refs()]

        return JSONResponse(await self.work(cards))

    async def picture(self, request: Request) -> Response:
        ref = request.query_params.get("ref", "")
        seed = _seed(request.query_params.get("seed", "0"))
        png = await self.work(self.workspace.picture, ref, seed)
        return Response(png, media_type="image/png", headers={"Cache-Control": "no-cache"})

    async def scenario(self, request: Request) -> Response:
        ref = request.query_params.get("ref", "")
        text = await self.work(self.workspace.text, ref)
        return JSONResponse({"ref": ref, "text": text})

    async def schema(self, request: Request) -> Response:
        return JSONResponse(await self.work(file_schema))

    async def policies(self, request: Request) -> Response:
        ref = request.query_params.get("ref", "")

        def offered() -> list[dict]:
            spec = self.workspace.spec(ref)
            return agent_policies(spec, self.workspace.fitting_checkpoints)

        return JSONResponse({"ref": ref, "agents": await self.heavy(request, "policies", offered)})

    def _text(self, body: dict) -> tuple[str, Path | None]:
        text = body.get("text")
        if not isinstance(text, str):
            raise Refused(400, "text: the scenario's YAML, as a string")
        if len(text.encode()) > self.limits.file_bytes:
            raise Refused(413, f"a scenario holds at most {self.limits.file_bytes:,} bytes")
        folder = body.get("folder")
        try:
            return text, None if folder is None else self.workspace.folder(folder)
        except FolderError as err:
            raise Refused(400, str(err)) from None

    async def validate(self, request: Request) -> Response:
        text, folder = self._text(await self.body(request))
        name = str(request.query_params.get("name", "<editor>"))[:200]
        try:
            spec = await self.heavy(
                request, "edit", self.workspace.spec_of_text, text, name, folder
            )
        except Refused as refused:
            if refused.problems is None:
                raise
            return JSONResponse({"ok": False, "problems": refused.problems})
        return JSONResponse({"ok": True, "problems": [], "n_agents": spec.n_agents})

    async def preview(self, request: Request) -> Response:
        body = await self.body(request)
        text, folder = self._text(body)
        seed = _seed(body.get("seed", 0))

        def draw() -> bytes:
            spec = self.workspace.spec_of_text(text, "<editor>", folder)
            return encode(layout_picture(spec, seed))

        return Response(await self.heavy(request, "edit", draw), media_type="image/png")

    async def save(self, request: Request) -> Response:
        from flatland_ma.studio.folders import write_file

        body = await self.body(request)
        text, _ = self._text(body)
        index, name = body.get("folder"), body.get("name")
        overwrite = body.get("overwrite", False) is True
        folder = await self.work(self.workspace.folder, index)
        limit = self.limits.file_bytes
        try:
            await self.work(write_file, folder, name, text, limit, overwrite)
        except Refused as refused:
            if "exists already" in refused.message:
                refused.status = 409
            raise
        return JSONResponse({"ref": f"{index}:{name}"}, status_code=201)

    async def gif(self, request: Request) -> Response:
        recording = self.hub.recordings.get(request.path_params["key"])
        if recording is None or not recording.frames:
            raise Refused(404, "no open episode by that key, or no frame yet")
        job = self.gifs.start(list(recording.frames))
        if job is None:
            raise Refused(429, f"{self.limits.gifs} GIFs are being made already: try again")
        return JSONResponse(job.progress(), status_code=202)

    async def gif_progress(self, request: Request) -> Response:
        job = self.gifs.get(request.path_params["job"])
        if job is None:
            raise Refused(404, "no GIF by that key (made too long ago?)")
        return JSONResponse(job.progress())

    async def gif_file(self, request: Request) -> Response:
        job = self.gifs.get(request.path_params["job"])
        if job is None or job.data is None:
            raise Refused(404, "no GIF by that key ready (ask its progress first)")
        headers = {"Content-Disposition": 'attachment; filename="episode.gif"'}
        return Response(job.data, media_type="image/gif", headers=headers)


def whole_number(value: object, name: str, high: int | None = None) -> int:
    """``value`` (text or an int) as a whole number from 0 to ``high``; ``Refused`` (400)
    for anything else, digits outside ASCII ("²", "٣") included."""
    text = str(value)
    if (
        isinstance(value, bool)
        or not (text.isascii() and text.isdigit())
        or len(text) > MAX_DIGITS
        or (high is not None and int(text) > high)
    ):
        bound = f" to {high:,}" if high is not None else ""
        raise Refused(400, f"{name}: a whole number from 0{bound}, not {text[:20]!r}")
    return int(text)


def _seed(value: object) -> int:
    return whole_number(value, "seed", MAX_SEED)
