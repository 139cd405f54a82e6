"""A decomposition as NPZ arrays (``layers.npz``): written and read back without pickle."""

from __future__ import annotations

import json
from collections.abc import Mapping

import numpy as np

from ..model import Layers

__all__ = ["layers_from_npz", "layers_to_npz"]


def layers_to_npz(layers: Layers) -> dict[str, np.ndarray]:
    """Arrays to save a decomposition with ``np.savez_compressed``.

    Keys: ``primer`` (3,), ``colours`` (L, 3), ``alphas`` (L, H, W) float32,
    ``mm_per_px`` (), ``energy_trace`` (n,), ``iterations`` (), ``info_json``
    (a 0-d string array holding ``info`` as JSON). Loads without pickle.
    """
    return {
        "primer": np.asarray(layers.primer, dtype=np.float64),
        "colours": np.asarray(layers.colours, dtype=np.float64),
        "alphas": np.asarray(layers.alphas, dtype=np.float32),
        "mm_per_px": np.asarray(layers.mm_per_px, dtype=np.float64),
        "energy_trace": np.asarray(layers.energy_trace, dtype=np.float64),
        "iterations": np.asarray(layers.iterations, dtype=np.int64),
        "info_json": np.asarray(json.dumps(layers.info, default=_json_default)),
    }


def _json_default(obj: object) -> object:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)


def layers_from_npz(mapping: Mapping[str, np.ndarray]) -> Layers:
    """Inverse of :func:`layers_to_npz` (accepts the mapping ``np.load`` returns).

    Raises:
        ValueError: A required key is missing or the shapes disagree.
    """
    for key in ("primer", "colours", "alphas"):
        if key not in mapping:
            raise ValueError(f"layers NPZ has no {key!r} array")
    primer = np.asarray(mapping["primer"], dtype=np.float64).reshape(3)
    colours = np.asarray(mapping["colours"], dtype=np.float64)
    alphas = np.asarray(mapping["alphas"], dtype=np.float64)
    if colours.ndim != 2 or colours.shape[1] != 3 or alphas.ndim != 3 or alphas.shape[0] != colours.shape[0]:
        raise ValueError(
            f"layers NPZ: colours {colours.shape} and alphas {alphas.shape} do not match (L, 3) and (L, H, W)"
        )
    info = json.loads(str(mapping["info_json"])) if "info_json" in mapping else {}
    return Layers(
        primer=primer,
        colours=colours,
        alphas=alphas,
        mm_per_px=float(mapping["mm_per_px"]) if "mm_per_px" in mapping else 1.0,
        energy_trace=tuple(float(e) for e in np.asarray(mapping.get("energy_trace", ()))),
        iterations=int(mapping["iterations"]) if "iterations" in mapping else 0,
        info=info,
    )
