"""Cut a flat plate mesh into touching tiles: one object per tile keeps the slicer linear.

PrusaSlicer's cost per object grows faster than its hole count, so a plate with
thousands of holes is sliced as tiles that keep their positions and fuse into one
plate; every seam is placed where it leaves no strip too narrow to print.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..exchange.mesh import read_stl, write_triangles_stl
from ..geometry import index_triangles, mesh_genus
from ..names import slice_tile_name

log = logging.getLogger(__name__)

__all__ = [
    "HOLES_PER_TILE",
    "SEAM_CLEARANCE_MM",
    "choose_seam",
    "hole_boxes",
    "split_into_tiles",
    "tile_grid",
]

#: Holes per tile that keep PrusaSlicer in its linear regime (measured: 250 holes per object
#: sliced at the same cost per hole as 4,000 holes in 16 objects).
HOLES_PER_TILE = 300


def tile_grid(
    size_xy: tuple[float, float], holes: int, holes_per_tile: int = HOLES_PER_TILE
) -> tuple[int, int]:
    """Choose ``(nx, ny)`` tiles so each holds about ``holes_per_tile`` holes and is close to square.

    Args:
        size_xy: Plate size ``(width, height)`` in mm.
        holes: Hole count of the plate.
        holes_per_tile: Target holes per tile. Defaults to :data:`HOLES_PER_TILE`.

    Returns:
        Tile counts along x and y, each at least 1.
    """
    width, height = (max(float(v), 1e-9) for v in size_xy)
    tiles = max(1, int(np.ceil(holes / max(1, holes_per_tile))))
    nx = max(1, int(round(np.sqrt(tiles * width / height))))
    ny = max(1, int(np.ceil(tiles / nx)))
    return nx, ny


#: Material narrower than this next to a seam is a sliver the slicer drops (about one extrusion width), mm.
SEAM_CLEARANCE_MM = 0.5


def hole_boxes(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres and half-sizes of the through holes of a flat plate mesh.

    Every hole's wall is a ring of vertical triangles; the ring whose box is the
    largest is the plate's outer wall and is left out.

    Args:
        triangles: ``(F, 3, 3)`` triangle corners in mm, plate lying flat.

    Returns:
        ``(centres, half_sizes)``: two ``(N, 2)`` arrays in mm (bounding-box centre
        and half extent in x and y of each hole).
    """
    tri = np.asarray(triangles, dtype=np.float64)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normal, axis=1)
    wall = np.abs(normal[:, 2]) < 1e-3 * np.maximum(length, 1e-300)
    if not wall.any():
        return np.zeros((0, 2)), np.zeros((0, 2))
    verts, faces = index_triangles(tri[wall])

    rows = np.concatenate([faces[:, 0], faces[:, 1]])
    cols = np.concatenate([faces[:, 1], faces[:, 2]])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(verts), len(verts)))
    n, labels = connected_components(graph, directed=False)
    lo = np.full((n, 2), np.inf)
    hi = np.full((n, 2), -np.inf)
    np.minimum.at(lo, labels, verts[:, :2])
    np.maximum.at(hi, labels, verts[:, :2])
    size = hi - lo
    keep = np.ones(n, dtype=bool)
    keep[np.argmax(size[:, 0] * size[:, 1])] = False
    return ((lo + hi) / 2)[keep], (size / 2)[keep]


def choose_seam(
    nominal: float,
    centres: np.ndarray,
    half: np.ndarray,
    window: float,
    clearance: float = SEAM_CLEARANCE_MM,
    step: float = 0.05,
) -> float:
    """Place a straight seam near ``nominal`` where it leaves no slivers.

    A seam is good next to a hole when it crosses the hole near its middle
    (the cut web pieces stay wide) or misses it by more than ``clearance``; in
    between it leaves a strip narrower than an extrusion, which the slicer
    drops and which would print as a slit along the seam.

    Args:
        nominal: Seam coordinate wanted (x for a vertical seam), in mm.
        centres: ``(N,)`` hole centres along the same axis, in mm.
        half: ``(N,)`` hole half-sizes along that axis, in mm.
        window: How far the seam may move from ``nominal``, in mm.
        clearance: Narrowest strip kept between a seam and a hole, in mm.
            Defaults to :data:`SEAM_CLEARANCE_MM`.
        step: Search step in mm. Defaults to 0.05 mm.

    Returns:
        The seam coordinate with the fewest bad holes (the nearest to
        ``nominal`` among equals).
    """
    k = int(np.floor(window / step))
    candidates = nominal + step * np.arange(-k, k + 1)
    near = np.abs(centres - nominal) < window + half + clearance
    c, h = centres[near], half[near]
    if len(c) == 0:
        return float(nominal)
    d = np.abs(c[None, :] - candidates[:, None])
    bad = ((d > 0.5 * h[None, :]) & (d < h[None, :] + clearance)).sum(axis=1)
    score = bad + np.abs(candidates - nominal) / (4 * window + 1e-9)
    return float(candidates[np.argmin(score)])


