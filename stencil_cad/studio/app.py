"""The studio's routes: the page, uploads, previews streamed as they improve, making a job, its files.

Every route answers a problem the maker can fix with a 4xx status and ``{"error": message}``, the message
the command line gives for the same input.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import json
import threading
from collections.abc import AsyncIterator, Generator
from importlib import resources
from pathlib import Path
from typing import Any

from starlette.applications import Starlette
from starlette.concurrency import iterate_in_threadpool, run_in_threadpool
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response, StreamingResponse
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from .. import api
from ..errors import UserError
from ..files import DATA_LIMIT
from ..names import job_zip_download
from .calibrate import Calibration
from .jobs import JOB_ZIP, Busy, Jobs
from .settings import DEFAULTS, can_list, config_data
from .workspace import Workspace, new_id

STATIC = Path(str(resources.files("stencil_cad.studio") / "static"))


def _error(message: str, status: int = 400) -> JSONResponse:
    return JSONResponse({"error": message}, status_code=status)


class Previews:
    """One preview at a time: a newer request cancels the older one's work (it is not queued)."""

    def __init__(self) -> None:
        self.cache = api.preview_cache()
        self.lock = threading.Lock()
        self.switch = threading.Lock()
        self.current: api.CancelToken | None = None

    def start(self) -> api.CancelToken:
        """A token for a new preview; the one before it is cancelled."""
        token = api.CancelToken()
        with self.switch:
            if self.current is not None:
                self.current.cancel()
            self.current = token
        return token

    def events(self, cfg: Any, token: api.CancelToken) -> Generator[dict[str, Any], None, None]:
        """The preview's levels as page events, until the last one or until a newer preview cancels it.

        The lock is held while a level is computed, never while the event waits to be sent: a page
        that asks for a newer preview while a level is being computed leaves this generator at its
        next ``yield`` for good (the stream that read it is gone), and a lock held there would keep
        every later preview waiting.
        """
        levels = api.previews(cfg, self.cache, token)
        try:
            while True:
                with self.lock:
                    token.check()
                    p = next(levels, None)
                    if p is None:
                        return
                    event = {
                        **p.figures(),
                        "sprayed": _data_url(p.sprayed),
                        "reference": _data_url(p.reference),
                        "size_px": [int(p.sprayed.shape[1]), int(p.sprayed.shape[0])],
                    }
                yield event
        except api.Cancelled:
            yield {"level": "cancelled"}
        except UserError as exc:
            yield {"level": "error", "error": str(exc)}


def _data_url(img: Any) -> str:
    from ..exchange.png import png_bytes

    return "data:image/png;base64," + base64.b64encode(png_bytes(img)).decode("ascii")


def _sse(event: dict[str, Any]) -> str:
    return f"data: {json.dumps(event)}\n\n"


def create_app(workspace: Workspace) -> Starlette:
    """The studio's ASGI application over ``workspace`` (swept of what a killed server left)."""
    workspace.sweep()
    studio = Studio(workspace)
    wizard = Calibration(workspace)
    routes = [
        Route("/api/card", wizard.card, methods=["POST"]),
        Route("/api/cards/{card_id}/files/{name:path}", wizard.card_file),
        Route("/api/calibrate", wizard.fit, methods=["POST"]),
        Route("/api/profiles", wizard.profiles),
        Route("/", studio.index),
        Route("/api/options", studio.options),
        Route("/api/upload", studio.upload, methods=["POST"]),
        Route("/api/pictures/{picture_id}", studio.picture),
        Route("/api/preview", studio.preview),
        Route("/api/jobs", studio.make, methods=["POST"]),
        Route("/api/jobs", studio.job_list, methods=["GET"]),
        Route("/api/jobs/{job_id}/events", studio.job_events),
        Route("/api/jobs/{job_id}/cancel", studio.cancel, methods=["POST"]),
        Route("/api/jobs/{job_id}/files/{name:path}", studio.job_file),
        Mount("/static", app=StaticFiles(directory=STATIC), name="static"),
    ]
    app = Starlette(routes=routes)
    app.state.studio = studio
    return app


