"""The studio's HTTP endpoints (JSON in and out, pictures as PNG, episodes as GIF).

=================================  ===============================================
GET  /api/info                     folders, policies, limits
GET  /api/gallery                  every scenario's card (reference, description, id)
GET  /api/picture?ref=R&seed=S     PNG of a scenario's layout
GET  /api/scenario?ref=R           its YAML text
GET  /api/schema                   the JSON schema of scenario files
POST /api/validate {text, folder}  {ok, problems: [{line, path, message}]}
POST /api/preview {text, seed}     PNG of the layout, or 422 with the problems
POST /api/save {text, folder,      writes FILE into folder N: {ref}
     name, overwrite}
GET  /api/episodes/K/gif           the open episode K's latest frames as a GIF
=================================  ===============================================

Every refusal is a JSON ``{"error": message}`` (with ``problems`` for a scenario) and a
4xx status; the work of checking and drawing runs in worker threads, a few at a time.
"""

from __future__ import annotations

import io
import json
import tempfile
from pathlib import Path

import anyio
from PIL import Image
from starlette.requests import Request
from starlette.responses import JSONResponse, Response

from flatland_ma.options import MAX_SEED
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.json_schema import file_schema
from flatland_ma.studio.episodes import policy_names
from flatland_ma.studio.folders import FolderError
from flatland_ma.studio.scenarios import encode, layout_picture, problem_json
from flatland_ma.studio.sockets import Hub
from flatland_ma.studio.workspace import Workspace


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


def scenario_refusal(err: ScenarioError) -> Refused:
    return Refused(422, "the scenario cannot be used", [problem_json(p) for p in err.problems])


class Api:
    """The endpoints over one workspace and its episodes."""

    def __init__(self, workspace: Workspace, hub: Hub):
        self.workspace = workspace
        self.hub = hub
        self.limits = workspace.config.limits
        self.workers = anyio.CapacityLimiter(self.limits.work)

    async def work(self, function, *args):
        """``function(*args)`` in a worker thread; faults of the input become refusals."""
        try:
            return await anyio.to_thread.run_sync(function, *args, limiter=self.workers)
        except ScenarioError as err:
            raise scenario_refusal(err) from None
        except FolderError as err:
            raise Refused(400, str(err)) from None

    async def body(self, request: Request) -> dict:
        """The request's JSON object, refused past ``limits.request_bytes``."""
        limit = self.limits.request_bytes
        declared = request.headers.get("content-length", "0")
        if not declared.isdigit() or int(declared) > limit:
            raise Refused(413, f"a request's body holds at most {limit:,} bytes")
        data = bytearray()
        async for chunk in request.stream():
            data += chunk
            if len(data) > limit:
                raise Refused(413, f"a request's body holds at most {limit:,} bytes")
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
                "folders": [str(f) for f in config.folders],
                "policies": policy_names(checkpoints),
                "limits": self.limits.__dict__,
                "scores": str(config.scores) if config.scores else None,
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
            spec = await self.work(self.workspace.spec_of_text, text, name, folder)
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

        return Response(await self.work(draw), media_type="image/png")

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
        from flatland_ma.render.video import save_gif

        recording = self.hub.recordings.get(request.path_params["key"])
        if recording is None or not recording.frames:
            raise Refused(404, "no open episode by that key, or no frame yet")
        encoded, fps = list(recording.frames), recording.fps

        def write() -> bytes:
            frames = [_decode(data) for data in encoded]
            with tempfile.TemporaryDirectory(prefix="studio-gif-") as folder:
                path = save_gif(frames, Path(folder) / "episode.gif", fps=fps)
                return path.read_bytes()

        gif = await self.work(write)
        headers = {"Content-Disposition": 'attachment; filename="episode.gif"'}
        return Response(gif, media_type="image/gif", headers=headers)


def _decode(data: bytes):
    import numpy as np

    with Image.open(io.BytesIO(data)) as image:
        return np.asarray(image.convert("RGB"))


def _seed(value: object) -> int:
    text = str(value)
    if not text.isdigit() or len(text) > 10 or int(text) > MAX_SEED:
        raise Refused(400, f"seed: a whole number from 0 to {MAX_SEED:,}")
    return int(text)
