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