class Studio:
    """The routes' state: the workspace, its job maker and the preview in progress."""

    def __init__(self, workspace: Workspace) -> None:
        self.ws = workspace
        self.jobs = Jobs(workspace)
        self.previews = Previews()

    async def index(self, request: Request) -> Response:
        """``GET /``: the page."""
        return FileResponse(STATIC / "index.html")

    async def options(self, request: Request) -> Response:
        """``GET /api/options``: the defaults, processes, beds and cans the page offers."""
        from ..config.bed import BED_PRESETS
        from ..config.stipple import Process

        return JSONResponse(
            {
                "defaults": DEFAULTS,
                "processes": [p.value for p in Process],
                "beds": list(BED_PRESETS),
                "cans": can_list(),
                "workspace": str(self.ws.root),
            }
        )

    async def upload(self, request: Request) -> Response:
        """``POST /api/upload?name=…``: the picture as the request's body; checked as the command line checks an image, kept only if it passes."""
        name = Path(request.query_params.get("name", "picture")).name or "picture"
        upload_id = new_id()
        tmp = self.ws.tmp / f"{upload_id}.upload"
        length = request.headers.get("content-length", "")
        if length.isdigit() and int(length) > DATA_LIMIT:
            # The command line's words for a file over the limit (stencil_cad.files).
            return _error(
                f"image {name} is {int(length) / 1e6:.1f} MB, more than the {DATA_LIMIT / 1e6:.0f} MB "
                "stencil-cad reads (check the path, or the `image:` key of the config)",
                413,
            )
        try:
            size = 0
            with open(tmp, "wb") as fh:
                async for chunk in request.stream():
                    size += len(chunk)
                    if size > DATA_LIMIT:
                        break
                    fh.write(chunk)
            if size > DATA_LIMIT:
                return _error(
                    f"image {name} is more than the {DATA_LIMIT / 1e6:.0f} MB stencil-cad reads "
                    "(check the path, or the `image:` key of the config)",
                    413,
                )
            try:
                w, h = await run_in_threadpool(api.check_image, tmp)
            except UserError as exc:
                return _error(str(exc).replace(str(tmp), name))
            kept = self.ws.uploads / f"{upload_id}{_suffix(tmp)}"
            tmp.replace(kept)
            self.ws.evict(keep={upload_id})
            return JSONResponse({"id": upload_id, "name": name, "width_px": w, "height_px": h})
        finally:
            tmp.unlink(missing_ok=True)

    async def picture(self, request: Request) -> Response:
        """``GET /api/pictures/<id>``: an uploaded picture as it was uploaded (``example``: the bundled one), to crop."""
        from ..imaging import example_image_path

        ident = request.path_params["picture_id"]
        path = example_image_path() if ident == "example" else self.ws.upload_path(ident)
        if path is None:
            return _error("no such picture in the studio's workspace; upload it again", 404)
        return FileResponse(path)

    def settings_config(self, settings: Any) -> tuple[dict[str, Any], Any, Path | None]:
        """The page's settings as ``(config mapping, checked config, picture)``.

        Raises:
            UserError: A setting or a config value is wrong (the config's own message).
        """
        if not isinstance(settings, dict):
            raise UserError("settings must be a JSON object")
        data, picture = config_data(settings, self.ws)
        return data, api.load_config(data), picture

    async def preview(self, request: Request) -> Response:
        """``GET /api/preview?settings=…``: the previews as server-sent events, coarse first; a newer one cancels it."""
        try:
            settings = json.loads(request.query_params.get("settings", "{}"))
            _, cfg, _ = self.settings_config(settings)
        except (UserError, ValueError) as exc:
            return _error(str(exc))
        token = self.previews.start()

        events = self.previews.events(cfg, token)

        async def stream() -> AsyncIterator[str]:
            try:
                async for event in iterate_in_threadpool(events):
                    yield _sse(event)
                    if await request.is_disconnected():
                        return
            finally:
                # A page that went away or asked for a newer preview: stop the work, free the lock.
                token.cancel()
                with contextlib.suppress(ValueError):
                    await run_in_threadpool(events.close)

        return StreamingResponse(
            stream(), media_type="text/event-stream", headers={"Cache-Control": "no-store"}
        )

    async def make(self, request: Request) -> Response:
        """``POST /api/jobs``: start making the job of the settings in the body (409 while one is being made)."""
        try:
            data, cfg, picture = self.settings_config(await request.json())
        except (UserError, ValueError) as exc:
            return _error(str(exc))
        try:
            job = self.jobs.start(data, picture)
        except Busy as exc:
            return _error(str(exc), 409)
        return JSONResponse({"id": job.id})

    async def job_events(self, request: Request) -> Response:
        """``GET /api/jobs/<id>/events``: the job's progress per stage as server-sent events, then how it ended."""
        job = self.jobs.get(request.path_params["job_id"])
        if job is None:
            return _error("no such job is being made", 404)

        async def stream() -> AsyncIterator[str]:
            sent = 0
            while True:
                events = job.events[sent:]
                for e in events:
                    yield _sse(e)
                sent += len(events)
                if job.state != "running" and sent == len(job.events):
                    return
                if await request.is_disconnected():
                    return
                await asyncio.sleep(0.2)

        return StreamingResponse(
            stream(), media_type="text/event-stream", headers={"Cache-Control": "no-store"}
        )

    async def cancel(self, request: Request) -> Response:
        """``POST /api/jobs/<id>/cancel``: stop making the job; nothing of it is kept."""
        ok = await run_in_threadpool(self.jobs.cancel, request.path_params["job_id"])
        return JSONResponse({"cancelled": ok}, status_code=200 if ok else 409)

    async def job_list(self, request: Request) -> Response:
        """``GET /api/jobs``: the finished jobs in the workspace, newest first."""
        return JSONResponse([{"id": p.name} for p in self.ws.finished_jobs()])

    async def job_file(self, request: Request) -> Response:
        """``GET /api/jobs/<id>/files/<name>``: a file of a finished job (``job.zip``, ``output/instructions.html``, …)."""
        folder = self.ws.job_dir(request.path_params["job_id"])
        if folder is None:
            return _error("no such job in the workspace", 404)
        path = self.ws.file_in(folder, request.path_params["name"])
        if path is None:
            return _error("no such file in the job", 404)
        self.ws.touch(folder)
        if path.name == JOB_ZIP:
            return FileResponse(path, filename=job_zip_download(folder.name[:8]))
        return FileResponse(path)


def _suffix(path: Path) -> str:
    """The file suffix of the image at ``path`` by its content (Pillow's format)."""
    from PIL import Image

    with Image.open(path) as im:
        fmt = (im.format or "PNG").lower()
    return {"jpeg": ".jpg", "tiff": ".tif"}.get(fmt, f".{fmt}")
