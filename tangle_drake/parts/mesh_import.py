"""A user's part from a mesh file: read, scale, repair, and cut into convex pieces with CoACD.

Drake uses the convex hull of any collision mesh, so a hook given as one mesh would collide as
a solid blob and never tangle; CoACD splits it into convex pieces that follow its concavities.
"""

from __future__ import annotations

import io
from pathlib import Path

import coacd
import numpy as np
import trimesh

from tangle_drake.common.errors import TangleDrakeError

MESH_SUFFIXES: tuple[str, ...] = (".obj", ".stl", ".ply")

# CoACD settings, chosen to be quick for small parts: concavity threshold 0.05 (of the part's
# size) is CoACD's default quality; at most 16 pieces keeps contact cheap; a smaller, shallower
# tree search (10 nodes, 60 iterations, depth 2 instead of 20/150/3) and a coarser sampling
# resolution (1000 instead of 2000) cut the time several-fold on the wire parts' tubes, with
# about as many pieces and hulls as close to the part's volume (figures: docs/performance.md);
# a fixed seed makes the pieces, hence the cached files, reproducible.
# "auto" preprocessing remeshes inputs that are not manifold: that is how CoACD copes with a
# mesh our repair could not close, slowly (tens of seconds or more).
COACD_PARAMS: dict[str, object] = {
    "threshold": 0.05,
    "max_convex_hull": 16,
    "preprocess_mode": "auto",
    "preprocess_resolution": 50,
    "resolution": 1000,
    "mcts_nodes": 10,
    "mcts_iterations": 60,
    "mcts_max_depth": 2,
    "seed": 0,
}

# Convex pieces smaller than this (m^3) are flat slivers: nothing to collide with.
_MIN_PIECE_VOLUME = 1e-12


def read_mesh(data: bytes, suffix: str, path: Path, scale: float) -> tuple[trimesh.Trimesh, int]:
    """Parse a mesh file's bytes, scale to metres, repair, and say how many holes were capped.

    Text (OBJ, ASCII STL) that is not UTF-8 (a Latin-1 comment, or garbage) is decoded
    leniently here, so a stray byte does not reject a good file and garbage fails to parse
    (trimesh would otherwise guess the encoding with an optional package).

    Repair: merge duplicate vertices, drop degenerate and repeated faces, make the winding
    consistent and outward (trimesh's `fix_normals`), then close every hole with a flat
    triangle fan from its centroid (trimesh's `fill_holes` only closes 3- and 4-edge holes;
    CAD exports often lack whole end faces). The result may still not be watertight (e.g.
    edges shared by three faces); callers check `is_volume`. Raises `TangleDrakeError` for
    files that cannot be read or hold no triangles.
    """
    if suffix == ".obj" or (suffix == ".stl" and not _is_binary_stl(data)):
        data = data.decode("utf-8", errors="replace").encode("utf-8")
    try:
        mesh = trimesh.load_mesh(io.BytesIO(data), file_type=suffix.lstrip("."), process=True)
    except Exception as exc:  # trimesh raises many types for malformed files
        raise TangleDrakeError(
            f"cannot read mesh file {path}: {type(exc).__name__}: {exc}; "
            "give a valid OBJ, STL or PLY file"
        ) from exc
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise TangleDrakeError(
            f"mesh file {path} contains no triangles; give a surface mesh (OBJ, STL or PLY)"
        )
    if not np.all(np.isfinite(mesh.vertices)):
        raise TangleDrakeError(f"mesh file {path} has non-finite vertex coordinates")
    mesh.apply_scale(scale)
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    mesh.remove_unreferenced_vertices()
    holes = 0
    if not mesh.is_volume:
        trimesh.repair.fix_normals(mesh)
        mesh, holes = _cap_holes(mesh)
        trimesh.repair.fix_normals(mesh)
    return mesh, holes


def _is_binary_stl(data: bytes) -> bool:
    """Binary STL: an 80-byte header, a triangle count, and 50 bytes per triangle."""
    return len(data) >= 84 and len(data) == 84 + 50 * int.from_bytes(data[80:84], "little")


def _cap_holes(mesh: trimesh.Trimesh) -> tuple[trimesh.Trimesh, int]:
    """Close each loop of boundary edges with a fan of triangles from the loop's centroid.

    Boundary half-edges (those whose reverse no face has) are followed head to tail, which
    also splits holes that touch at a vertex into separate loops; the fan triangles run
    against the loop so their winding matches the faces around the hole.
    """
    half_edges = mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    present = {(int(a), int(b)) for a, b in half_edges}
    outgoing: dict[int, list[int]] = {}
    for a, b in half_edges:
        if (int(b), int(a)) not in present:
            outgoing.setdefault(int(a), []).append(int(b))
    vertices, faces = [np.asarray(mesh.vertices)], [np.asarray(mesh.faces)]
    count, loops = len(mesh.vertices), 0
    for start in sorted(outgoing):
        while outgoing.get(start):
            loop, vertex = [start], outgoing[start].pop()
            while vertex != start and outgoing.get(vertex):
                loop.append(vertex)
                vertex = outgoing[vertex].pop()
            if vertex != start or len(loop) < 3:
                continue  # not a closed loop (non-manifold boundary): leave it open
            vertices.append(mesh.vertices[loop].mean(axis=0, keepdims=True))
            ring = np.array(loop)
            faces.append(np.column_stack([np.full(len(ring), count), np.roll(ring, -1), ring]))
            count, loops = count + 1, loops + 1
    if loops == 0:
        return mesh, 0
    return trimesh.Trimesh(np.vstack(vertices), np.vstack(faces), process=True), loops


def convex_pieces(mesh: trimesh.Trimesh, path: Path) -> list[trimesh.Trimesh]:
    """CoACD's convex decomposition of `mesh` (see `COACD_PARAMS`), as closed convex hulls."""
    coacd.set_log_level("error")
    try:
        parts = coacd.run_coacd(
            coacd.Mesh(np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.faces, dtype=int)),
            **COACD_PARAMS,
        )
    except Exception as exc:  # CoACD's C++ errors surface as RuntimeError or worse
        raise TangleDrakeError(
            f"convex decomposition of {path} failed ({exc}); check the mesh in a mesh viewer"
        ) from exc
    pieces = []
    for vertices, _ in parts:
        points = np.asarray(vertices, dtype=float)
        if len(points) < 4:
            continue
        try:
            hull = trimesh.convex.convex_hull(points)
        except Exception:  # qhull fails on coplanar points: a sliver, nothing to collide with
            continue
        if hull.volume > _MIN_PIECE_VOLUME:
            pieces.append(hull)
    if not pieces:
        raise TangleDrakeError(
            f"mesh file {path} encloses no volume (a flat or open surface?); "
            "give a solid part's surface"
        )
    return pieces

