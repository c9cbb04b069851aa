"""Writing meshes as Wavefront OBJ with vertex normals, the form Drake reads for meshes.

Written by hand rather than through trimesh's exporter so the bytes depend only on the mesh
(no library version in a header), which keeps cache entries byte-identical across runs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh


def write_obj(path: Path, mesh: trimesh.Trimesh) -> None:
    """Write `mesh` with one normal per vertex (``f a//a b//b c//c``)."""
    normals = np.asarray(mesh.vertex_normals)
    lines = [f"v {x:.7f} {y:.7f} {z:.7f}" for x, y, z in np.asarray(mesh.vertices)]
    lines += [f"vn {x:.6f} {y:.6f} {z:.6f}" for x, y, z in normals]
    lines += [f"f {a}//{a} {b}//{b} {c}//{c}" for a, b, c in np.asarray(mesh.faces) + 1]
    path.write_text("\n".join(lines) + "\n", encoding="ascii")
