"""Pictures of the mesh check: the part and its convex pieces, from above and from the side,
and a depth image of a settled pile of it. No display and no GL: the meshes are drawn with
OpenCV (orthographic, far triangles first, each shaded by how squarely it faces the viewer).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import trimesh

from tangle_drake.graspability.overlay import depth_preview

PANEL_PX = 320
PART_COLOUR = (200, 200, 205)
"""BGR of the part; the pieces take turns in :data:`PIECE_COLOURS`."""
PIECE_COLOURS = ((80, 160, 240), (90, 200, 120), (230, 140, 90), (200, 110, 200),
                 (90, 210, 220), (150, 150, 240), (120, 220, 170), (240, 180, 120))
VIEWS = {"from above": (0, 1, 2), "from the side": (0, 2, 1)}
"""Each view's image right, image up and towards-the-viewer axes (of the mesh's frame)."""


def shaded_view(meshes: list[trimesh.Trimesh], colours: list[tuple[int, int, int]],
                axes: tuple[int, int, int], extent: float, size: int = PANEL_PX) -> np.ndarray:
    """The ``meshes`` drawn orthographically along ``axes`` into a ``size`` square, BGR;
    ``extent`` metres span the square (the same for every panel, so they compare)."""
    image = np.full((size, size, 3), 255, np.uint8)
    right, up, toward = axes
    scale = 0.9 * size / extent
    triangles, shades = [], []
    for mesh, colour in zip(meshes, colours, strict=True):
        normals = mesh.face_normals[:, toward]
        light = 0.35 + 0.65 * np.abs(normals)
        for tri, bright in zip(mesh.triangles, light, strict=True):
            triangles.append(tri)
            shades.append(tuple(int(c * bright) for c in colour))
    if not triangles:
        return image
    tris = np.asarray(triangles)
    order = np.argsort(tris[:, :, toward].mean(axis=1))  # far first
    centre = size / 2
    for k in order:
        tri = tris[k]
        points = np.stack([centre + scale * tri[:, right], centre - scale * tri[:, up]], axis=1)
        cv2.fillConvexPoly(image, np.round(points * 16).astype(np.int32), shades[k],
                           lineType=cv2.LINE_AA, shift=4)
    return image


def part_picture(surface: trimesh.Trimesh, pieces: list[trimesh.Trimesh]) -> np.ndarray:
    """A 2 x 2 sheet: the part and its convex pieces, from above and from the side."""
    centre = surface.bounds.mean(axis=0)
    surface = surface.copy()
    surface.apply_translation(-centre)
    moved = []
    for piece in pieces:
        piece = piece.copy()
        piece.apply_translation(-centre)
        moved.append(piece)
    extent = float(np.max(surface.extents)) * 1.05
    rows = []
    for meshes, colours, what in (
            ([surface], [PART_COLOUR], "the part"),
            (moved, [PIECE_COLOURS[i % len(PIECE_COLOURS)] for i in range(len(moved))],
             f"its {len(moved)} convex pieces")):
        panels = []
        for view, axes in VIEWS.items():
            panel = shaded_view(meshes, colours, axes, extent)
            cv2.putText(panel, f"{what}, {view}", (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5,
                        (40, 40, 40), 1, cv2.LINE_AA)
            panels.append(panel)
        rows.append(np.hstack(panels))
    sheet = np.vstack(rows)
    cv2.putText(sheet, f"{1000 * extent / 1.05:.0f} mm across", (8, sheet.shape[0] - 10),
                cv2.FONT_HERSHEY_SIMPLEX, 0.5, (40, 40, 40), 1, cv2.LINE_AA)
    return sheet


def write_pictures(directory: Path, surface: trimesh.Trimesh, pieces: list[trimesh.Trimesh],
                   pile_depth: np.ndarray | None) -> list[Path]:
    """``part.png`` and, given a settled pile's depth image, ``pile.png``; their paths."""
    written = [directory / "part.png"]
    cv2.imwrite(str(written[0]), part_picture(surface, pieces))
    if pile_depth is not None:
        written.append(directory / "pile.png")
        cv2.imwrite(str(written[1]), depth_preview(pile_depth))
    return written
