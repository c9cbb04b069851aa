"""Mass properties of a closed triangle mesh of uniform density."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh


@dataclass(frozen=True)
class MassProperties:
    """Mass (kg), centre of mass (m) and rotational inertia about the COM (kg m^2), body frame."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


def mass_properties(mesh: trimesh.Trimesh, density: float) -> MassProperties:
    """Integrate `mesh` (closed, outward normals; disjoint closed pieces add up) at `density`."""
    props = trimesh.triangles.mass_properties(mesh.triangles, density=density)
    return MassProperties(
        mass=float(props["mass"]),
        com=np.asarray(props["center_mass"], dtype=float),
        inertia=np.asarray(props["inertia"], dtype=float),
    )



VOXEL_CELLS = 200_000
"""Grid cells over the mesh's bounding box for :func:`voxel_mass_properties`: sub-millimetre
cells for a hook of a few centimetres, fine enough for a wire part's volume and inertia, and
cheap enough to run once per mesh."""


def voxel_mass_properties(mesh: trimesh.Trimesh, density: float,
                          cells: int = VOXEL_CELLS) -> MassProperties | None:
    """Mass properties of the solid a surface that is closed but not a clean volume bounds
    (edges shared by three faces, say), from a voxel fill: cells inside count whole, cells the
    surface passes through half (the surface cuts them about in two, so the estimate has no
    bias of a shell's thickness). ``None`` if the fill finds no inside (the surface is open)."""
    pitch = float((np.prod(np.maximum(mesh.extents, 1e-12)) / cells) ** (1 / 3))
    shell = mesh.voxelized(pitch)
    solid = shell.copy().fill()
    surface = shell.matrix
    inside = solid.matrix & ~surface
    if not inside.any():
        return None
    weights = inside.astype(float) + 0.5 * surface  # in cells
    index = np.argwhere(weights > 0)
    w = weights[tuple(index.T)] * density * pitch ** 3
    centres = trimesh.transform_points(index.astype(float), shell.transform)
    mass = float(w.sum())
    com = (w[:, None] * centres).sum(axis=0) / mass
    r = centres - com
    inertia = np.eye(3) * (w * (r ** 2).sum(axis=1)).sum() - (w[:, None, None] * (
        r[:, :, None] * r[:, None, :])).sum(axis=0)
    inertia += np.eye(3) * mass * pitch ** 2 / 6  # each cell's own inertia, a cube's
    return MassProperties(mass, com, inertia)