def split_into_tiles(
    model: str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    holes_per_tile: int = HOLES_PER_TILE,
    grid: tuple[int, int] | None = None,
    overlap_mm: float = 0.0,
) -> list[Path]:
    """Cut a flat plate mesh into touching rectangular tiles, one STL per tile.

    Sliced as separate objects that keep their positions (``--merge
    --dont-arrange``), the tiles print side by side and fuse into one plate,
    while the slicer's per-object work stays small: PrusaSlicer's cost per
    object grows faster than its hole count, so tiles make the total linear.
    Each seam is moved (up to 3 mm) to where it crosses holes through their
    middle or clears them by :data:`SEAM_CLEARANCE_MM` (see
    :func:`choose_seam`), so no strip too narrow to print runs along it.
    Needs ``manifold3d`` for the watertight cut.

    Args:
        model: Closed plate mesh (STL), lying flat.
        out_dir: Existing folder for ``tile_<i>_<j>.stl``.
        holes_per_tile: Target holes per tile when ``grid`` is None. Defaults
            to :data:`HOLES_PER_TILE`.
        grid: Explicit ``(nx, ny)`` tile counts; overrides ``holes_per_tile``.
        overlap_mm: Width of the strip two neighbouring tiles share at a seam,
            in mm, for a stronger weld (0 = tiles touch exactly). Defaults to 0 mm.

    Returns:
        Paths of the written tiles (a single path when one tile suffices).

    Raises:
        ImportError: ``manifold3d`` is not installed.
        ValueError: The mesh is not a closed manifold.
    """
    import manifold3d as m3d

    tri = read_stl(model)
    verts, faces = index_triangles(tri)
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    if grid is None:
        grid = tile_grid((hi[0] - lo[0], hi[1] - lo[1]), mesh_genus(tri), holes_per_tile)
    nx, ny = (max(1, int(g)) for g in grid)
    out_dir = Path(out_dir)
    if nx * ny == 1:
        dest = out_dir / slice_tile_name(0, 0)
        write_triangles_stl(dest, tri)
        return [dest]
    solid = m3d.Manifold(
        m3d.Mesh(vert_properties=verts.astype(np.float32), tri_verts=faces.astype(np.uint32))
    )
    if solid.status() != m3d.Error.NoError or solid.is_empty():
        raise ValueError(f"{model}: not a closed manifold mesh ({solid.status()})")
    xs = np.linspace(lo[0], hi[0], nx + 1)
    ys = np.linspace(lo[1], hi[1], ny + 1)
    if nx > 1 or ny > 1:
        centres, half = hole_boxes(tri)
        for axis, cuts in ((0, xs), (1, ys)):
            pitch = cuts[1] - cuts[0] if len(cuts) > 2 else 0.0
            for k in range(1, len(cuts) - 1):
                cuts[k] = choose_seam(cuts[k], centres[:, axis], half[:, axis], window=min(3.0, pitch / 4))
    pad = 1.0 + overlap_mm
    paths: list[Path] = []
    for i in range(nx):
        for j in range(ny):
            # Outer edges get a margin so the box never grazes the plate's own boundary faces.
            x0 = xs[i] - (pad if i == 0 else overlap_mm / 2)
            x1 = xs[i + 1] + (pad if i == nx - 1 else overlap_mm / 2)
            y0 = ys[j] - (pad if j == 0 else overlap_mm / 2)
            y1 = ys[j + 1] + (pad if j == ny - 1 else overlap_mm / 2)
            box = m3d.Manifold.cube([x1 - x0, y1 - y0, hi[2] - lo[2] + 2.0]).translate([x0, y0, lo[2] - 1.0])
            piece = (solid ^ box).to_mesh()
            if len(piece.tri_verts) == 0:
                continue
            corners = np.asarray(piece.vert_properties, dtype=np.float64)[:, :3][np.asarray(piece.tri_verts)]
            dest = out_dir / slice_tile_name(i, j)
            write_triangles_stl(dest, corners)
            paths.append(dest)
    log.info("split %s into %d x %d tiles", model, nx, ny)
    return paths
