"""The calibration wizard's routes: the card to print, the photo of the sprayed card fitted, the profile kept.

The card is :func:`stencil_cad.api.make_card` for the page's settings (their holes, plate and wall), made
in ``cards/.making-<id>`` and renamed when whole. A photo is fitted by :func:`stencil_cad.api.calibrate`
(the ``calibrate`` command's fit and messages); the profile it writes is kept in ``profiles/`` under an
identifier, with the paint it was measured for (the key of ``spray.profile``'s mapping: a layer number, a
``#rrggbb`` code, a can's name, or ``default`` when no paint is given), and a later job sprays that paint with
it when the page chooses it (:func:`stencil_cad.studio.settings.profile_mapping`).
"""

from __future__ import annotations

import json
import os
import shutil
from typing import Any

from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response

from .. import api
from ..config.profiles import DEFAULT_KEY, profile_key
from ..errors import UserError
from ..files import DATA_LIMIT
from ..names import CARD_JSON, PROFILE_JSON_PATTERN, profile_json, profile_yaml
from .settings import config_data
from .workspace import MAKING, Workspace, new_id


def _error(message: str, status: int = 400) -> JSONResponse:
    return JSONResponse({"error": message}, status_code=status)


class Calibration:
    """The wizard's routes over a workspace."""

    def __init__(self, ws: Workspace) -> None:
        self.ws = ws

    async def card(self, request: Request) -> Response:
        """``POST /api/card``: the calibration card for the settings in the body; its id and files."""
        try:
            data, _ = config_data(await request.json(), self.ws)
            cfg = api.load_config(data)
        except (UserError, ValueError) as exc:
            return _error(str(exc))
        card_id = new_id()
        making = self.ws.cards / f"{MAKING}{card_id}"
        try:
            result = await run_in_threadpool(api.make_card, cfg, making)
        except UserError as exc:
            shutil.rmtree(making, ignore_errors=True)
            return _error(str(exc))
        os.replace(making, self.ws.cards / card_id)
        c = result.figures.card or {}
        return JSONResponse(
            {
                "id": card_id,
                "files": sorted(p.name for p in result.files),
                "passes": c.get("passes"),
                "standoffs_mm": c.get("standoffs_mm"),
            }
        )

    async def card_file(self, request: Request) -> Response:
        """``GET /api/cards/<id>/files/<name>``: a file of a card (``card_sheet.pdf``, ``card_plate.stl`` …)."""
        folder = self.ws.card_dir(request.path_params["card_id"])
        path = None if folder is None else self.ws.file_in(folder, request.path_params["name"])
        if path is None:
            return _error("no such file of a card in the workspace", 404)
        return FileResponse(path)

    async def fit(self, request: Request) -> Response:
        """``POST /api/calibrate?card=<id>&paint=…&name=…``: fit the photo in the body; keep the profile it gives."""
        folder = self.ws.card_dir(request.query_params.get("card", ""))
        if folder is None:
            return _error("make the card first: no such card in the workspace", 404)
        name = os.path.basename(request.query_params.get("name", "photo")) or "photo"
        paint = request.query_params.get("paint", "").strip()[:200]
        try:
            key = profile_key(paint) if paint else DEFAULT_KEY
        except ValueError as exc:
            return _error(f"paint: {exc}")
        ident = new_id()
        photo = self.ws.tmp / f"{ident}.photo"
        profile = self.ws.tmp / profile_yaml(ident)
        try:
            size = 0
            with open(photo, "wb") as fh:
                async for chunk in request.stream():
                    size += len(chunk)
                    if size > DATA_LIMIT:
                        return _error(
                            f"photo {name} is more than the {DATA_LIMIT / 1e6:.0f} MB stencil-cad reads", 413
                        )
                    fh.write(chunk)
            try:
                fit, report = await run_in_threadpool(
                    api.calibrate, photo, folder / CARD_JSON, profile, paint=paint
                )
            except UserError as exc:
                return _error(str(exc).replace(str(photo), name))
            figures = {
                **_fit_figures(fit, paint, name, report.replace(str(profile), "the profile")),
                "key": key,
            }
            (self.ws.profiles / profile_json(ident)).write_text(json.dumps(figures), encoding="utf-8")
            os.replace(profile, self.ws.profiles / profile_yaml(ident))
            return JSONResponse({"id": ident, **figures})
        finally:
            photo.unlink(missing_ok=True)
            profile.unlink(missing_ok=True)

    async def profiles(self, request: Request) -> Response:
        """``GET /api/profiles``: the spray profiles kept, with the paint each was measured for."""
        out = []
        for p in sorted(
            self.ws.profiles.glob(PROFILE_JSON_PATTERN), key=lambda p: p.stat().st_mtime, reverse=True
        ):
            if self.ws.profile_path(p.stem) is not None:
                out.append({"id": p.stem, **json.loads(p.read_text(encoding="utf-8"))})
        return JSONResponse(out)


def _fit_figures(fit: Any, paint: str, photo: str, report: str) -> dict[str, Any]:
    """What the page shows of a fit: the constants, the residuals, the markers found."""
    can = fit.can
    info = fit.info or {}
    return {
        "paint": paint or "any paint",
        "photo": photo,
        "spread_k": round(float(can.spread_k), 4),
        "bleed_sigma_mm": round(float(can.bleed_sigma_mm), 4),
        "deposit_per_pass": round(float(can.deposit_per_pass), 4),
        "residual_rms": round(float(fit.residual_rms), 4),
        "feature_residuals": {k: round(float(v), 4) for k, v in fit.feature_residuals.items()},
        "markers_found": [int(m) for m in info.get("markers_found", [])],
        "standoffs_mm": [float(g) for g in info.get("standoffs_mm", [])],
        "noise": info.get("noise"),
        "report": report,
    }
