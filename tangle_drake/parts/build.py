"""Writing a part's files (SDF, visual OBJ, collision OBJs) into one cache entry directory.

Both builders move the body origin to the part's centre of mass, keeping the axes of the
skeleton or mesh file, and return the metadata the cache stores next to the files.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from tangle_drake.parts import wire
from tangle_drake.parts.mass import MassProperties, mass_properties, voxel_mass_properties
from tangle_drake.parts.obj_file import write_obj
from tangle_drake.parts.sdf import BODY_NAME, write_part_sdf

SDF_FILE = "model.sdf"
VISUAL_FILE = "visual.obj"
# Added to the bounding radius so it still encloses the vertices as rounded in the OBJ files.
_ROUNDING_MARGIN = 1e-6

# Where a part's mass properties came from: its closed surface; for a mesh that is no clean
# volume after repair (edges shared by three faces, say), a voxel fill of the solid it bounds;
# if even that finds no inside, its convex collision pieces (CoACD's exceed a bent wire's
# volume by up to a third). Never the mesh's convex hull, which weighs a bent wire several
# times its mass, and the closed loop weighs what it lifts.
MASS_FROM_MESH = "mesh"
MASS_FROM_VOXELS = "voxel_fill"
MASS_FROM_PIECES = "convex_pieces"


def _meta(
    name: str,
    props: MassProperties,
    bounding_radius: float,
    pieces: int,
    mass_from: str = MASS_FROM_MESH,
    holes_capped: int = 0,
) -> dict[str, Any]:
    return {
        "name": name,
        "body_name": BODY_NAME,
        "sdf": SDF_FILE,
        "visual": VISUAL_FILE,
        "mass": props.mass,
        "com": [0.0, 0.0, 0.0],
        "inertia": props.inertia.tolist(),
        "bounding_radius": bounding_radius + _ROUNDING_MARGIN,
        "num_collision_pieces": pieces,
        "mass_from": mass_from,
        "holes_capped": holes_capped,
    }


def wire_body(spec: wire.WireSpec, density: float
              ) -> tuple[trimesh.Trimesh, MassProperties, list[wire.CapsuleSpec]]:
    """A wire part in its body frame (origin at the tube's centre of mass): the tube, its
    mass properties (about the tube's centre of mass) and the capsules along the skeleton."""
    tube = wire.tube_mesh(spec)
    props = mass_properties(tube, density)
    tube.apply_translation(-props.com)
    capsules = [wire.CapsuleSpec(c.start - props.com, c.end - props.com, c.radius)
                for c in wire.capsules(spec)]
    return tube, props, capsules


def build_wire_part(
    directory: Path,
    name: str,
    spec: wire.WireSpec,
    color: tuple[float, float, float, float],
    density: float,
) -> dict[str, Any]:
    """Capsule collisions along the skeleton, one tube visual, mass from the tube."""
    tube, props, capsules = wire_body(spec, density)
    body_props = MassProperties(props.mass, np.zeros(3), props.inertia)
    write_obj(directory / VISUAL_FILE, tube)
    write_part_sdf(directory / SDF_FILE, name, body_props, VISUAL_FILE, color, capsules=capsules)
    radius = max(
        float(np.linalg.norm(tube.vertices, axis=1).max()),
        max(max(np.linalg.norm(c.start), np.linalg.norm(c.end)) + c.radius for c in capsules),
    )
    return _meta(name, body_props, radius, len(capsules))


def build_mesh_part(
    directory: Path,
    name: str,
    mesh: trimesh.Trimesh,
    pieces: list[trimesh.Trimesh],
    color: tuple[float, float, float, float],
    density: float,
    holes_capped: int,
) -> dict[str, Any]:
    """Convex-piece collisions, the mesh itself as visual; mass from the mesh (see
    ``MASS_FROM_MESH`` for one that is no clean volume)."""
    mass_from, props = MASS_FROM_MESH, None
    if mesh.is_volume:
        props = mass_properties(mesh, density)
    elif (props := voxel_mass_properties(mesh, density)) is not None:
        mass_from = MASS_FROM_VOXELS
    else:
        mass_from = MASS_FROM_PIECES
        props = mass_properties(trimesh.util.concatenate(pieces), density)
    shift = -props.com
    mesh = mesh.copy()
    mesh.apply_translation(shift)
    uris = []
    radius = float(np.linalg.norm(mesh.vertices, axis=1).max())
    for k, piece in enumerate(pieces):
        piece = piece.copy()
        piece.apply_translation(shift)
        uri = f"collision_{k:02d}.obj"
        write_obj(directory / uri, piece)
        uris.append(uri)
        radius = max(radius, float(np.linalg.norm(piece.vertices, axis=1).max()))
    body_props = MassProperties(props.mass, np.zeros(3), props.inertia)
    write_obj(directory / VISUAL_FILE, mesh)
    write_part_sdf(directory / SDF_FILE, name, body_props, VISUAL_FILE, color, convex_uris=uris)
    return _meta(name, body_props, radius, len(pieces), mass_from, holes_capped)
