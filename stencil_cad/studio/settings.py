"""The page's settings as a job config: the bundled example's keys with what the maker chose on top."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

from ..errors import UserError
from ..names import profile_json, upload_png
from .workspace import Workspace

#: The settings the page sends, with their defaults (the bundled example's).
DEFAULTS: dict[str, Any] = {
    "image": None,
    "width_mm": 150.0,
    "process": "fdm",
    "bed": "",
    "layers": 4,
    "paints": "auto",
    "distance_m": 1.0,
    "standoff_mm": None,
    "profile": None,
    "crop": None,
}
#: The least a crop keeps of the picture, in pixels each way.
MIN_CROP_PX = 8


def example_data() -> dict[str, Any]:
    """The bundled example's config as a mapping (without its image: a config without one uses the example)."""
    import yaml

    from ..imaging import example_config_path

    data = yaml.safe_load(example_config_path().read_text(encoding="utf-8"))
    data.pop("image", None)
    return dict(data)


def config_data(settings: dict[str, Any], ws: Workspace) -> tuple[dict[str, Any], Path | None]:
    """The config mapping of the page's ``settings``, and the picture it names (None: the bundled example).

    The values are checked by the config itself when the mapping is loaded (:func:`stencil_cad.api.load_config`),
    with its messages.

    Raises:
        UserError: An unknown setting, or a picture that is not in the workspace (evicted: upload it again).
    """
    unknown = sorted(set(settings) - set(DEFAULTS))
    if unknown:
        raise UserError(f"unknown setting(s): {', '.join(unknown)}; the page sends {', '.join(DEFAULTS)}")
    s = {**DEFAULTS, **{k: v for k, v in settings.items() if v is not None or k == "standoff_mm"}}
    data = example_data()
    picture = None
    if s["image"]:
        picture = ws.upload_path(str(s["image"]))
        if picture is None:
            raise UserError(
                "the picture is no longer in the studio's workspace (old uploads are removed); upload it again"
            )
        data["image"] = str(picture)
    if s["crop"] is not None:
        from ..imaging import example_image_path

        picture = cropped(picture or example_image_path(), s["crop"], ws)
        data["image"] = str(picture)
    data["size"] = {**data.get("size", {}), "width_mm": s["width_mm"]}
    data["decompose"] = {**data.get("decompose", {}), "layers": s["layers"]}
    if s["paints"] != "auto":
        data["decompose"]["palette"] = list(s["paints"])
    data["stipple"] = {**data.get("stipple", {}), "process": s["process"]}
    data["view"] = {**data.get("view", {}), "distance_m": s["distance_m"]}
    if s["standoff_mm"] not in (None, "", "auto"):
        data["wall"] = {**data.get("wall", {}), "standoff_mm": [s["standoff_mm"]]}
    if s["bed"]:
        data["bed"] = s["bed"]
    if s["profile"]:
        data["spray"] = {**data.get("spray", {}), "profile": profile_mapping(s["profile"], ws)}
    return data, picture


def profile_key_of(profile_id: str, ws: Workspace) -> str:
    """The ``spray.profile`` key of a kept profile: the paint it was measured for (``default``: every layer)."""
    import json

    from ..config.profiles import DEFAULT_KEY

    meta = ws.profiles / profile_json(profile_id)
    try:
        return str(json.loads(meta.read_text(encoding="utf-8")).get("key") or DEFAULT_KEY)
    except (OSError, ValueError):
        return DEFAULT_KEY


def profile_mapping(chosen: Any, ws: Workspace) -> dict[str, str]:
    """The chosen profiles (one id or a list of ids) as ``spray.profile``'s mapping ``{paint key: file}``.

    Each profile is keyed by the paint the wizard measured it for (a layer number, ``#rrggbb``, a can's
    name, or ``default`` for every layer no other key names).

    Raises:
        UserError: A profile is no longer in the workspace, or two chosen profiles are for the same paint.
    """
    ids = [chosen] if isinstance(chosen, str) else chosen
    if not isinstance(ids, list) or not all(isinstance(i, str) for i in ids):
        raise UserError("profile: give the id of a spray profile, or a list of ids (one per paint)")
    mapping: dict[str, str] = {}
    for profile_id in ids:
        path = ws.profile_path(profile_id)
        if path is None:
            raise UserError("the spray profile is no longer in the studio's workspace; calibrate again")
        key = profile_key_of(profile_id, ws)
        if key in mapping:
            raise UserError(
                f"two of the chosen spray profiles are for the same paint ({key}): choose one profile per paint"
            )
        mapping[key] = str(path)
    return mapping


def can_list() -> list[dict[str, str]]:
    """The bundled can list (name, code, hex): the paints the page offers with swatches."""
    from importlib import resources

    text = (resources.files("stencil_cad") / "data" / "example_cans.csv").read_text(encoding="utf-8")
    rows = csv.DictReader(line for line in text.splitlines() if line and not line.startswith("#"))
    return [{"name": r["name"], "code": r["code"], "hex": r["hex"]} for r in rows]


def crop_box(crop: Any, width_px: int, height_px: int) -> tuple[int, int, int, int]:
    """The pixels ``(left, top, right, bottom)`` of ``crop`` (``[x, y, w, h]`` in % of the picture).

    Raises:
        UserError: The crop is not four numbers inside the picture, or keeps fewer than :data:`MIN_CROP_PX`.
    """
    shape = "crop: give [x, y, width, height] in % of the picture (e.g. [10, 10, 80, 80]), or none"
    if not isinstance(crop, list) or len(crop) != 4:
        raise UserError(shape)
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in crop):
        raise UserError(shape)
    x, y, w, h = (float(v) for v in crop)
    if min(x, y) < 0.0 or w <= 0.0 or h <= 0.0 or x + w > 100.0 + 1e-6 or y + h > 100.0 + 1e-6:
        raise UserError(
            f"crop {crop} reaches outside the picture: keep x + width and y + height within 100 %"
        )
    box = (
        round(x / 100.0 * width_px),
        round(y / 100.0 * height_px),
        min(width_px, round((x + w) / 100.0 * width_px)),
        min(height_px, round((y + h) / 100.0 * height_px)),
    )
    if box[2] - box[0] < MIN_CROP_PX or box[3] - box[1] < MIN_CROP_PX:
        raise UserError(
            f"crop {crop} keeps {box[2] - box[0]} × {box[3] - box[1]} pixels of the "
            f"{width_px} × {height_px} picture; keep at least {MIN_CROP_PX} each way"
        )
    return box


def cropped(source: Path, crop: Any, ws: Workspace) -> Path:
    """``source`` cropped to ``crop`` (see :func:`crop_box`), as a picture of its own in the workspace's uploads.

    The picture is turned upright first (as the page shows it); the cropped file is named by the source and
    the crop, so the same crop again is the same file (the previews' cache keeps it). Written whole or not at all.

    Raises:
        UserError: The crop is wrong (nothing is written).
    """
    import hashlib

    from PIL import Image, ImageOps

    ident = hashlib.sha256(f"{source.name}:{[float(v) for v in crop]}".encode()).hexdigest()[:32]
    with Image.open(source) as im:
        upright = ImageOps.exif_transpose(im)
        box = crop_box(crop, *upright.size)
        done = ws.upload_path(ident)
        if done is not None:
            return done
        out = ws.uploads / upload_png(ident)
        part = ws.tmp / upload_png(ident)
        icc = upright.info.get("icc_profile")
        try:
            upright.crop(box).save(part, format="PNG", **({"icc_profile": icc} if icc else {}))
            part.replace(out)
        finally:
            part.unlink(missing_ok=True)
    return out
